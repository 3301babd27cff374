#include "back/window_queue.h"

#include <gtest/gtest.h>

#include <thread>

namespace rumi {
namespace {

ImageWindow W(int64_t id) {
  ImageWindow w;
  w.id = id;
  return w;
}

// A window of frames at these times (seconds), all of one sample set.
ImageWindow W(int64_t id, std::vector<double> seconds, SampleSet set = SampleSet::kS2) {
  ImageWindow w = W(id);
  for (double s : seconds) {
    WindowFrame f;
    f.timestamp = SecondsToNs(s);
    f.set = set;
    f.image = cv::Mat(2, 2, CV_8UC1, cv::Scalar(static_cast<int>(id)));
    w.frames.push_back(f);
  }
  return w;
}

WindowQueueOptions NoJoins(size_t capacity) { return {capacity, -1.0, 300}; }

TEST(WindowQueueTest, DropsOldestWhenFull) {
  WindowQueue q(NoJoins(2));
  EXPECT_TRUE(q.Push(W(1)).dropped.empty());
  EXPECT_TRUE(q.Push(W(2)).dropped.empty());
  EXPECT_EQ(q.Push(W(3)).dropped, std::vector<int64_t>{1});
  EXPECT_EQ(q.size(), 2u);
  EXPECT_EQ(q.dropped(), 1u);
  ImageWindow w;
  ASSERT_TRUE(q.Pop(&w, std::chrono::milliseconds(0)));
  EXPECT_EQ(w.id, 2);
  ASSERT_TRUE(q.Pop(&w, std::chrono::milliseconds(0)));
  EXPECT_EQ(w.id, 3);
  EXPECT_FALSE(q.Pop(&w, std::chrono::milliseconds(10)));
}

TEST(WindowQueueTest, PopWakesOnPushAndClose) {
  WindowQueue q(NoJoins(1));
  std::thread t([&] { q.Push(W(9)); });
  ImageWindow w;
  EXPECT_TRUE(q.Pop(&w, std::chrono::seconds(10)));
  EXPECT_EQ(w.id, 9);
  t.join();
  std::thread c([&] { q.Close(); });
  EXPECT_FALSE(q.Pop(&w, std::chrono::seconds(10)));
  c.join();
}

TEST(WindowQueueTest, MergeWindowsKeepsOneFramePerTimestampTheDensestSample) {
  ImageWindow a = W(1, {1.0, 1.2, 1.4}, SampleSet::kS1);
  const ImageWindow b = W(2, {1.2, 1.3, 2.0}, SampleSet::kS2);
  ASSERT_TRUE(MergeWindows(&a, b, 10));
  EXPECT_EQ(a.id, 1);
  ASSERT_EQ(a.frames.size(), 5u);
  const double t[] = {1.0, 1.2, 1.3, 1.4, 2.0};
  for (size_t k = 0; k < 5; ++k) EXPECT_EQ(a.frames[k].timestamp, SecondsToNs(t[k]));
  EXPECT_EQ(a.frames[1].set, SampleSet::kS2);  // in both: S2 wins over S1
  EXPECT_EQ(a.frames[1].image.at<uint8_t>(0, 0), 2);
  EXPECT_EQ(a.frames[3].set, SampleSet::kS1);
  EXPECT_EQ(a.joined_at, std::vector<Timestamp>{SecondsToNs(1.2)});  // where the joined part begins
  // Too many frames together, or another camera: no join, nothing touched.
  ImageWindow c = W(3, {5.0, 6.0});
  EXPECT_FALSE(MergeWindows(&c, W(4, {7.0, 8.0}), 3));
  EXPECT_EQ(c.frames.size(), 2u);
  ImageWindow other = W(5, {9.0});
  other.camera.fx = 400;
  EXPECT_FALSE(MergeWindows(&c, other, 100));
}

TEST(WindowQueueTest, ACloseWindowJoinsTheLastWaitingOneAndPopSaysWhich) {
  WindowQueue q({2, 3.0, 8});
  EXPECT_EQ(q.Push(W(1, {10.0, 11.0, 12.0})).merged_into, -1);
  // Starts 2.5 s after window 1 ends: joins it.
  const WindowQueue::PushResult r = q.Push(W(2, {14.5, 15.0}));
  EXPECT_EQ(r.merged_into, 1);
  EXPECT_TRUE(r.dropped.empty());
  EXPECT_EQ(q.size(), 1u);
  EXPECT_EQ(q.merged(), 1u);
  // 4 s after window 2 ends: queued on its own.
  EXPECT_EQ(q.Push(W(3, {19.0, 20.0, 21.0})).merged_into, -1);
  EXPECT_EQ(q.size(), 2u);
  // Window 4 overlaps 3 but would make 9 frames with it: queued alone, and
  // the queue (capacity 2) drops window 1 with the window 2 it had joined.
  const WindowQueue::PushResult full = q.Push(W(4, {21.0, 22.0, 23.0, 24.0, 25.0, 26.0, 27.0}));
  EXPECT_EQ(full.merged_into, -1);
  EXPECT_EQ(full.dropped, (std::vector<int64_t>{1, 2}));
  EXPECT_EQ(q.dropped(), 2u);
  ImageWindow w;
  std::vector<int64_t> joined = {99};
  ASSERT_TRUE(q.Pop(&w, std::chrono::milliseconds(0), &joined));
  EXPECT_EQ(w.id, 3);
  EXPECT_TRUE(joined.empty());
  ASSERT_TRUE(q.Pop(&w, std::chrono::milliseconds(0), &joined));
  EXPECT_EQ(w.id, 4);
}

TEST(WindowQueueTest, HistoryHasTheLengthAfterEveryChange) {
  WindowQueue q({2, 3.0, 300});
  q.Push(W(1, {1.0}));
  q.Push(W(2, {2.0}));   // joins: the length stays 1, nothing recorded
  q.Push(W(3, {10.0}));
  q.Push(W(4, {20.0}));  // drops 1: still 2
  ImageWindow w;
  q.Pop(&w, std::chrono::milliseconds(0));
  const auto h = q.History();
  std::vector<size_t> lengths;
  for (const auto& e : h) lengths.push_back(e.second);
  EXPECT_EQ(lengths, (std::vector<size_t>{1, 2, 2, 1}));
  for (size_t k = 1; k < h.size(); ++k) EXPECT_GE(h[k].first, h[k - 1].first);
}

TEST(WindowQueueTest, JoinedWindowsComeOutTogether) {
  WindowQueue q({4, 3.0, 300});
  q.Push(W(7, {1.0, 2.0}));
  q.Push(W(8, {2.0, 3.0}));  // overlaps
  q.Push(W(9, {5.5}));       // 2.5 s after the joined end
  ImageWindow w;
  std::vector<int64_t> joined;
  ASSERT_TRUE(q.Pop(&w, std::chrono::milliseconds(0), &joined));
  EXPECT_EQ(w.id, 7);
  EXPECT_EQ(joined, (std::vector<int64_t>{8, 9}));
  EXPECT_EQ(w.frames.size(), 4u);
  // Nothing waits: a window cannot join one being built.
  EXPECT_EQ(q.Push(W(10, {6.0})).merged_into, -1);
  // A sealed window (a retry) neither takes others nor joins one.
  q.Pop(&w, std::chrono::milliseconds(0));
  EXPECT_EQ(q.Push(W(11, {7.0}), /*sealed=*/true).merged_into, -1);
  EXPECT_EQ(q.Push(W(12, {7.5})).merged_into, -1);
  EXPECT_EQ(q.Push(W(13, {7.6}), /*sealed=*/true).merged_into, -1);
  EXPECT_EQ(q.size(), 3u);
}

}  // namespace
}  // namespace rumi
