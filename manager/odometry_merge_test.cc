#include "manager/odometry_merge.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "manager/testing/synthetic_submaps.h"

namespace rumi {
namespace {

const Se3 kT_ow(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, 0.3, 1).normalized())),
                Eigen::Vector3d(5, -2, 0.3));

TEST(OdometryMerge, FitRecoversTheSubmapToOdometrySim3) {
  const SyntheticScene scene = MakeSyntheticScene({});
  const Sim3 S_aw = RandomSim3(11);
  SyntheticSubmap a = MakeSyntheticFront(scene, 0, 0, 40, S_aw, 3);
  AttachSyntheticOdometry(scene, kT_ow, 0.0, 0.01, 5, &a.submap);
  ManagerOptions o;
  std::string why;
  const auto fit = FitOdometry(a.submap, 0, scene.timestamps[40], o, &why);
  ASSERT_TRUE(fit) << why;
  EXPECT_EQ(fit->frames, 41);
  EXPECT_NEAR(fit->path_m, 4.0, 0.6);  // 0.1 m per frame plus the jitter
  const Sim3 expect = Sim3(kT_ow) * S_aw.Inverse();
  EXPECT_NEAR(fit->S_os.scale() / expect.scale(), 1.0, 0.01);
  EXPECT_LT(fit->S_os.rotation().angularDistance(expect.rotation()), 0.005);
  for (int i : {0, 20, 40}) {
    const Eigen::Vector3d c = a.submap.frames[i].T_wc.translation();
    EXPECT_LT((fit->S_os * c - expect * c).norm(), 0.03) << "frame " << i;
  }
  EXPECT_LT(fit->position_rmse_m, 0.03);
  EXPECT_LT(fit->rotation_rmse_deg, 0.2);

  // Only the frames inside the window count.
  const auto part = FitOdometry(a.submap, scene.timestamps[30], scene.timestamps[40], o, &why);
  ASSERT_TRUE(part) << why;
  EXPECT_EQ(part->frames, 11);
}

TEST(OdometryMerge, FitRefusesWhatCannotGiveAScale) {
  const SyntheticScene scene = MakeSyntheticScene({});
  SyntheticSubmap a = MakeSyntheticFront(scene, 0, 0, 40, RandomSim3(12), 4);
  ManagerOptions o;
  std::string why;
  EXPECT_FALSE(FitOdometry(a.submap, 0, scene.timestamps[40], o, &why));  // no odometry at all
  EXPECT_NE(why.find("0 tracked frames with odometry"), std::string::npos) << why;

  AttachSyntheticOdometry(scene, kT_ow, 0.0, 0.0, 6, &a.submap);
  EXPECT_FALSE(FitOdometry(a.submap, scene.timestamps[36], scene.timestamps[40], o, &why));  // 5 frames
  EXPECT_NE(why.find("< 10"), std::string::npos) << why;

  // A robot standing still: the odometry cannot give the submap's scale.
  Submap still = a.submap;
  for (OdometryPose& p : still.odometry) p.T_wb = still.odometry[0].T_wb;
  EXPECT_FALSE(FitOdometry(still, 0, scene.timestamps[40], o, &why));
  EXPECT_NE(why.find("scale not observable"), std::string::npos) << why;

  // A pose source that is not the camera's (orientations unrelated).
  Submap turned = a.submap;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  for (OdometryPose& p : turned.odometry)
    p.T_wb = Se3(Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized(), p.T_wb.translation());
  EXPECT_FALSE(FitOdometry(turned, 0, scene.timestamps[40], o, &why));
  EXPECT_NE(why.find("rotation residual"), std::string::npos) << why;

  // Positions that do not follow the submap's centres.
  Submap scrambled = a.submap;
  std::shuffle(scrambled.odometry.begin(), scrambled.odometry.end(), rng);
  for (size_t i = 0; i < scrambled.odometry.size(); ++i) {
    scrambled.odometry[i].timestamp = a.submap.odometry[i].timestamp;
    scrambled.odometry[i].T_wb = Se3(a.submap.odometry[i].T_wb.rotation(), scrambled.odometry[i].T_wb.translation());
  }
  EXPECT_FALSE(FitOdometry(scrambled, 0, scene.timestamps[40], o, &why));
}

// Two front submaps of one drive with a 0.6 s gap between them, in frames of
// their own with their own scales, sharing no view and no frame: only the
// pose source joins them.
struct Drive {
  SyntheticScene scene;
  Sim3 S_aw, S_bw;
  GlobalMap map;
  int a = -1, b = -1;
};

Drive MakeDrive(double bias) {
  Drive d;
  d.scene = MakeSyntheticScene({});
  d.S_aw = RandomSim3(21);
  d.S_bw = RandomSim3(22);
  SyntheticSubmap a = MakeSyntheticFront(d.scene, 0, 0, 40, d.S_aw, 7);
  SyntheticSubmap b = MakeSyntheticFront(d.scene, 1, 59, 110, d.S_bw, 8);
  AttachSyntheticOdometry(d.scene, kT_ow, bias, 0.005, 11, &a.submap);
  AttachSyntheticOdometry(d.scene, kT_ow, bias, 0.005, 12, &b.submap);
  d.a = d.map.AddSubmap(a.submap);
  d.b = d.map.AddSubmap(b.submap);
  return d;
}

TEST(OdometryMerge, JoinsSubmapsVisionCannotJoin) {
  Drive d = MakeDrive(0.01);  // odometry 1 % long
  ManagerOptions o;
  const auto reports = OdometryMergeAll(&d.map, o);
  ASSERT_EQ(reports.size(), 1u);
  ASSERT_TRUE(reports[0].merged) << reports[0].reason;
  EXPECT_EQ(reports[0].init_method, "odometry");
  EXPECT_EQ(reports[0].front, d.map.Key(d.a));
  EXPECT_EQ(reports[0].common_points, 41 + 52);  // all frames lie within 3 s of the gap
  EXPECT_TRUE(d.map.Connected(d.a, d.b));
  // Both submaps now in one global frame: each frame's centre where the
  // ground truth puts it, seen through A's transform (world metres).
  const Sim3 S_gw = d.map.ToGlobal(d.a) * d.S_aw;
  double worst = 0;
  for (int s : {d.a, d.b}) {
    const Submap& sm = d.map.submap(s);
    for (const FrameRecord& f : sm.frames) {
      const auto it = std::find(d.scene.timestamps.begin(), d.scene.timestamps.end(), f.timestamp);
      const Eigen::Vector3d truth = S_gw * d.scene.T_wc[it - d.scene.timestamps.begin()].translation();
      worst = std::max(worst, (d.map.ToGlobal(s) * f.T_wc.translation() - truth).norm() / S_gw.scale());
    }
  }
  EXPECT_LT(worst, 0.08);  // 5.1 m driven after the gap, 1 % odometry bias and 1 cm pose noise
  EXPECT_GT(worst, 1e-4);  // not trivially equal

  // Nothing left to join: a second pass tries nothing.
  EXPECT_TRUE(OdometryMergeAll(&d.map, o).empty());
}

TEST(OdometryMerge, OffOrTooLongAGapLeavesTheSubmapsApart) {
  {
    Drive d = MakeDrive(0.0);
    ManagerOptions o;
    o.odometry_merge = false;
    EXPECT_TRUE(OdometryMergeAll(&d.map, o).empty());
    EXPECT_FALSE(d.map.Connected(d.a, d.b));
  }
  {
    Drive d = MakeDrive(0.0);
    ManagerOptions o;
    o.odometry_max_gap_s = 0.3;  // the gap is 18 frames at 30 Hz
    const auto reports = OdometryMergeAll(&d.map, o);
    ASSERT_EQ(reports.size(), 1u);
    EXPECT_FALSE(reports[0].merged);
    EXPECT_NE(reports[0].reason.find("gap"), std::string::npos) << reports[0].reason;
    EXPECT_FALSE(d.map.Connected(d.a, d.b));
  }
  {
    Drive d = MakeDrive(0.0);
    d.map.submap(d.b).odometry.clear();  // a submap without a pose source takes no part
    EXPECT_TRUE(OdometryMergeAll(&d.map, ManagerOptions{}).empty());
  }
}

}  // namespace
}  // namespace rumi
