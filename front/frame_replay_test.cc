#include "front/frame_replay.h"

#include <gtest/gtest.h>

#include <vector>

namespace rumi {
namespace {

constexpr int64_t kMs = 1'000'000;

// n frames at 10 Hz starting at 5 s; tiny images; frame `unreadable` (if any)
// is skipped by the source as a corrupt file would be.
class FakeSource : public FrameSource {
 public:
  explicit FakeSource(int n, int unreadable = -1) : cam_(Options()), unreadable_(unreadable) {
    for (int i = 0; i < n; ++i) ts_.push_back(5000 * kMs + i * 100 * kMs);
  }
  static PinholeCameraOptions Options() {
    PinholeCameraOptions o;
    o.width = 4;
    o.height = 4;
    o.fx = o.fy = 4;
    o.cx = o.cy = 1.5;
    return o;
  }
  const PinholeCamera& camera() const override { return cam_; }
  size_t size() const override { return ts_.size(); }
  bool Next(Frame* f) override {
    while (i_ < ts_.size() && static_cast<int>(i_) == unreadable_) ++i_;
    if (i_ >= ts_.size()) return false;
    f->timestamp = ts_[i_++];
    f->image = cv::Mat(4, 4, CV_8UC1, cv::Scalar(1));
    return true;
  }
  void Rewind() override { i_ = 0; }
  size_t skipped() const override { return unreadable_ >= 0 ? 1 : 0; }
  const std::vector<Timestamp>& timestamps() const override { return ts_; }
  const std::vector<std::pair<Timestamp, Se3>>& ground_truth() const override { return gt_; }

 private:
  PinholeCamera cam_;
  std::vector<Timestamp> ts_;
  std::vector<std::pair<Timestamp, Se3>> gt_;
  size_t i_ = 0;
  int unreadable_;
};

class FakeClock : public ReplayClock {
 public:
  int64_t NowNs() override { return now; }
  void SleepUntilNs(int64_t t, const std::atomic<bool>*) override {
    if (t > now) {
      slept += t - now;
      now = t;
    }
  }
  int64_t now = 777 * kMs;  // arbitrary origin
  int64_t slept = 0;
};

// Replays with a consumer that needs work_ms[i] (cyclic) per delivered frame;
// returns indices delivered, and fills skipped indices and delivery times.
std::vector<int> Replay(FrameReplay* r, FakeClock* clock, std::vector<int64_t> work_ms, std::vector<int>* skipped,
                     std::vector<int64_t>* at = nullptr) {
  std::vector<int> got;
  Frame f;
  std::vector<Timestamp> sk;
  size_t k = 0;
  while (r->Next(&f, &sk)) {
    got.push_back(static_cast<int>((f.timestamp - 5000 * kMs) / (100 * kMs)));
    if (at) at->push_back(clock->now);
    clock->now += work_ms[k++ % work_ms.size()] * kMs;
  }
  for (Timestamp t : sk) skipped->push_back(static_cast<int>((t - 5000 * kMs) / (100 * kMs)));
  return got;
}

TEST(FrameReplay, ParseRate) {
  FrameReplayOptions o;
  EXPECT_TRUE(ParseReplayRate("max", &o));
  EXPECT_TRUE(o.max);
  EXPECT_TRUE(ParseReplayRate("0.5", &o));
  EXPECT_FALSE(o.max);
  EXPECT_DOUBLE_EQ(o.rate, 0.5);
  for (const char* bad : {"", "0", "-1", "fast", "1x", "nan", "inf"}) EXPECT_FALSE(ParseReplayRate(bad, &o)) << bad;
}

TEST(FrameReplay, FastConsumerGetsEveryFrameAtItsTime) {
  FakeSource src(20);
  FakeClock clock;
  FrameReplay r(&src, FrameReplayOptions{}, &clock);
  std::vector<int> skipped;
  std::vector<int64_t> at;
  const std::vector<int> got = Replay(&r, &clock, {30}, &skipped, &at);
  ASSERT_EQ(got.size(), 20u);
  EXPECT_TRUE(skipped.empty());
  for (int i = 0; i < 20; ++i) {
    EXPECT_EQ(got[i], i);
    EXPECT_EQ(at[i], 777 * kMs + i * 100 * kMs) << i;  // due at its offset, not earlier
  }
  EXPECT_EQ(r.skipped(), 0u);
}

TEST(FrameReplay, RateScalesTheSchedule) {
  FakeSource src(10);
  FakeClock clock;
  FrameReplayOptions o;
  o.rate = 2.0;
  FrameReplay r(&src, o, &clock);
  std::vector<int> skipped;
  std::vector<int64_t> at;
  Replay(&r, &clock, {10}, &skipped, &at);
  ASSERT_EQ(at.size(), 10u);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(at[i], 777 * kMs + i * 50 * kMs);
}

TEST(FrameReplay, BusyConsumerSkipsOvertakenFrames) {
  // 250 ms per frame at 10 Hz: delivered 0 at 0; busy until 250, when frames
  // 1 and 2 are overtaken by 2 (due 200)... frame 2 is the newest arrived.
  FakeSource src(12);
  FakeClock clock;
  FrameReplay r(&src, FrameReplayOptions{}, &clock);
  std::vector<int> skipped;
  std::vector<int64_t> at;
  const std::vector<int> got = Replay(&r, &clock, {250}, &skipped, &at);
  // t=0 take 0 -> 250: 1 (next due 200 <= 250) skipped, take 2 at 250 (late,
  // no sleep) -> 500: 3,4 skipped, take 5 at 500 -> 750: 6 skipped, take 7 at
  // 750 -> 1000: 8,9 skipped, take 10 at 1000 -> 1250: 11 is the last frame.
  EXPECT_EQ(got, (std::vector<int>{0, 2, 5, 7, 10, 11}));
  EXPECT_EQ(skipped, (std::vector<int>{1, 3, 4, 6, 8, 9}));
  EXPECT_EQ(r.skipped(), 6u);
  EXPECT_EQ(r.delivered(), 6u);
  EXPECT_EQ(got.size() + skipped.size(), 12u);
}

TEST(FrameReplay, SlightlyLateFrameIsNotSkipped) {
  // 150 ms per frame: frame 1 (due 100) is taken at 150 since frame 2 is due
  // only at 200; then 2 at 300 would be overtaken by 3 (due 300): skipped.
  FakeSource src(4);
  FakeClock clock;
  FrameReplay r(&src, FrameReplayOptions{}, &clock);
  std::vector<int> skipped;
  const std::vector<int> got = Replay(&r, &clock, {150}, &skipped);
  EXPECT_EQ(got, (std::vector<int>{0, 1, 3}));
  EXPECT_EQ(skipped, (std::vector<int>{2}));
}

TEST(FrameReplay, MaxNeverSleepsNorSkips) {
  FakeSource src(15);
  FakeClock clock;
  FrameReplayOptions o;
  o.max = true;
  FrameReplay r(&src, o, &clock);
  std::vector<int> skipped;
  const std::vector<int> got = Replay(&r, &clock, {1000}, &skipped);
  EXPECT_EQ(got.size(), 15u);
  EXPECT_TRUE(skipped.empty());
  EXPECT_EQ(clock.slept, 0);
}

TEST(FrameReplay, UnreadableFrameDoesNotShiftTheSchedule) {
  FakeSource src(6, /*unreadable=*/2);
  FakeClock clock;
  FrameReplay r(&src, FrameReplayOptions{}, &clock);
  std::vector<int> skipped;
  std::vector<int64_t> at;
  const std::vector<int> got = Replay(&r, &clock, {10}, &skipped, &at);
  EXPECT_EQ(got, (std::vector<int>{0, 1, 3, 4, 5}));
  EXPECT_EQ(at[2], 777 * kMs + 300 * kMs);
  EXPECT_TRUE(skipped.empty());
}

TEST(FrameReplay, StopEndsTheReplay) {
  FakeSource src(10);
  FakeClock clock;
  FrameReplay r(&src, FrameReplayOptions{}, &clock);
  std::atomic<bool> stop{false};
  Frame f;
  ASSERT_TRUE(r.Next(&f, nullptr, &stop));
  stop = true;
  EXPECT_FALSE(r.Next(&f, nullptr, &stop));
}

TEST(FrameReplay, SteadyClockSleepStopsEarly) {
  SteadyReplayClock c;
  std::atomic<bool> stop{true};
  const int64_t t0 = c.NowNs();
  c.SleepUntilNs(t0 + 10'000 * kMs, &stop);  // would be 10 s
  EXPECT_LT(c.NowNs() - t0, 1000 * kMs);
}

// A looped replay goes on with increasing timestamps: the period is the
// sequence's duration plus one frame interval, so identity stays unique.
TEST(FrameReplay, LoopContinuesWithIncreasingTimestamps) {
  FakeSource src(5);  // 5.0 .. 5.4 s
  FakeClock clock;
  FrameReplayOptions o;
  o.loop = true;
  FrameReplay r(&src, o, &clock);
  std::vector<Timestamp> t;
  Frame f;
  for (int k = 0; k < 12 && r.Next(&f); ++k) {
    t.push_back(f.timestamp);
    clock.now += 1 * kMs;
  }
  ASSERT_EQ(t.size(), 12u);
  for (size_t i = 1; i < t.size(); ++i) EXPECT_EQ(t[i] - t[i - 1], 100 * kMs) << i;
  EXPECT_EQ(r.loops(), 2);
  EXPECT_EQ(r.offset(), 2 * 500 * kMs);
  EXPECT_EQ(r.skipped(), 0u);
}

// A front that starts late (restarted by rumid) joins the stream where it is:
// what was due before now is passed over unread, and counted.
TEST(FrameReplay, LateStartJoinsTheStreamWhereItIs) {
  FakeSource src(10);
  FakeClock clock;
  FrameReplayOptions o;
  o.start_ns = clock.now - 450 * kMs;  // frames 0..4 were due; 4 is due 50 ms ago, 5 in 50 ms
  FrameReplay r(&src, o, &clock);
  std::vector<int> skipped;
  const std::vector<int> got = Replay(&r, &clock, {1}, &skipped);
  EXPECT_EQ(skipped, (std::vector<int>{0, 1, 2, 3}));
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(got.front(), 4);  // the newest one due is delivered at once
  EXPECT_EQ(got.back(), 9);
  EXPECT_EQ(r.delivered() + r.skipped(), 10u);
}

}  // namespace
}  // namespace rumi
