#include "ipc/link/latency_plot.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "common/testing/temp_dir.h"

namespace rumi {
namespace {

TEST(LatencyPlot, ReadsTheFramesLogAndDrawsDroppedFramesInRed) {
  const TempDir tmp;
  tmp.Create();
  const std::string p = tmp / "frames.csv";
  {
    std::ofstream f(p);
    f << "frame_id,robot_us,ground_capture_us,first_us,complete_us,latency_ms,fragments,recovered,status\n";
    for (int i = 0; i < 50; ++i) f << i << ",1,2,3,4," << 40 + i << ",8," << (i % 5 == 0) << ",complete\n";
    f << "50,0,0,0,0,0,0,0,dropped\n";
  }
  std::vector<LinkFrameLogLine> v;
  std::string why;
  ASSERT_TRUE(ReadLinkFramesLog(p, &v, &why)) << why;
  ASSERT_EQ(v.size(), 51u);
  EXPECT_TRUE(v.back().dropped);
  EXPECT_DOUBLE_EQ(v[10].latency_ms, 50);
  const cv::Mat img = RenderLatencyPlot(v, "test");
  ASSERT_FALSE(img.empty());
  // The dropped frame's tick (pure red-ish pixels) is there.
  int red = 0;
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const cv::Vec3b c = img.at<cv::Vec3b>(y, x);
      red += c[2] > 180 && c[0] < 80 && c[1] < 80;
    }
  EXPECT_GT(red, 10);
  {
    std::ofstream f(p);
    f << "frame_id,robot_us\n1,2,3\n";
  }
  EXPECT_FALSE(ReadLinkFramesLog(p, &v, &why));
  EXPECT_NE(why.find(":2:"), std::string::npos) << why;
  std::filesystem::remove(p);
  EXPECT_FALSE(ReadLinkFramesLog(p, &v, &why));
}

}  // namespace
}  // namespace rumi
