// One real COLMAP run (labelled "colmap"; exclude with `ctest -LE colmap`):
// 8 TUM fr3 office frames at 320x240 through BackSubmapBuilder, checked
// against ground truth and for pixel-convention consistency.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/testing/require.h"
#include "common/testing/temp_dir.h"
#include "back/back_submap_builder.h"
#include "back/window_dir.h"
#include "common/geometry.h"

namespace rumi {
namespace {

TEST(BackColmapRunTest, TumOfficeEightFrames) {
  const std::string data = std::string(RUMI_SHARED_DATA_DIR) + "/tum_fr3_office_sparse17";
  RUMI_REQUIRE(std::filesystem::exists(data + "/rgb.txt"), "no " << data);
  RUMI_REQUIRE(std::system("colmap help > /dev/null 2>&1") == 0, "no colmap on PATH");

  PinholeCameraOptions cam;
  cam.width = 640;
  cam.height = 480;
  cam.fx = 535.4;
  cam.fy = 539.2;
  cam.cx = 320.1;
  cam.cy = 247.6;
  WindowDirOptions wd;
  wd.count = 8;
  wd.scale = 0.5;
  ImageWindow window;
  std::string err;
  ASSERT_TRUE(ReadWindowDir(data, cam, wd, 3, &window, &err)) << err;
  ASSERT_EQ(window.frames.size(), 8u);
  ASSERT_EQ(window.camera.width, 320);

  BackOptions o;
  o.num_threads = 1;
  o.max_num_features = 1024;
  const TempDir workspace;
  o.workspace_dir = workspace.str();
  BackSubmapBuilder builder(o);
  const BackResult r = builder.Build(window);
  std::printf("colmap steps: extract %.2f s, match %.2f s, map %.2f s, total %.2f s\n",
              r.times.feature_extraction_s, r.times.matching_s, r.times.mapping_s, r.times.total_s);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  // Matched through matches_importer with the selected pairs: 8 lost frames
  // (no sets in the index) are all within lost_overlap of each other.
  EXPECT_EQ(o.matcher, "pairs");
  EXPECT_EQ(r.matched_pairs, 28);
  ASSERT_EQ(r.submaps.size(), 1u);
  const Submap& s = r.submaps[0];
  EXPECT_GE(s.keyframes.size(), 7u);
  EXPECT_LT(r.stats[0].mean_reprojection_error_px, 1.5);
  EXPECT_GT(r.stats[0].num_points, 50);
  EXPECT_TRUE(std::filesystem::is_empty(o.workspace_dir));

  // Timestamps are exactly the window's.
  for (const Keyframe& kf : s.keyframes) {
    bool found = false;
    for (const WindowFrame& f : window.frames) found |= f.timestamp == kf.timestamp;
    EXPECT_TRUE(found) << kf.timestamp;
  }

  // Observations reproject onto their keypoints with rumi's K and T_cw, with
  // no systematic offset (a missed half-pixel shift on one side shows as a
  // mean residual of ~0.5 px).
  double sum_x = 0, sum_y = 0, sum_sq = 0;
  int n = 0;
  for (const MapPoint& p : s.points) {
    for (const auto& ob : p.observations) {
      const Keyframe& kf = s.keyframes.at(static_cast<size_t>(ob.keyframe_id));
      const Eigen::Vector3d pc = kf.T_cw * p.position;
      ASSERT_GT(pc.z(), 0);
      const Eigen::Vector2f kp = kf.keypoints.at(static_cast<size_t>(ob.keypoint_index));
      const double dx = s.camera.fx * pc.x() / pc.z() + s.camera.cx - kp.x();
      const double dy = s.camera.fy * pc.y() / pc.z() + s.camera.cy - kp.y();
      sum_x += dx;
      sum_y += dy;
      sum_sq += dx * dx + dy * dy;
      ++n;
    }
  }
  ASSERT_GT(n, 100);
  EXPECT_LT(std::abs(sum_x / n), 0.1);
  EXPECT_LT(std::abs(sum_y / n), 0.1);
  EXPECT_LT(std::sqrt(sum_sq / n), 2.0);

  // Poses against ground truth after Sim(3) Umeyama on the camera centres
  // (path ~0.5 m here). Kept free of the evaluation library on purpose.
  std::vector<std::pair<Timestamp, Se3>> gt;
  {
    std::ifstream in(data + "/groundtruth.txt");
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream ls(line);
      std::string ts;
      double v[7];
      Timestamp t;
      if (ls >> ts >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5] >> v[6] && ParseSecondsToNs(ts, &t))
        gt.emplace_back(t, Se3::FromTumXyzw({v[0], v[1], v[2]}, v[3], v[4], v[5], v[6]));
    }
  }
  ASSERT_GT(gt.size(), 100u);
  std::vector<Eigen::Vector3d> src, dst;
  std::vector<std::pair<Se3, Se3>> pose_pairs;  // (estimate T_wc, ground truth T_wc)
  for (const Keyframe& kf : s.keyframes) {
    const auto* best = &gt.front();
    for (const auto& g : gt)
      if (std::llabs(g.first - kf.timestamp) < std::llabs(best->first - kf.timestamp)) best = &g;
    if (std::llabs(best->first - kf.timestamp) > SecondsToNs(0.02)) continue;
    src.push_back(kf.T_wc().translation());
    dst.push_back(best->second.translation());
    pose_pairs.emplace_back(kf.T_wc(), best->second);
  }
  ASSERT_GE(src.size(), 6u);
  const UmeyamaResult u = UmeyamaAlign(src, dst, true);
  ASSERT_TRUE(u.ok);
  std::printf("ATE %.4f m over %zu poses\n", u.rmse, src.size());
  EXPECT_LT(u.rmse, 0.03);
  // Orientations agree too once aligned (fails on an inverted pose).
  for (const auto& [est, ref] : pose_pairs) {
    const Eigen::Quaterniond q_est_in_gt = u.transform.rotation() * est.rotation();
    EXPECT_LT(RotationAngle(ref.rotation().inverse() * q_est_in_gt) * 180.0 / M_PI, 3.0);
  }
}

}  // namespace
}  // namespace rumi
