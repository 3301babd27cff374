#include "common/trajectory_eval.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

namespace rumi {
namespace {

const std::string kEvo = std::string(RUMI_SHARED_DATA_DIR) + "/eval-reference/evo/";

// Relative agreement with evo's printed values; prints the figures.
void ExpectRel(double value, double reference, double rel = 1e-6) {
  EXPECT_NEAR(value, reference, rel * std::abs(reference)) << "reference " << reference;
  std::printf("  rumi %.17g evo %.17g rel.diff %.3g\n", value, reference,
              std::abs(value - reference) / std::abs(reference));
}

// ---- evo reference values (../shared/data/README.md and evo/res_files) -----

TEST(AteEvoReference, Kitti00OrbSe3) {
  const Trajectory est = ReadKittiTrajectory(kEvo + "KITTI_00_ORB.txt");
  const Trajectory gt = ReadKittiTrajectory(kEvo + "KITTI_00_gt.txt");
  AteOptions o;
  o.alignment = Alignment::kSe3;
  o.match_by_index = true;
  const AteResult r = ComputeAte(est, gt, o);
  EXPECT_EQ(r.pairs.size(), 4541u);
  ExpectRel(r.translation.rmse, 1.3034497145650266);
  // The rest of evo's stats.json (res_files/orb_ape.zip).
  ExpectRel(r.translation.mean, 1.1569971285389768);
  ExpectRel(r.translation.median, 1.065624769555848);
  ExpectRel(r.translation.std, 0.6002822693968323);
  ExpectRel(r.translation.min, 0.06931322021483087);
  ExpectRel(r.translation.max, 3.587949120678954);
  ExpectRel(r.translation.sse, 7715.073440292808);
  EXPECT_DOUBLE_EQ(r.S_gt_est.scale(), 1.0);

  // Index timestamps (i s) associate one-to-one by time as well.
  o.match_by_index = false;
  const AteResult by_time = ComputeAte(est, gt, o);
  EXPECT_EQ(by_time.pairs.size(), 4541u);
  EXPECT_DOUBLE_EQ(by_time.translation.rmse, r.translation.rmse);
}

TEST(AteEvoReference, Kitti00SptamSe3) {
  const Trajectory est = ReadKittiTrajectory(kEvo + "KITTI_00_SPTAM.txt");
  const Trajectory gt = ReadKittiTrajectory(kEvo + "KITTI_00_gt.txt");
  AteOptions o;
  o.alignment = Alignment::kSe3;
  o.match_by_index = true;
  const AteResult r = ComputeAte(est, gt, o);
  EXPECT_EQ(r.pairs.size(), 4541u);
  // res_files/sptam_ape.zip stats.json
  ExpectRel(r.translation.rmse, 3.738487907582613);
  ExpectRel(r.translation.mean, 3.4909766330848684);
  ExpectRel(r.translation.median, 3.6425846417432637);
  ExpectRel(r.translation.std, 1.3376748418045645);
  ExpectRel(r.translation.min, 0.694787347406252);
  ExpectRel(r.translation.max, 7.7689774065713175);
}

TEST(AteEvoReference, Freiburg1XyzOrbKfMonoSim3) {
  const Trajectory est = ReadTumTrajectory(kEvo + "freiburg1_xyz-ORB_kf_mono.txt");
  const Trajectory gt = ReadTumTrajectory(kEvo + "freiburg1_xyz-groundtruth.txt");
  AteOptions o;
  o.alignment = Alignment::kSim3;
  const AteResult r = ComputeAte(est, gt, o);
  EXPECT_EQ(r.pairs.size(), 32u);
  ExpectRel(r.translation.rmse, 0.009754581898685104);
  EXPECT_LE(r.max_abs_dt_s, 0.02);
  // Monocular: the recovered scale is far from 1, SE3 must be much worse.
  o.alignment = Alignment::kSe3;
  EXPECT_GT(ComputeAte(est, gt, o).translation.rmse, 2 * r.translation.rmse);
}

TEST(AteEvoReference, Freiburg1XyzRgbdslamNoAlignment) {
  const Trajectory est = ReadTumTrajectory(kEvo + "freiburg1_xyz-rgbdslam.txt");
  const Trajectory gt = ReadTumTrajectory(kEvo + "freiburg1_xyz-groundtruth.txt");
  AteOptions o;
  o.alignment = Alignment::kNone;
  const AteResult r = ComputeAte(est, gt, o);
  EXPECT_EQ(r.pairs.size(), 786u);
  ExpectRel(r.translation.rmse, 0.020077667181419186);
  EXPECT_TRUE(r.S_gt_est.Matrix().isIdentity(0.0));
  // evo's own (possibly many-to-one) pairing gives the same pairs here.
  o.association.one_to_one = false;
  EXPECT_EQ(ComputeAte(est, gt, o).pairs.size(), 786u);
}

// ---- synthetic checks that catch convention mistakes ----------------------

// A curvy 3-D ground-truth path at 100 Hz with rotating orientation.
Trajectory MakeGroundTruth(size_t n, Timestamp t0 = 1305031102LL * kNsPerSecond,
                           Timestamp dt = 10000000) {
  Trajectory gt;
  for (size_t i = 0; i < n; ++i) {
    const double s = 0.01 * static_cast<double>(i);
    StampedPose p;
    p.t = t0 + static_cast<Timestamp>(i) * dt;
    const Eigen::Vector3d pos(std::cos(s) * 2.0, std::sin(1.3 * s), 0.3 * s + 0.2 * std::sin(3 * s));
    const Eigen::Quaterniond q(Eigen::AngleAxisd(0.7 * s, Eigen::Vector3d(0.2, 1, 0.3).normalized()));
    p.T_wc = Se3(q, pos);
    gt.push_back(p);
  }
  return gt;
}

Trajectory Transform(const Trajectory& traj, const Sim3& S) {
  Trajectory out = traj;
  for (StampedPose& p : out) p.T_wc = S.TransformPose(p.T_wc);
  return out;
}

Sim3 SomeSim3(double scale) {
  return Sim3(scale,
              Eigen::Quaterniond(Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -0.5, 0.8).normalized())),
              Eigen::Vector3d(4.0, -2.0, 0.5));
}

TEST(Ate, Sim3RecoversScaledCopyAndSe3DoesNot) {
  const Trajectory gt = MakeGroundTruth(300);
  // Estimate in a frame related to the GT by a Sim3 of scale 0.4.
  const Sim3 S_est_gt = SomeSim3(0.4);
  const Trajectory est = Transform(gt, S_est_gt);
  AteOptions o;
  o.alignment = Alignment::kSim3;
  const AteResult sim = ComputeAte(est, gt, o);
  EXPECT_EQ(sim.pairs.size(), 300u);
  EXPECT_LT(sim.translation.rmse, 1e-9);
  EXPECT_NEAR(sim.S_gt_est.scale(), 1.0 / 0.4, 1e-9);
  EXPECT_TRUE(sim.S_gt_est.Matrix().isApprox(S_est_gt.Inverse().Matrix(), 1e-9));
  EXPECT_LT(sim.rotation_deg.max, 1e-6);
  // Without scale the same data cannot be explained.
  o.alignment = Alignment::kSe3;
  const AteResult se3 = ComputeAte(est, gt, o);
  EXPECT_GT(se3.translation.rmse, 0.1);
  EXPECT_DOUBLE_EQ(se3.S_gt_est.scale(), 1.0);
  // No alignment: the raw offset shows up.
  o.alignment = Alignment::kNone;
  EXPECT_GT(ComputeAte(est, gt, o).translation.rmse, 1.0);
}

TEST(Ate, Se3AlignmentIsExactOnRigidCopy) {
  const Trajectory gt = MakeGroundTruth(200);
  const Trajectory est = Transform(gt, SomeSim3(1.0));
  AteOptions o;
  o.alignment = Alignment::kSe3;
  const AteResult r = ComputeAte(est, gt, o);
  EXPECT_LT(r.translation.rmse, 1e-9);
  EXPECT_LT(r.rotation_deg.max, 1e-6);
}

TEST(Ate, MirroredEstimateIsNotExplainedByAlignment) {
  // A sign error on one axis is a reflection: no Sim3 can undo it.
  const Trajectory gt = MakeGroundTruth(300);
  Trajectory est = gt;
  for (StampedPose& p : est) p.T_wc.translation().y() *= -1.0;
  AteOptions o;
  EXPECT_GT(ComputeAte(est, gt, o).translation.rmse, 0.05);
}

TEST(Ate, KnownErrorValues) {
  // Two-point-per-axis offsets with no alignment: errors are exactly known.
  Trajectory gt = MakeGroundTruth(4);
  Trajectory est = gt;
  const double offsets[4] = {0.0, 1.0, 2.0, 4.0};
  for (size_t i = 0; i < 4; ++i) est[i].T_wc.translation().z() += offsets[i];
  AteOptions o;
  o.alignment = Alignment::kNone;
  const AteResult r = ComputeAte(est, gt, o);
  ASSERT_EQ(r.translation.count, 4u);
  EXPECT_NEAR(r.translation.mean, 7.0 / 4.0, 1e-12);
  EXPECT_NEAR(r.translation.rmse, std::sqrt(21.0 / 4.0), 1e-12);
  EXPECT_NEAR(r.translation.median, 1.5, 1e-12);
  EXPECT_NEAR(r.translation.min, 0.0, 1e-12);
  EXPECT_NEAR(r.translation.max, 4.0, 1e-12);
  EXPECT_NEAR(r.translation.std, std::sqrt(21.0 / 4.0 - 49.0 / 16.0), 1e-12);
}

TEST(Ate, ErrorsAndDegenerateInputThrow) {
  const Trajectory gt = MakeGroundTruth(100);
  Trajectory far = gt;
  for (StampedPose& p : far) p.t += 100 * kNsPerSecond;
  EXPECT_THROW(ComputeAte(far, gt, AteOptions()), std::runtime_error);
  // Two pairs cannot define a Sim3.
  const Trajectory two(gt.begin(), gt.begin() + 2);
  EXPECT_THROW(ComputeAte(two, gt, AteOptions()), std::runtime_error);
  // Static estimate: degenerate.
  Trajectory still = gt;
  for (StampedPose& p : still) p.T_wc = Se3();
  EXPECT_THROW(ComputeAte(still, gt, AteOptions()), std::runtime_error);
  // Unsorted input.
  Trajectory unsorted = gt;
  std::swap(unsorted[3], unsorted[4]);
  EXPECT_THROW(ComputeAte(unsorted, gt, AteOptions()), std::runtime_error);
  AteOptions bad;
  bad.association.max_diff_s = -1;
  EXPECT_FALSE(bad.Check());
  EXPECT_THROW(ComputeAte(gt, gt, bad), std::invalid_argument);
}

TEST(Ate, StraightLineGroundTruthIsAlignedAlongTheLine) {
  // A slider (ECD slider_*): positions on a line, orientation fixed.
  Trajectory gt;
  for (int i = 0; i < 100; ++i) gt.push_back({1000 + i * 33'000'000LL, Se3(Eigen::Quaterniond::Identity(),
                                                                         Eigen::Vector3d(0.01 * i, 0, 0))});
  const Sim3 S_est_gt = SomeSim3(0.4);
  AteOptions o;
  const AteResult exact = ComputeAte(Transform(gt, S_est_gt), gt, o);
  EXPECT_TRUE(exact.line_alignment);
  EXPECT_LT(exact.translation.rmse, 1e-9);
  EXPECT_NEAR(exact.S_gt_est.scale(), 2.5, 1e-9);
  // The angle about the line comes from the orientations: all recovered.
  EXPECT_LT(exact.rotation_deg.max, 1e-6);
  EXPECT_TRUE(exact.S_gt_est.Matrix().isApprox(S_est_gt.Inverse().Matrix(), 1e-9));

  // 2 cm off the line on frames 40-59 (symmetric about the middle, so the
  // axis does not tilt; the centroid moves 4 mm): errors 16 mm there and
  // 4 mm elsewhere, rmse sqrt((20 * 16^2 + 80 * 4^2) / 100) = 8 mm.
  Trajectory bumped = gt;
  for (int i = 40; i < 60; ++i) bumped[i].T_wc.translation().y() += 0.02;
  const AteResult bump = ComputeAte(Transform(bumped, S_est_gt), gt, o);
  EXPECT_TRUE(bump.line_alignment);
  EXPECT_NEAR(bump.translation.rmse, 0.008, 1e-9);
  EXPECT_NEAR(bump.translation.max, 0.016, 1e-9);

  // Se3 cannot undo the scale of 0.4.
  o.alignment = Alignment::kSe3;
  const AteResult se3 = ComputeAte(Transform(gt, S_est_gt), gt, o);
  EXPECT_DOUBLE_EQ(se3.S_gt_est.scale(), 1.0);
  EXPECT_GT(se3.translation.rmse, 0.1);

  // A static estimate against the line, and two pairs, still throw.
  Trajectory still = gt;
  for (StampedPose& p : still) p.T_wc = Se3();
  EXPECT_THROW(ComputeAte(still, gt, AteOptions()), std::runtime_error);
  const Trajectory two(gt.begin(), gt.begin() + 2);
  EXPECT_THROW(ComputeAte(two, gt, AteOptions()), std::runtime_error);
  // Collinear estimate against ground truth that is not a line.
  EXPECT_THROW(ComputeAte(gt, MakeGroundTruth(100, 1000, 33'000'000), AteOptions()), std::runtime_error);
}

// ---- association -----------------------------------------------------------

TEST(Association, PairsEachEstimateWithNearestGroundTruth) {
  // GT at 100 Hz, estimate at ~33 Hz with +-3 ms jitter.
  const Trajectory gt = MakeGroundTruth(300);
  Trajectory est;
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> jitter(-3000000, 3000000);
  for (size_t i = 0; i < gt.size(); i += 3) {
    StampedPose p = gt[i];
    p.t += jitter(rng);
    est.push_back(p);
  }
  const std::vector<PosePair> pairs = AssociateByTimestamp(est, gt, AssociationOptions());
  ASSERT_EQ(pairs.size(), est.size());
  for (size_t k = 0; k < pairs.size(); ++k) {
    EXPECT_EQ(pairs[k].est, k);
    EXPECT_EQ(pairs[k].gt, 3 * k) << "off-by-one association at " << k;
  }
  // The estimate poses are the GT poses: any misassociation shows as error.
  AteOptions o;
  o.alignment = Alignment::kNone;
  EXPECT_LT(ComputeAte(est, gt, o).translation.max, 1e-12);
}

TEST(Association, SkippedFramesAreDroppedNotShifted) {
  const Trajectory gt = MakeGroundTruth(50);
  Trajectory est = gt;
  est.erase(est.begin() + 20);  // the estimate skipped a frame
  AssociationOptions a;
  a.max_diff_s = 0.004;  // less than half the 10 ms spacing
  std::vector<PosePair> pairs = AssociateByTimestamp(est, gt, a);
  ASSERT_EQ(pairs.size(), 49u);
  for (const PosePair& p : pairs) EXPECT_EQ(est[p.est].t, gt[p.gt].t);
  // A GT hole: the estimate pose without a partner is dropped.
  Trajectory gt_hole = gt;
  gt_hole.erase(gt_hole.begin() + 30);
  pairs = AssociateByTimestamp(gt, gt_hole, a);
  ASSERT_EQ(pairs.size(), 49u);
  for (const PosePair& p : pairs) EXPECT_EQ(gt[p.est].t, gt_hole[p.gt].t);
  AteOptions o;
  o.alignment = Alignment::kNone;
  EXPECT_LT(ComputeAte(est, gt, o).translation.max, 1e-12);
  // With index matching (KITTI) a skipped frame shifts everything after it.
  o.match_by_index = true;
  EXPECT_GT(ComputeAte(est, gt, o).translation.max, 1e-3);
}

TEST(Association, MaxDiffIsInclusiveAndExact) {
  Trajectory gt = MakeGroundTruth(3, 1000 * kNsPerSecond, kNsPerSecond);
  Trajectory est = gt;
  est[0].t += 20000000;  // exactly 0.02 s: kept
  est[1].t += 20000001;  // 1 ns beyond: dropped
  est[2].t -= 19999999;
  const std::vector<PosePair> pairs = AssociateByTimestamp(est, gt, AssociationOptions());
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0].est, 0u);
  EXPECT_EQ(pairs[1].est, 2u);
  EXPECT_EQ(pairs[1].gt, 2u);
}

TEST(Association, ShorterTrajectoryDrivesAsEvo) {
  // Estimate denser than GT: GT poses pick their nearest estimate pose.
  const Trajectory est = MakeGroundTruth(100, 0, 10000000);       // 100 Hz
  const Trajectory gt = MakeGroundTruth(10, 3000000, 100000000);  // 10 Hz, +3 ms
  for (bool one_to_one : {false, true}) {
    // Driven by the estimate, 4 estimate poses would fall within 20 ms of each
    // GT pose; evo (many-to-one allowed) keeps them all that way.
    AssociationOptions a;
    a.one_to_one = one_to_one;
    const std::vector<PosePair> pairs = AssociateByTimestamp(est, gt, a);
    ASSERT_EQ(pairs.size(), 10u);
    for (size_t k = 0; k < pairs.size(); ++k) {
      EXPECT_EQ(pairs[k].gt, k);
      EXPECT_EQ(pairs[k].est, 10 * k);
    }
  }
}

TEST(Association, OneToOneKeepsTheCloserOfTwoClaims) {
  // est 0 and est 1 (12 ms apart) both have gt 0 as nearest within 20 ms.
  Trajectory gt = MakeGroundTruth(3, 0, kNsPerSecond);
  Trajectory est = MakeGroundTruth(2, 5000000, 12000000);  // t = 5 ms, 17 ms
  AssociationOptions a;
  a.one_to_one = false;  // evo: both pair with gt 0
  std::vector<PosePair> pairs = AssociateByTimestamp(est, gt, a);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0].gt, 0u);
  EXPECT_EQ(pairs[1].gt, 0u);
  a.one_to_one = true;
  pairs = AssociateByTimestamp(est, gt, a);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].est, 0u);
  // Closer claim arriving second replaces the first.
  est[0].t = 0 - 15000000;
  est[1].t = 0 + 2000000;
  pairs = AssociateByTimestamp(est, gt, a);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].est, 1u);
}

TEST(Association, TieGoesToEarlierPose) {
  Trajectory gt = MakeGroundTruth(2, 0, 20000000);  // 0 and 20 ms
  Trajectory est = MakeGroundTruth(1, 10000000, 1);  // 10 ms: equidistant
  const std::vector<PosePair> pairs = AssociateByTimestamp(est, gt, AssociationOptions());
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].gt, 0u);
}

TEST(ErrorStats, EmptyAndOddMedian) {
  EXPECT_EQ(ComputeErrorStats({}).count, 0u);
  const ErrorStats s = ComputeErrorStats({5.0, 1.0, 3.0});
  EXPECT_DOUBLE_EQ(s.median, 3.0);
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 5.0);
  EXPECT_DOUBLE_EQ(s.sse, 35.0);
}

TEST(AteOptions, ReadFromConfig) {
  ConfigSection s = LoadConfigString("max_diff_s: 0.05\nalignment: se3\none_to_one: false\n");
  AteOptions o;
  ReadOptions(s, &o);
  s.Finish();
  EXPECT_DOUBLE_EQ(o.association.max_diff_s, 0.05);
  EXPECT_EQ(o.alignment, Alignment::kSe3);
  EXPECT_FALSE(o.association.one_to_one);
  ConfigSection bad = LoadConfigString("alignment: affine\n");
  EXPECT_THROW(ReadOptions(bad, &o), ConfigError);
  ConfigSection neg = LoadConfigString("max_diff_s: -1\n");
  EXPECT_THROW(ReadOptions(neg, &o), ConfigError);
  TrackingRateOptions t;
  ConfigSection ts = LoadConfigString("max_gap_factor: 5\nmatch_tolerance_s: 0.01\n");
  ReadOptions(ts, &t);
  ts.Finish();
  EXPECT_DOUBLE_EQ(t.max_gap_factor, 5.0);
  EXPECT_DOUBLE_EQ(t.match_tolerance_s, 0.01);
  ConfigSection tbad = LoadConfigString("max_gap_factor: 0.5\n");
  EXPECT_THROW(ReadOptions(tbad, &t), ConfigError);
}

// ---- tracking rate -----------------------------------------------------------

std::vector<Timestamp> Frames(size_t n, Timestamp dt = 100000000) {  // 10 Hz
  std::vector<Timestamp> f(n);
  for (size_t i = 0; i < n; ++i) f[i] = 5 * kNsPerSecond + static_cast<Timestamp>(i) * dt;
  return f;
}

TEST(TrackingRate, AllTracked) {
  const std::vector<Timestamp> f = Frames(101);  // 10 s
  const TrackingRate r = ComputeTrackingRate(f, f);
  EXPECT_DOUBLE_EQ(r.sequence_duration_s, 10.0);
  EXPECT_DOUBLE_EQ(r.covered_rate, 1.0);
  EXPECT_DOUBLE_EQ(r.tracked_rate, 1.0);
  EXPECT_DOUBLE_EQ(r.frame_rate, 1.0);
  EXPECT_EQ(r.num_segments, 1u);
}

TEST(TrackingRate, GapsSplitSegmentsButNotCoverage) {
  const std::vector<Timestamp> f = Frames(101);
  std::vector<Timestamp> tracked;
  // Tracked 1..30, lost 31..60 (3 s), tracked 61..90; one dropped frame (45 ms
  // jitter aside) at 75 is a small gap that must not split.
  for (size_t i = 10; i <= 30; ++i) tracked.push_back(f[i]);
  for (size_t i = 61; i <= 90; ++i) {
    if (i != 75) tracked.push_back(f[i] + 1000000);  // 1 ms off the frame time
  }
  const TrackingRate r = ComputeTrackingRate(f, tracked);
  EXPECT_DOUBLE_EQ(r.median_frame_interval_s, 0.1);
  EXPECT_EQ(r.num_tracked_frames, 21u + 29u);
  EXPECT_DOUBLE_EQ(r.frame_rate, 50.0 / 101.0);
  EXPECT_NEAR(r.covered_duration_s, 8.001, 1e-12);  // f[10] .. f[90]+1ms
  EXPECT_NEAR(r.covered_rate, 0.8001, 1e-12);
  EXPECT_EQ(r.num_segments, 2u);
  EXPECT_NEAR(r.tracked_duration_s, 2.0 + 2.9, 1e-12);
  EXPECT_NEAR(r.tracked_rate, 0.49, 1e-12);
  // A stricter gap factor splits at the dropped frame too (gap 0.2 s > 1.5*0.1).
  TrackingRateOptions o;
  o.max_gap_factor = 1.5;
  EXPECT_EQ(ComputeTrackingRate(f, tracked, o).num_segments, 3u);
}

TEST(TrackingRate, PosesOutsideTheSequenceAreClippedAndIsolatedPosesCountZero) {
  const std::vector<Timestamp> f = Frames(11);  // 1 s
  const std::vector<Timestamp> tracked = {f[0] - kNsPerSecond, f[5], f[10] + kNsPerSecond};
  const TrackingRate r = ComputeTrackingRate(f, tracked);
  EXPECT_DOUBLE_EQ(r.covered_rate, 1.0);
  EXPECT_DOUBLE_EQ(r.tracked_rate, 0.0);
  EXPECT_EQ(r.num_segments, 3u);
  EXPECT_EQ(r.num_tracked_frames, 1u);
  const TrackingRate none = ComputeTrackingRate(f, std::vector<Timestamp>{});
  EXPECT_EQ(none.frame_rate, 0.0);
  EXPECT_EQ(none.covered_rate, 0.0);
  EXPECT_THROW(ComputeTrackingRate(Frames(1), f), std::runtime_error);
}

}  // namespace
}  // namespace rumi
