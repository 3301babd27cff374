// Costs on the front's per-frame path: image undistortion (cached maps) and
// point undistortion of ~1000 keypoints, EuRoC cam0 model.
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>

#include "common/camera.h"

namespace rumi {
namespace {

PinholeCamera EurocCamera() {
  PinholeCameraOptions o;
  o.width = 752, o.height = 480;
  o.fx = 458.654, o.fy = 457.296, o.cx = 367.215, o.cy = 248.375;
  o.k1 = -0.28340811, o.k2 = 0.07395907, o.p1 = 0.00019359, o.p2 = 1.76187114e-05;
  return PinholeCamera(o);
}

void BM_UndistortImage(benchmark::State& state) {
  const PinholeCamera cam = EurocCamera();
  cv::Mat img(480, 752, CV_8U);
  cv::randu(img, 0, 255);
  cam.UndistortImage(img);  // builds the maps once
  for (auto _ : state) benchmark::DoNotOptimize(cam.UndistortImage(img).data);
}
BENCHMARK(BM_UndistortImage)->Unit(benchmark::kMillisecond);

void BM_UndistortPoints1000(benchmark::State& state) {
  const PinholeCamera cam = EurocCamera();
  std::vector<Eigen::Vector2d> px;
  cv::RNG rng(1);
  for (int i = 0; i < 1000; ++i) px.emplace_back(rng.uniform(0.0, 752.0), rng.uniform(0.0, 480.0));
  for (auto _ : state) benchmark::DoNotOptimize(cam.UndistortPoints(px).data());
}
BENCHMARK(BM_UndistortPoints1000)->Unit(benchmark::kMicrosecond);

void BM_Project(benchmark::State& state) {
  const PinholeCamera cam = EurocCamera();
  Eigen::Vector3d p(0.3, -0.2, 2.0);
  Eigen::Vector2d px;
  for (auto _ : state) {
    benchmark::DoNotOptimize(cam.Project(p, &px));
    benchmark::DoNotOptimize(px);
  }
}
BENCHMARK(BM_Project);

}  // namespace
}  // namespace rumi
BENCHMARK_MAIN();
