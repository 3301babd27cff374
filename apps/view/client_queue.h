#pragma once
// One browser's live stream: the messages waiting for it. Push never
// blocks and never grows the queue past its capacity: a slow or vanished
// browser loses its oldest messages (counted), while the feed that pushes
// and every other browser go on.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <string>

namespace rumi {

class ClientQueue {
 public:
  explicit ClientQueue(size_t capacity) : capacity_(capacity < 1 ? 1 : capacity) {}
  void Push(std::string message);
  // The oldest message, waiting at most `wait`; false when none came (a
  // closed queue still hands out what it held, then nothing).
  bool Pop(std::chrono::milliseconds wait, std::string* message);
  void Close();
  bool closed() const;
  int64_t dropped() const;
  size_t size() const;

 private:
  const size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::string> messages_;
  int64_t dropped_ = 0;
  bool closed_ = false;
};

}  // namespace rumi
