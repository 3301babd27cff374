#include "common/trajectory.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace rumi {
namespace {

const std::string kData = RUMI_SHARED_DATA_DIR;
const std::string kEvo = kData + "/eval-reference/evo/";

std::string TempPath(const std::string& name) {
  return std::string(RUMI_BINARY_DIR) + "/trajectory_test_" + name;
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

// Message of the runtime_error thrown by f, or "" when it does not throw.
template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

Trajectory ParseTum(const std::string& text) {
  std::istringstream in(text);
  return ParseTumTrajectory(in, "test.txt");
}

Trajectory SomeTrajectory() {
  Trajectory t;
  for (int i = 0; i < 5; ++i) {
    StampedPose p;
    p.t = 1305031102175304000LL + i * 33333333LL + (i == 3 ? 1 : 0);  // odd ns on purpose
    p.T_wc = Se3(Eigen::Quaterniond(Eigen::AngleAxisd(0.4 * i + 0.1, Eigen::Vector3d(1, -2, 0.5).normalized())),
                 Eigen::Vector3d(0.123456789 * i, -2.5 + i, 1e-3 * i));
    t.push_back(p);
  }
  return t;
}

void ExpectSamePoses(const Trajectory& a, const Trajectory& b, double tol, bool same_time = true) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    if (same_time) {
      EXPECT_EQ(a[i].t, b[i].t) << i;
    }
    EXPECT_TRUE(a[i].T_wc.Matrix().isApprox(b[i].T_wc.Matrix(), tol)) << i;
  }
}

// ---- conventions --------------------------------------------------------------

TEST(TumReader, QuaternionIsXyzwAndTranslationKeepsSign) {
  // 90 degrees about z: qz = qw = sqrt(1/2). As wxyz the same numbers would
  // mean a different rotation, so x -> y below catches a swapped order.
  const Trajectory t = ParseTum(
      "# comment\n"
      "\n"
      "1305031102.175304 1.5 -2.25 3 0 0 0.7071067811865476 0.7071067811865476\n"
      "  1305031102.2 0 0 0 0.5 0.5 0.5 0.5  \n");
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].t, 1305031102175304000LL);
  EXPECT_TRUE(t[0].T_wc.translation().isApprox(Eigen::Vector3d(1.5, -2.25, 3)));
  EXPECT_TRUE((t[0].T_wc.R() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
  // 120 degrees about (1,1,1): x -> y -> z -> x.
  EXPECT_TRUE((t[1].T_wc.R() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
  EXPECT_TRUE((t[1].T_wc.R() * Eigen::Vector3d::UnitY()).isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
}

TEST(EurocReader, QuaternionIsWxyzAndMatchesTum) {
  std::istringstream euroc(
      "#timestamp [ns],p_x,p_y,p_z,q_w,q_x,q_y,q_z,v_x,v_y,v_z\n"
      "1403715524907143168,0.5,1.9,0.97,0.161996,0.789985,-0.205376,0.554528,1,2,3\n");
  const Trajectory e = ParseEurocTrajectory(euroc, "gt.csv");
  const Trajectory t =
      ParseTum("1403715524.907143168 0.5 1.9 0.97 0.789985 -0.205376 0.554528 0.161996\n");
  ExpectSamePoses(e, t, 1e-15);
  EXPECT_EQ(e[0].t, 1403715524907143168LL);
  EXPECT_NEAR(e[0].T_wc.rotation().w(), 0.161996 / std::sqrt(0.161996 * 0.161996 + 0.789985 * 0.789985 + 0.205376 * 0.205376 + 0.554528 * 0.554528), 1e-15);
}

TEST(KittiReader, RowMajorAndIndexTimestamps) {
  std::istringstream in(
      "1 0 0 10 0 1 0 20 0 0 1 30\n"
      "0 -1 0 1 1 0 0 2 0 0 1 3\n");
  const Trajectory t = ParseKittiTrajectory(in, "00.txt");
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].t, 0);
  EXPECT_EQ(t[1].t, kNsPerSecond);
  EXPECT_TRUE(t[0].T_wc.translation().isApprox(Eigen::Vector3d(10, 20, 30)));
  EXPECT_TRUE(t[1].T_wc.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  // Row-major: R(0,1) = -1, so x -> (0,1,0).
  EXPECT_TRUE((t[1].T_wc.R() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
}

// ---- round trips ----------------------------------------------------------------

TEST(TrajectoryWriters, RoundTripAllFormats) {
  const Trajectory traj = SomeTrajectory();
  const std::string tum = TempPath("rt.txt"), kitti = TempPath("rt_kitti.txt"),
                    euroc = TempPath("rt.csv");
  WriteTumTrajectory(tum, traj);
  WriteKittiTrajectory(kitti, traj);
  WriteEurocTrajectory(euroc, traj);
  ExpectSamePoses(ReadTumTrajectory(tum), traj, 1e-8);  // ns exact, 9 decimals on poses
  ExpectSamePoses(ReadEurocTrajectory(euroc), traj, 1e-8);
  ExpectSamePoses(ReadKittiTrajectory(kitti), traj, 1e-14, /*same_time=*/false);
  // With a times file (TUM file reused: its first column is the time).
  ExpectSamePoses(ReadKittiTrajectory(kitti, tum), traj, 1e-14);
  EXPECT_EQ(DetectTrajectoryFormat(tum), TrajectoryFormat::kTum);
  EXPECT_EQ(DetectTrajectoryFormat(kitti), TrajectoryFormat::kKitti);
  EXPECT_EQ(DetectTrajectoryFormat(euroc), TrajectoryFormat::kEuroc);
  for (const std::string& f : {tum, kitti, euroc}) std::remove(f.c_str());
}

TEST(TrajectoryWriters, UnwritablePathThrows) {
  EXPECT_NE(ErrorOf([] { WriteTumTrajectory("/nonexistent_dir/x.txt", SomeTrajectory()); }), "");
}

TEST(TrajectoryFormat, Names) {
  TrajectoryFormat f;
  ASSERT_TRUE(ParseTrajectoryFormat("kitti", &f));
  EXPECT_EQ(f, TrajectoryFormat::kKitti);
  EXPECT_STREQ(ToString(TrajectoryFormat::kEuroc), "euroc");
  EXPECT_FALSE(ParseTrajectoryFormat("TUMM", &f));
}

// ---- errors ---------------------------------------------------------------------

TEST(TrajectoryReaders, MissingFileNamesThePath) {
  const std::string msg = ErrorOf([] { ReadTumTrajectory("/no/such/traj.txt"); });
  EXPECT_NE(msg.find("/no/such/traj.txt"), std::string::npos) << msg;
  EXPECT_NE(ErrorOf([] { ReadEurocTrajectory("/no/such/gt.csv"); }), "");
  EXPECT_NE(ErrorOf([] { ReadKittiTrajectory("/no/such/00.txt"); }), "");
  EXPECT_NE(ErrorOf([] { DetectTrajectoryFormat("/no/such/00.txt"); }), "");
}

// A device, a pipe or a folder is refused before a byte is read: /dev/zero
// was read for 11 s (1.1 GB) before `rumi eval ate` refused it.
TEST(TrajectoryReaders, NonRegularFilesAreRefusedAtOnce) {
  for (const char* path : {"/dev/zero", "/tmp"}) {
    try {
      ReadTumTrajectory(path);
      ADD_FAILURE() << path;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(ReadKittiTrajectory("/dev/zero"), std::runtime_error);
  EXPECT_THROW(ReadEurocTrajectory("/dev/zero"), std::runtime_error);
}

TEST(Trajectory, SortOnePosePerTimeKeepsTheFirstOfEachTime) {
  Trajectory t;
  for (Timestamp ts : {3, 1, 2, 1, 3}) t.push_back({ts, Se3()});
  t[1].T_wc.translation().x() = 7;  // the first pose at t = 1
  SortOnePosePerTime(&t);
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[0].t, 1);
  EXPECT_EQ(t[0].T_wc.translation().x(), 7);
  EXPECT_EQ(t[2].t, 3);
  EXPECT_NO_THROW(CheckStrictlyIncreasing(t, "t"));
}

TEST(TrajectoryReaders, MalformedLinesNameFileLineAndReason) {
  const std::string good = "1.0 0 0 0 0 0 0 1\n";
  struct Case {
    std::string text, expect;
  } cases[] = {
      {good + "2.0 0 0 0 0 0 1\n", "test.txt:2: expected 8 fields"},
      {good + "2.0 0 0 x 0 0 0 1\n", "test.txt:2: column 4 'x'"},
      {good + "2.0 0 0 nan 0 0 0 1\n", "test.txt:2: column 4"},
      {good + "abc 0 0 0 0 0 0 1\n", "test.txt:2: bad timestamp 'abc'"},
      {good + "2.0 0 0 0 0 0 0 2\n", "test.txt:2: quaternion norm"},
      {good + "2.0 0 0 0 0 0 0 0\n", "test.txt:2: quaternion norm"},
      {good + "\n# c\n0.5 0 0 0 0 0 0 1\n", "test.txt:4: timestamp 0.500000000 is before"},
      {good + "1.0 0 0 0 0 0 0 1\n", "test.txt:2: timestamp 1.000000000 duplicates"},
  };
  for (const Case& c : cases) {
    const std::string msg = ErrorOf([&] { ParseTum(c.text); });
    EXPECT_NE(msg.find(c.expect), std::string::npos) << "got '" << msg << "' for\n" << c.text;
  }
  // EuRoC: float timestamps are not nanoseconds; too few columns.
  std::istringstream e1("#h\n1.5,0,0,0,1,0,0,0\n");
  EXPECT_NE(ErrorOf([&] { ParseEurocTrajectory(e1, "gt.csv"); }).find("gt.csv:2: timestamp"),
            std::string::npos);
  std::istringstream e2("10,0,0,0,1,0,0\n");
  EXPECT_NE(ErrorOf([&] { ParseEurocTrajectory(e2, "gt.csv"); }).find("gt.csv:1: expected at least 8"),
            std::string::npos);
  std::istringstream e3("10,0,0,0,1,0,0,0\n10,0,0,0,1,0,0,0\n");
  EXPECT_NE(ErrorOf([&] { ParseEurocTrajectory(e3, "gt.csv"); }).find("gt.csv:2: timestamp"),
            std::string::npos);
  // KITTI: wrong count, not a rotation (scaled, reflected).
  std::istringstream k1("1 0 0 0 0 1 0 0 0 0 1\n");
  EXPECT_NE(ErrorOf([&] { ParseKittiTrajectory(k1, "00.txt"); }).find("00.txt:1: expected 12"),
            std::string::npos);
  std::istringstream k2("1 0 0 0 0 1 0 0 0 0 1 0\n2 0 0 0 0 2 0 0 0 0 2 0\n");
  EXPECT_NE(ErrorOf([&] { ParseKittiTrajectory(k2, "00.txt"); }).find("00.txt:2: the 3x3 block"),
            std::string::npos);
  std::istringstream k3("1 0 0 0 0 1 0 0 0 0 -1 0\n");
  EXPECT_NE(ErrorOf([&] { ParseKittiTrajectory(k3, "00.txt"); }).find("not a rotation"),
            std::string::npos);
}

TEST(TrajectoryReaders, KittiTimesFileMustMatch) {
  const std::string poses = TempPath("k.txt"), times = TempPath("k_times.txt");
  WriteText(poses, "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 1 0 0 0 0 1 0\n");
  WriteText(times, "0.0\n");
  std::string msg = ErrorOf([&] { ReadKittiTrajectory(poses, times); });
  EXPECT_NE(msg.find("has 1 timestamps"), std::string::npos) << msg;
  WriteText(times, "0.5\n0.5\n");
  msg = ErrorOf([&] { ReadKittiTrajectory(poses, times); });
  EXPECT_NE(msg.find("k_times.txt:2"), std::string::npos) << msg;
  WriteText(times, "0.0\n1.037359e-01\n");
  EXPECT_EQ(ReadKittiTrajectory(poses, times)[1].t, 103735900);
  std::remove(poses.c_str());
  std::remove(times.c_str());
}

TEST(TrajectoryReaders, DropDuplicatesKeepsFirstButStillRejectsUnsorted) {
  TrajectoryReadOptions o;
  o.drop_duplicates = true;
  std::istringstream in("1.0 1 0 0 0 0 0 1\n1.0 2 0 0 0 0 0 1\n1.0 3 0 0 0 0 0 1\n2.0 4 0 0 0 0 0 1\n");
  const Trajectory t = ParseTumTrajectory(in, "dup.txt", o);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].T_wc.translation().x(), 1.0);
  EXPECT_EQ(t[1].T_wc.translation().x(), 4.0);
  std::istringstream unsorted("2.0 0 0 0 0 0 0 1\n1.0 0 0 0 0 0 0 1\n");
  EXPECT_NE(ErrorOf([&] { ParseTumTrajectory(unsorted, "u.txt", o); }).find("u.txt:2"),
            std::string::npos);
  std::istringstream euroc("5,0,0,0,1,0,0,0\n5,1,0,0,1,0,0,0\n6,0,0,0,1,0,0,0\n");
  EXPECT_EQ(ParseEurocTrajectory(euroc, "d.csv", o).size(), 2u);
  // The official TUM fr2_desk ground truth has one duplicated stamp.
  const std::string fr2 = kEvo + "fr2_desk_groundtruth.txt";
  EXPECT_NE(ErrorOf([&] { ReadTumTrajectory(fr2); }).find("duplicates"), std::string::npos);
  EXPECT_GT(ReadTrajectory(fr2, TrajectoryFormat::kTum, "", o).size(), 1000u);
}

TEST(TrajectoryReaders, CheckStrictlyIncreasing) {
  Trajectory t = SomeTrajectory();
  EXPECT_NO_THROW(CheckStrictlyIncreasing(t, "x"));
  t[2].t = t[1].t;
  EXPECT_THROW(CheckStrictlyIncreasing(t, "x"), std::runtime_error);
}

// ---- the real files -------------------------------------------------------------

TEST(TrajectoryReaders, RealFiles) {
  const Trajectory gt = ReadTumTrajectory(kEvo + "freiburg1_xyz-groundtruth.txt");
  ASSERT_FALSE(gt.empty());
  EXPECT_EQ(gt.front().t, 1305031098665900000LL);
  EXPECT_TRUE(gt.front().T_wc.translation().isApprox(Eigen::Vector3d(1.3563, 0.6305, 1.6380)));
  EXPECT_NEAR(gt.front().T_wc.rotation().w(), -0.3986, 1e-3);  // xyzw order: qw last

  const Trajectory euroc = ReadEurocTrajectory(kEvo + "V102_groundtruth.csv");
  ASSERT_FALSE(euroc.empty());
  EXPECT_EQ(euroc.front().t, 1403715524907143168LL);
  EXPECT_NEAR(euroc.front().T_wc.rotation().w(), 0.161996, 1e-5);  // wxyz order: qw first
  EXPECT_NEAR(euroc.front().T_wc.rotation().x(), 0.789985, 1e-5);
  EXPECT_EQ(DetectTrajectoryFormat(kEvo + "V102_groundtruth.csv"), TrajectoryFormat::kEuroc);

  // Exponent-notation timestamps (numpy savetxt).
  const Trajectory ov = ReadTumTrajectory(kEvo + "V101_openvins.txt");
  ASSERT_GT(ov.size(), 1u);
  EXPECT_NEAR(NsToSeconds(ov.front().t), 1403715278.86213994, 1e-6);

  const Trajectory k = ReadKittiTrajectory(kEvo + "KITTI_00_gt.txt", kEvo + "KITTI_00_gt_times.txt");
  EXPECT_EQ(k.size(), 4541u);
  EXPECT_EQ(k[1].t, 103735900);
  EXPECT_EQ(DetectTrajectoryFormat(kEvo + "KITTI_00_SPTAM.txt"), TrajectoryFormat::kKitti);
}

}  // namespace
}  // namespace rumi
