#include "ipc/link/rate_control.h"

#include <gtest/gtest.h>

namespace rumi {
namespace {

constexpr double kDeadlineMs = 500;

// Feeds up to `seconds` of frames at `fps` (a share `dropped` of them
// dropped, the others `latency_ms` late), polling as the link's thread does;
// returns the rates asked for (with `first`, stops at the first).
std::vector<double> Feed(RateControl* rc, int64_t* now_us, double seconds, double fps, double dropped,
                         double latency_ms, bool first = false) {
  std::vector<double> asked;
  const int n = static_cast<int>(seconds * fps);
  double debt = 0;
  for (int i = 0; i < n; ++i) {
    *now_us += static_cast<int64_t>(1e6 / fps);
    debt += dropped;
    const bool drop = debt >= 1;
    if (drop) debt -= 1;
    rc->OnFrame(*now_us, !drop, latency_ms);
    if (const double f = rc->Poll(*now_us); f > 0) {
      asked.push_back(f);
      if (first) break;
    }
  }
  return asked;
}

TEST(RateControl, ACleanLinkIsLeftAlone) {
  RateControl rc(RateControlOptions(), kDeadlineMs);
  int64_t t = 1'000'000;
  EXPECT_TRUE(Feed(&rc, &t, 20, 30, 0.0, 120).empty());
  // Random loss the NACKs repair (a few drops, latency well inside the deadline) too.
  EXPECT_TRUE(Feed(&rc, &t, 20, 30, 0.02, 300).empty());
  EXPECT_EQ(rc.asked_fps(), 0);
  EXPECT_NEAR(rc.max_seen_fps(), 30, 1.5);
}

TEST(RateControl, CutsOnDropsAndLatenessRaisesWhenCleanUpToTheRobotsRate) {
  RateControl rc(RateControlOptions(), kDeadlineMs);
  int64_t t = 1'000'000;
  EXPECT_TRUE(Feed(&rc, &t, 3, 30, 0.0, 100).empty());
  // A third of the frames miss their deadline: 0.7 x 30.
  std::vector<double> a = Feed(&rc, &t, 3, 30, 0.33, 450, true);
  ASSERT_EQ(a.size(), 1u);
  EXPECT_NEAR(a[0], 21, 1.5);
  // Still too many for the link at that rate: the frames queued before the
  // cut drain first (hold_s), then it cuts again, from the asked rate.
  const double first = a[0];
  EXPECT_TRUE(Feed(&rc, &t, 1.5, first, 0.2, 450).empty());
  a = Feed(&rc, &t, 3, first, 0.2, 450, true);
  ASSERT_EQ(a.size(), 1u);
  EXPECT_NEAR(a[0], 0.7 * first, 1.0);
  // A few drops (left alone), but frames later than the deadline (they
  // queued on the robot before their first fragment left): cut too.
  a = Feed(&rc, &t, 3, rc.asked_fps(), 0.05, 600, true);
  ASSERT_EQ(a.size(), 1u);
  EXPECT_EQ(rc.cuts(), 3);
  // Clean: +1 fps after 5 s, and so on, never above the robot's own 30.
  const double low = rc.asked_fps();
  a = Feed(&rc, &t, 10, low, 0.0, 100, true);
  ASSERT_EQ(a.size(), 1u);
  EXPECT_NEAR(a[0], low + 1, 1e-9);
  for (int i = 0; i < 40; ++i) Feed(&rc, &t, 10, rc.asked_fps(), 0.0, 100, true);
  EXPECT_NEAR(rc.asked_fps(), rc.max_seen_fps(), 1e-9);
  EXPECT_LE(rc.asked_fps(), 31.5);
  EXPECT_GE(rc.raises(), 10);
}

TEST(RateControl, NeverBelowTheFloorAndOffWhenDisabled) {
  RateControlOptions o;
  o.min_fps = 5;
  RateControl rc(o, kDeadlineMs);
  int64_t t = 1'000'000;
  std::vector<double> a = Feed(&rc, &t, 30, 30, 0.5, 480);
  ASSERT_FALSE(a.empty());
  EXPECT_EQ(a.back(), 5);
  const int cuts = rc.cuts();
  // At the floor, trouble asks nothing more.
  EXPECT_TRUE(Feed(&rc, &t, 5, 5, 0.5, 480).empty());
  EXPECT_EQ(rc.cuts(), cuts);
  o.enabled = false;
  RateControl off(o, kDeadlineMs);
  t = 1'000'000;
  EXPECT_TRUE(Feed(&off, &t, 10, 30, 0.5, 480).empty());
}

TEST(RateControl, OptionsAreChecked) {
  RateControlOptions o;
  EXPECT_TRUE(o.Check());
  o.cut = 1.0;
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("cut"), std::string::npos) << why;
}

}  // namespace
}  // namespace rumi
