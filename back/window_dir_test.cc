#include "back/window_dir.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include "common/testing/temp_dir.h"

namespace rumi {
namespace {

class WindowDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    tmp_.Create();
    for (int i = 0; i < 3; ++i)
      ASSERT_TRUE(cv::imwrite((dir_ / ("f" + std::to_string(i) + ".png")).string(), cv::Mat(6, 8, CV_8U, cv::Scalar(40 * i))));
    cam_.width = 8;
    cam_.height = 6;
    cam_.fx = cam_.fy = 10;
    cam_.cx = 4;
    cam_.cy = 3;
  }
  void WriteIndex(const std::string& text) { std::ofstream(dir_ / "rgb.txt") << text; }

  TempDir tmp_;
  std::filesystem::path dir_ = tmp_.path();
  PinholeCameraOptions cam_;
};

TEST_F(WindowDirTest, ReadsTheOptionalSampleSet) {
  WriteIndex("# t path set\n1.0 f0.png S1\n1.1 f1.png 2\n1.2 f2.png\n");
  ImageWindow w;
  std::string err;
  ASSERT_TRUE(ReadWindowDir(dir_.string(), cam_, WindowDirOptions(), 7, &w, &err)) << err;
  ASSERT_EQ(w.frames.size(), 3u);
  EXPECT_EQ(w.id, 7);
  EXPECT_EQ(w.frames[0].set, SampleSet::kS1);
  EXPECT_EQ(w.frames[0].front_state, TrackingState::kTracking);
  EXPECT_EQ(w.frames[1].set, SampleSet::kS2);
  EXPECT_EQ(w.frames[1].front_state, TrackingState::kLost);
  EXPECT_EQ(w.frames[2].set, SampleSet::kS2);  // none given
  EXPECT_EQ(w.frames[2].timestamp, 1200000000);
  EXPECT_EQ(w.frames[2].image.at<uint8_t>(0, 0), 80);
}

TEST_F(WindowDirTest, BadLinesAreNamed) {
  ImageWindow w;
  std::string err;
  WriteIndex("1.0 f0.png S4\n");
  EXPECT_FALSE(ReadWindowDir(dir_.string(), cam_, WindowDirOptions(), 0, &w, &err));
  EXPECT_NE(err.find("rgb.txt:1: set must be"), std::string::npos) << err;
  WriteIndex("1.0 f0.png\nabc f1.png\n");
  EXPECT_FALSE(ReadWindowDir(dir_.string(), cam_, WindowDirOptions(), 0, &w, &err));
  EXPECT_NE(err.find("rgb.txt:2: bad timestamp"), std::string::npos) << err;
  WriteIndex("1.0 missing.png\n");
  EXPECT_FALSE(ReadWindowDir(dir_.string(), cam_, WindowDirOptions(), 0, &w, &err));
  EXPECT_NE(err.find("missing.png: cannot read image"), std::string::npos) << err;
}

}  // namespace
}  // namespace rumi
