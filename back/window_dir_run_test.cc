// rumi-back's file mode as a library call (the executable: back_cli_test).
#include "back/window_dir_run.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "common/process/exit_codes.h"
#include "common/testing/temp_dir.h"

namespace fs = std::filesystem;

namespace rumi {
namespace {

class WindowDirRunTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(dir_.path() / "win");
    std::ofstream idx(dir_ / "win/rgb.txt");
    for (int i = 0; i < 4; ++i) {
      cv::Mat img(24, 32, CV_8UC1);
      cv::RNG(i + 1).fill(img, cv::RNG::UNIFORM, 0, 256);
      cv::imwrite(dir_ / ("win/" + std::to_string(i) + ".png"), img);
      idx << "1341847980.72298" << i << " " << i << ".png\n";
    }
    o_.window_dir = dir_ / "win";
    o_.camera.width = 32;
    o_.camera.height = 24;
    o_.camera.fx = o_.camera.fy = 30;
    o_.camera.cx = 15.5;
    o_.camera.cy = 11.5;
    o_.out_dir = dir_ / "out";
    o_.back.workspace_dir = dir_ / "ws";
    o_.back.low_priority = false;
  }
  TempDir dir_;
  WindowDirRunOptions o_;
};

TEST_F(WindowDirRunTest, AFolderThatDoesNotLoadIsBadInput) {
  o_.window_dir = dir_ / "missing";
  EXPECT_EQ(RunWindowDir(o_), kExitBadInput);
}

TEST_F(WindowDirRunTest, TheWireBenchBuildsNothing) {
  o_.bench_wire = true;
  o_.out_dir.clear();
  o_.back.colmap_path = dir_ / "no-colmap";
  EXPECT_EQ(RunWindowDir(o_), kExitDone);
  EXPECT_FALSE(fs::exists(dir_ / "out"));
  EXPECT_FALSE(fs::exists(dir_ / "ws"));
}

TEST_F(WindowDirRunTest, AFailedWindowIsWrittenAndSaid) {
  const std::string fake = dir_ / "colmap.sh";
  std::ofstream(fake) << "#!/bin/sh\nexit 1\n";
  ::chmod(fake.c_str(), 0755);
  o_.back.colmap_path = fake;
  EXPECT_EQ(RunWindowDir(o_), kExitWindowFailed);
  EXPECT_TRUE(fs::exists(dir_ / "out/result.json"));
}

}  // namespace
}  // namespace rumi
