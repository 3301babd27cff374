#pragma once
// Bounded queue of windows waiting for the back (one is processed at a time).
// When full, the oldest waiting window is dropped: a newer window covers more
// recent frames, which the manager needs more. Drops are counted.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <vector>

#include "common/window.h"

namespace rumi {

class WindowQueue {
 public:
  explicit WindowQueue(size_t capacity) : capacity_(capacity < 1 ? 1 : capacity) {}

  // Returns false when a window had to be dropped to make room; the ids of
  // the dropped ones go to *dropped_ids when given.
  bool Push(ImageWindow window, std::vector<int64_t>* dropped_ids = nullptr);
  // Waits up to timeout for a window; false on timeout or after Close().
  bool Pop(ImageWindow* window, std::chrono::milliseconds timeout);
  void Close();

  size_t size() const;
  uint64_t dropped() const;

 private:
  const size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<ImageWindow> queue_;
  uint64_t dropped_ = 0;
  bool closed_ = false;
};

}  // namespace rumi
