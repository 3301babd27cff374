#include "manager/sim3_refine.h"

#include <gtest/gtest.h>

#include <random>
#include <unordered_map>

#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {

using testing::Sim3RotationError;

// True M_com between A and the back submap (same scene point) plus 10 %
// wrong pairs.
std::vector<PointMatch> TrueMatchesWithOutliers(const testing::Scenario& s, double outlier_ratio) {
  std::unordered_map<int, int64_t> back_of_scene;
  for (size_t i = 0; i < s.back.submap.points.size(); ++i)
    back_of_scene[s.back.scene_point[i]] = s.back.submap.points[i].id;
  std::vector<PointMatch> m;
  for (size_t i = 0; i < s.front_a.submap.points.size(); ++i) {
    const auto it = back_of_scene.find(s.front_a.scene_point[i]);
    if (it != back_of_scene.end()) m.push_back({s.front_a.submap.points[i].id, it->second, 1});
  }
  std::mt19937 rng(8);
  std::uniform_int_distribution<size_t> pick(0, s.back.submap.points.size() - 1);
  const size_t n_out = size_t(outlier_ratio * m.size());
  for (size_t k = 0; k < n_out; ++k) m[k * m.size() / n_out].back_point_id = s.back.submap.points[pick(rng)].id;
  return m;
}

void ExpectRecovers(const std::string& loss) {
  const auto s = testing::MakeScenario(3, 1.0, 1200, /*pose_noise=*/false);
  const Sim3 truth = s.S_bw * s.S_aw.Inverse();
  const auto matches = TrueMatchesWithOutliers(s, 0.1);
  ASSERT_GT(matches.size(), 200u);
  // Initial guess off by 3 degrees, 8 % scale and a shift.
  const Sim3 delta(1.08, Eigen::Quaterniond(Eigen::AngleAxisd(0.05, Eigen::Vector3d(1, 2, 3).normalized())),
                   Eigen::Vector3d(0.1, -0.05, 0.08) * s.S_bw.scale());
  const Sim3 initial = delta * truth;
  ManagerOptions o;
  o.robust_loss = loss;
  const auto r = RefineSim3(s.front_a.submap, s.back.submap, matches, nullptr, initial, o);
  ASSERT_TRUE(r.ok) << r.message;
  const double rot0 = Sim3RotationError(initial, truth), rot1 = Sim3RotationError(r.S_bf, truth);
  const double sc0 = std::abs(initial.scale() / truth.scale() - 1), sc1 = std::abs(r.S_bf.scale() / truth.scale() - 1);
  EXPECT_LT(rot1, 0.1 * rot0);
  EXPECT_LT(sc1, 0.1 * sc0);
  EXPECT_LT(rot1, 0.003);  // < 0.17 deg
  EXPECT_LT(sc1, 0.005);
  // Compare a camera-scale translation: map the back frame origin region.
  const Eigen::Vector3d p = s.front_a.submap.points[10].position;
  EXPECT_LT((r.S_bf * p - truth * p).norm(), 0.01 * s.S_bw.scale());
  EXPECT_LT(r.final_rmse_px, 2.0);  // 1 px noise per axis ~ 1.4 px
  EXPECT_LT(r.final_rmse_px, r.initial_rmse_px);
  // The gate drops the wrong pairs' observations (about 10 %).
  EXPECT_LT(r.num_inlier_residuals, r.num_residuals);
  EXPECT_GT(r.num_inlier_residuals, int(0.8 * r.num_residuals));
}

TEST(RefineSim3, RecoversKnownSim3Huber) { ExpectRecovers("huber"); }
TEST(RefineSim3, RecoversKnownSim3Cauchy) { ExpectRecovers("cauchy"); }

TEST(RefineSim3, TruthFitsWithoutPixelNoise) {
  // At the true Sim(3) both residual directions fit (only 3D point noise is
  // left): a swapped direction or inverse in either residual fails here.
  const auto s = testing::MakeScenario(3, 0.0, 1200, /*pose_noise=*/false);
  const Sim3 truth = s.S_bw * s.S_aw.Inverse();
  const auto matches = TrueMatchesWithOutliers(s, 0.0);
  ManagerOptions o;
  const auto r = RefineSim3(s.front_a.submap, s.back.submap, matches, nullptr, truth, o);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_LT(r.initial_rmse_px, 3.0);  // only 3D point noise left
  EXPECT_LT(Sim3RotationError(r.S_bf, truth), 0.003);
}

}  // namespace
}  // namespace rumi
