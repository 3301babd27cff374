// Per-frame hot paths of the front on a real KITTI frame: ORB extraction and
// the pose-only Gauss-Newton. Run: build/front/front_benchmark (or bin/).
#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <random>

#include "front/map.h"
#include "front/optimizer.h"
#include "common/orb_extractor.h"

namespace rumi {
namespace {

cv::Mat KittiFrame() {
  static cv::Mat img = cv::imread(std::string(RUMI_SHARED_DATA_DIR) + "/kitti03_first400/rgb/000100.png",
                                  cv::IMREAD_GRAYSCALE);
  return img;
}

void BM_OrbExtract(benchmark::State& state) {
  cv::setNumThreads(1);
  const cv::Mat img = KittiFrame();
  if (img.empty()) {
    state.SkipWithError("KITTI frame not found");
    return;
  }
  OrbExtractorOptions o;
  o.num_features = static_cast<int>(state.range(0));
  OrbExtractor ex(o);
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  for (auto _ : state) {
    ex.Extract(img, &kps, &desc);
    benchmark::DoNotOptimize(kps.data());
  }
  state.counters["keypoints"] = static_cast<double>(kps.size());
}
BENCHMARK(BM_OrbExtract)->Arg(1000)->Arg(2000)->Unit(benchmark::kMillisecond);

void BM_OptimizePose(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  PinholeCameraOptions co;
  co.fx = co.fy = 500;
  co.cx = 320;
  co.cy = 240;
  const PinholeCamera cam(co);
  const ScalePyramid pyr(8, 1.2);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-2, 2), z(3, 10);
  std::normal_distribution<double> noise(0, 1);
  auto f = std::make_shared<Features>();
  std::vector<std::unique_ptr<Landmark>> pts;
  const Se3 truth(Eigen::Quaterniond(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY())), Eigen::Vector3d(0.2, 0, 0.1));
  for (int i = 0; i < n; ++i) {
    auto p = std::make_unique<Landmark>();
    p->pos = Eigen::Vector3d(u(rng), u(rng), z(rng));
    const Eigen::Vector2d px = ProjectUndistorted(cam, truth * p->pos) + Eigen::Vector2d(noise(rng), noise(rng));
    f->un.push_back(px);
    cv::KeyPoint k;
    k.octave = 0;
    f->keypoints.push_back(k);
    pts.push_back(std::move(p));
  }
  TrackFrame fr;
  fr.f = f;
  for (auto _ : state) {
    fr.Reset(n);
    for (int i = 0; i < n; ++i) fr.points[i] = pts[i].get();
    fr.T_cw = Se3();
    benchmark::DoNotOptimize(OptimizePose(&fr, cam, pyr));
  }
}
BENCHMARK(BM_OptimizePose)->Arg(300)->Arg(1000)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace rumi

BENCHMARK_MAIN();
