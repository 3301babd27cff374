#include "back/window_layout.h"

#include <gtest/gtest.h>

namespace rumi {
namespace {

constexpr Timestamp kT0 = 1000000000LL, kDt = 100000000LL;

// Frames `blank` show nothing (all black), the others random texture.
ImageWindow Window(int n, const std::vector<int>& blank) {
  ImageWindow w;
  cv::RNG rng(1);
  for (int i = 0; i < n; ++i) {
    WindowFrame f;
    f.timestamp = kT0 + kDt * i;
    f.image = cv::Mat(48, 64, CV_8UC1, cv::Scalar(0));
    if (std::find(blank.begin(), blank.end(), i) == blank.end()) rng.fill(f.image, cv::RNG::UNIFORM, 0, 256);
    w.frames.push_back(f);
  }
  return w;
}

TEST(WindowLayout, BlankRunsBecomeStretchesAndSides) {
  const ImageWindow w = Window(12, {1, 4, 5, 6, 7});
  const WindowLayout l = LayOutWindow(w, BackOptions{});
  EXPECT_EQ(l.blank, (std::vector<bool>{0, 1, 0, 0, 1, 1, 1, 1, 0, 0, 0, 0}));
  EXPECT_EQ(l.num_blank, 5);
  ASSERT_EQ(l.stretches.size(), 1u);  // frame 1 alone is too short (blank_min_frames 3)
  EXPECT_EQ(l.stretches[0], std::make_pair(w.frames[4].timestamp, w.frames[7].timestamp));
  EXPECT_EQ(l.side, (std::vector<int>{0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1}));
  EXPECT_EQ(l.part_bounds, (std::vector<Timestamp>{w.frames[7].timestamp + 1}));
}

TEST(WindowLayout, JoinedWindowsArePartsAndBlankDetectionCanBeOff) {
  ImageWindow w = Window(6, {0, 1, 2});
  w.joined_at = {w.frames[4].timestamp};
  BackOptions o;
  o.blank_max_stddev = 0;
  const WindowLayout l = LayOutWindow(w, o);
  EXPECT_EQ(l.num_blank, 0);
  EXPECT_EQ(l.blank, std::vector<bool>(6, false));
  EXPECT_TRUE(l.stretches.empty());
  EXPECT_EQ(l.side, std::vector<int>(6, 0));
  EXPECT_EQ(l.part_bounds, w.joined_at);
}

}  // namespace
}  // namespace rumi
