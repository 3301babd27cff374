#include "back/window_queue.h"

namespace rumi {

bool WindowQueue::Push(ImageWindow window, std::vector<int64_t>* dropped_ids) {
  bool dropped = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    while (queue_.size() >= capacity_) {
      if (dropped_ids) dropped_ids->push_back(queue_.front().id);
      queue_.pop_front();
      ++dropped_;
      dropped = true;
    }
    queue_.push_back(std::move(window));
  }
  cv_.notify_one();
  return !dropped;
}

bool WindowQueue::Pop(ImageWindow* window, std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!cv_.wait_for(lock, timeout, [this] { return closed_ || !queue_.empty(); })) return false;
  if (queue_.empty()) return false;
  *window = std::move(queue_.front());
  queue_.pop_front();
  return true;
}

void WindowQueue::Close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
  }
  cv_.notify_all();
}

size_t WindowQueue::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return queue_.size();
}

uint64_t WindowQueue::dropped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dropped_;
}

}  // namespace rumi
