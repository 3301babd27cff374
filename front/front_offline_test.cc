#include "front/front_offline.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "common/process/exit_codes.h"
#include "common/synth/synthetic_sequence.h"
#include "common/testing/temp_dir.h"
#include "common/trajectory.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;

size_t Lines(const std::string& path) {
  std::ifstream in(path);
  size_t n = 0;
  for (std::string line; std::getline(in, line);) ++n;
  return n;
}

bool Has(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

// A short smooth synthetic sequence in the TUM layout (ground truth, camera,
// imu.csv), written once for the suite.
class FrontOffline : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir;
    SynthOptions s;
    s.frames = 40;
    s.width = 320;
    s.height = 240;
    s.seed = 3;
    s.threads = 1;
    SynthesizeSequence(s, Seq());
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string Seq() { return *dir_ / "seq"; }

  // Deterministic and as fast as it goes: local mapping inline, no pacing.
  static FrontOfflineOptions Options() {
    FrontOfflineOptions o;
    o.dataset.kind = DatasetKind::kTum;
    o.dataset.path = Seq();
    o.dataset.config_path = Seq() + "/camera.yaml";
    o.front.local_mapping_thread = false;
    o.pace = false;
    return o;
  }

  // Runs, returns what it printed.
  static std::string Run(const FrontOfflineOptions& o, int expect = kExitDone) {
    testing::internal::CaptureStdout();
    EXPECT_EQ(RunFrontOffline(o), expect);
    return testing::internal::GetCapturedStdout();
  }

  static TempDir* dir_;
};

TempDir* FrontOffline::dir_ = nullptr;

TEST_F(FrontOffline, PrintsTheRunAndWritesItsFiles) {
  FrontOfflineOptions o = Options();
  o.out_dir = *dir_ / "out";
  const std::string printed = Run(o);
  EXPECT_TRUE(Has(printed, "frames 40, tracked ")) << printed;
  EXPECT_TRUE(Has(printed, "wrote " + o.out_dir + "/{trajectory.txt,keyframes.txt,submaps_trajectory.txt,frames.txt}"))
      << printed;
  EXPECT_FALSE(Has(printed, "bench")) << printed;
  // frames.txt: a header and one line per frame.
  EXPECT_EQ(Lines(o.out_dir + "/frames.txt"), 41u);
  std::ifstream frames(o.out_dir + "/frames.txt");
  std::string header;
  std::getline(frames, header);
  EXPECT_EQ(header, "# timestamp state submap_id extract_ms track_ms total_ms cpu_ms keypoints inliers");
  ASSERT_TRUE(fs::exists(o.out_dir + "/submaps_trajectory.txt"));
  // The smooth scene is tracked: the largest submap's poses, its ATE against
  // the ground truth, and every submap's tracked poses.
  ASSERT_TRUE(Has(printed, "largest submap ")) << printed;
  EXPECT_TRUE(Has(printed, " m over path ")) << printed;
  const Trajectory traj = ReadTumTrajectory(o.out_dir + "/trajectory.txt");
  EXPECT_GE(traj.size(), 10u);
  EXPECT_FALSE(ReadTumTrajectory(o.out_dir + "/keyframes.txt").empty());
  EXPECT_GE(Lines(o.out_dir + "/submaps_trajectory.txt"), traj.size() + 1);
}

TEST_F(FrontOffline, StopsAtMaxFramesAndPrintsTheBench) {
  FrontOfflineOptions o = Options();
  o.max_frames = 12;
  o.bench = true;
  const std::string printed = Run(o);
  EXPECT_TRUE(Has(printed, "frames 12, tracked ")) << printed;
  EXPECT_TRUE(Has(printed, "bench: 12 frames, median ")) << printed;
  EXPECT_TRUE(Has(printed, "bench map-lock wait: median ")) << printed;
  EXPECT_TRUE(Has(printed, "bench cpu: median ")) << printed;
  EXPECT_FALSE(Has(printed, "wrote ")) << printed;  // no out_dir: no files
}

TEST_F(FrontOffline, LoopPlaysTheFramesForwardAndBack) {
  FrontOfflineOptions o = Options();
  o.max_frames = 10;
  o.loop = 2;
  const std::string printed = Run(o);
  EXPECT_TRUE(Has(printed, "pass 1/2: 10 frames (")) << printed;
  EXPECT_TRUE(Has(printed, "pass 2/2: 20 frames (")) << printed;
  EXPECT_TRUE(Has(printed, "frames 20, tracked ")) << printed;
  EXPECT_FALSE(Has(printed, "largest submap ")) << printed;  // no ATE of a looped run
}

TEST_F(FrontOffline, LoopNeedsTwoFrames) {
  FrontOfflineOptions o = Options();
  o.max_frames = 1;
  o.loop = 2;
  EXPECT_THROW(RunFrontOffline(o), std::runtime_error);
}

TEST_F(FrontOffline, AnImuFileThatCannotBeUsedIsBadInput) {
  FrontOfflineOptions o = Options();
  o.imu = Seq() + "/imu.csv";
  ASSERT_TRUE(fs::exists(o.imu));
  o.loop = 2;  // played backwards, the frames no longer match it
  EXPECT_EQ(RunFrontOffline(o), kExitBadInput);
  o.loop = 1;
  o.imu = *dir_ / "no_such_imu.csv";
  EXPECT_EQ(RunFrontOffline(o), kExitBadInput);
}

}  // namespace
}  // namespace rumi
