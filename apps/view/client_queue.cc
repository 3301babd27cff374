#include "apps/view/client_queue.h"

namespace rumi {

void ClientQueue::Push(std::string message) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_) return;
    if (messages_.size() >= capacity_) {
      messages_.pop_front();
      ++dropped_;
    }
    messages_.push_back(std::move(message));
  }
  cv_.notify_one();
}

bool ClientQueue::Pop(std::chrono::milliseconds wait, std::string* message) {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait_for(lock, wait, [this] { return closed_ || !messages_.empty(); });
  if (messages_.empty()) return false;  // what was queued before a close still goes out
  *message = std::move(messages_.front());
  messages_.pop_front();
  return true;
}

void ClientQueue::Close() {
  std::lock_guard<std::mutex> lock(mutex_);
  closed_ = true;
  cv_.notify_all();  // every stream thread waiting in Pop wakes and ends
}

bool ClientQueue::closed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return closed_;
}

int64_t ClientQueue::dropped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dropped_;
}

size_t ClientQueue::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return messages_.size();
}

}  // namespace rumi
