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

TEST(WindowQueueTest, DropsOldestWhenFull) {
  WindowQueue q(2);
  EXPECT_TRUE(q.Push(W(1)));
  EXPECT_TRUE(q.Push(W(2)));
  EXPECT_FALSE(q.Push(W(3)));  // drops 1
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
  WindowQueue q(1);
  std::thread t([&] { q.Push(W(9)); });
  ImageWindow w;
  EXPECT_TRUE(q.Pop(&w, std::chrono::seconds(10)));
  EXPECT_EQ(w.id, 9);
  t.join();
  std::thread c([&] { q.Close(); });
  EXPECT_FALSE(q.Pop(&w, std::chrono::seconds(10)));
  c.join();
}

}  // namespace
}  // namespace rumi
