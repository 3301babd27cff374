#include "manager/sim3_alignment.h"

#include <gtest/gtest.h>

#include <random>

#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {

using testing::Sim3RotationError;

TEST(RansacSim3, SurvivesThirtyPercentOutliers) {
  const Sim3 S = RandomSim3(5);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-3, 3);
  std::normal_distribution<double> n(0, 0.005);
  std::vector<Eigen::Vector3d> src, dst;
  std::vector<char> truth;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    src.push_back(p);
    const bool outlier = i % 10 < 3;
    dst.push_back(outlier ? Eigen::Vector3d(S * Eigen::Vector3d(u(rng), u(rng), u(rng)))
                          : Eigen::Vector3d(S * p + S.scale() * Eigen::Vector3d(n(rng), n(rng), n(rng))));
    truth.push_back(!outlier);
  }
  const auto r = RansacSim3(src, dst, 0.1 * S.scale(), 200, 9);
  ASSERT_TRUE(r.ok);
  EXPECT_NEAR(r.transform.scale() / S.scale(), 1.0, 0.01);
  EXPECT_LT(Sim3RotationError(r.transform, S), 0.01);
  EXPECT_LT((r.transform.translation() - S.translation()).norm(), 0.05 * S.scale());
  int agree = 0;
  for (size_t i = 0; i < truth.size(); ++i) agree += r.inliers[i] == truth[i];
  EXPECT_GT(agree, 290);
  // A plain least-squares fit on all points is visibly off: RANSAC matters.
  const auto ls = UmeyamaAlign(src, dst, true);
  EXPECT_GT(std::abs(ls.transform.scale() / S.scale() - 1.0), 0.05);
}

TEST(RansacSim3, SeededIsDeterministic) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Eigen::Vector3d> src, dst;
  for (int i = 0; i < 50; ++i) {
    src.emplace_back(u(rng), u(rng), u(rng));
    dst.emplace_back(u(rng), u(rng), u(rng));
  }
  const auto a = RansacSim3(src, dst, 0.2, 50, 3), b = RansacSim3(src, dst, 0.2, 50, 3);
  EXPECT_EQ(a.num_inliers, b.num_inliers);
  EXPECT_EQ(a.transform.Matrix(), b.transform.Matrix());
}

struct Prepared {
  testing::Scenario s;
  std::vector<KeyframePair> pairs;
  CommonPoints common;
};

Prepared Prepare(bool pose_noise = true) {
  Prepared p;
  p.s = testing::MakeScenario(3, 1.0, 1200, pose_noise);
  const SearchSet set = BuildSearchSet({&p.s.front_a.submap}, {&p.s.back.submap}, 10);
  p.pairs = PairKeyframes(p.s.front_a.submap, p.s.back.submap, set, 100000);
  p.common = FindCommonPoints(p.s.front_a.submap, p.s.back.submap, p.pairs, 3.0);
  return p;
}

TEST(AlignSubmaps, RecoversScenarioSim3) {
  const Prepared p = Prepare();
  const Sim3 truth = p.s.S_bw * p.s.S_aw.Inverse();  // A frame -> back frame
  const auto r = AlignSubmaps(p.s.front_a.submap, p.s.back.submap, p.pairs, p.common, ManagerOptions());
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_EQ(r.num_keyframe_pairs, 5);
  EXPECT_GT(r.inlier_ratio, 0.8);
  EXPECT_NEAR(r.S_bf.scale() / truth.scale(), 1.0, 0.02);
  EXPECT_LT(Sim3RotationError(r.S_bf, truth), 0.02);
  // Five paired centres 0.8 m apart with 1 cm noise: a poor Umeyama
  // candidate, RANSAC over the points wins.
  EXPECT_EQ(r.method, "ransac-points");
  EXPECT_GT(r.ransac_inlier_ratio, r.umeyama_inlier_ratio);
  // A point of A lands near its back partner.
  const Eigen::Vector3d pa = p.s.front_a.submap.points[0].position;
  const Eigen::Vector3d expected = truth * pa;
  EXPECT_LT((r.S_bf * pa - expected).norm(), 0.05 * truth.scale() * p.s.S_aw.scale() + 0.05 * p.s.S_bw.scale());
}

TEST(AlignSubmaps, UmeyamaOnExactKeyframeCentres) {
  const Prepared p = Prepare(/*pose_noise=*/false);
  const Sim3 truth = p.s.S_bw * p.s.S_aw.Inverse();
  const auto r = AlignSubmaps(p.s.front_a.submap, p.s.back.submap, p.pairs, p.common, ManagerOptions());
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_GT(r.umeyama_inlier_ratio, 0.8);
  EXPECT_NEAR(r.S_bf.scale() / truth.scale(), 1.0, 0.01);
  EXPECT_LT(Sim3RotationError(r.S_bf, truth), 0.01);
}

TEST(AlignSubmaps, RejectsRandomCorrespondences) {
  Prepared p = Prepare();
  // Shuffle the back side of M_com: geometrically meaningless pairs.
  std::mt19937 rng(4);
  std::vector<int64_t> back_ids;
  for (const auto& m : p.common.matches) back_ids.push_back(m.back_point_id);
  std::shuffle(back_ids.begin(), back_ids.end(), rng);
  for (size_t i = 0; i < back_ids.size(); ++i) p.common.matches[i].back_point_id = back_ids[i];
  // Without keyframe pairs the centre candidate is gone as well; give it
  // fake pairs whose centres are inconsistent.
  std::vector<KeyframePair> fake = {{0, 40, 0}, {20, 2, 0}, {3, 25, 0}, {10, 10, 0}};
  const auto r = AlignSubmaps(p.s.front_a.submap, p.s.back.submap, fake, p.common, ManagerOptions());
  EXPECT_FALSE(r.ok);
  EXPECT_LE(r.inlier_ratio, 0.1);
  EXPECT_NE(r.reason.find("inlier ratio"), std::string::npos) << r.reason;
}

TEST(AlignSubmaps, RejectsTooFewPairsOrPoints) {
  const Prepared p = Prepare();
  ManagerOptions o;
  auto r = AlignSubmaps(p.s.front_a.submap, p.s.back.submap, {}, p.common, o);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.reason.find("keyframe pairs"), std::string::npos) << r.reason;
  CommonPoints few = p.common;
  few.matches.resize(5);
  r = AlignSubmaps(p.s.front_a.submap, p.s.back.submap, p.pairs, few, o);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.reason.find("common points"), std::string::npos) << r.reason;
}

}  // namespace
}  // namespace rumi
