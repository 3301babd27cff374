#include "back/window_queue.h"

#include <algorithm>

namespace rumi {
namespace {

bool SameCamera(const PinholeCameraOptions& a, const PinholeCameraOptions& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy && a.cx == b.cx &&
         a.cy == b.cy && a.k1 == b.k1 && a.k2 == b.k2 && a.p1 == b.p1 && a.p2 == b.p2 && a.k3 == b.k3 &&
         a.flipped_y == b.flipped_y;
}

// Which sample of one frame to keep: the densest set's.
int Rank(SampleSet s) { return s == SampleSet::kS2 ? 2 : s == SampleSet::kS3 ? 1 : 0; }

}  // namespace

bool MergeWindows(ImageWindow* into, const ImageWindow& w, int max_frames) {
  if (!SameCamera(into->camera, w.camera)) return false;
  std::vector<WindowFrame> frames;
  frames.reserve(into->frames.size() + w.frames.size());
  size_t i = 0, j = 0;
  while (i < into->frames.size() || j < w.frames.size()) {
    if (j == w.frames.size() || (i < into->frames.size() && into->frames[i].timestamp < w.frames[j].timestamp)) {
      frames.push_back(into->frames[i++]);
    } else if (i == into->frames.size() || w.frames[j].timestamp < into->frames[i].timestamp) {
      frames.push_back(w.frames[j++]);
    } else {  // one frame in both
      frames.push_back(Rank(w.frames[j].set) > Rank(into->frames[i].set) ? w.frames[j] : into->frames[i]);
      ++i, ++j;
    }
  }
  if (static_cast<int>(frames.size()) > max_frames) return false;
  into->frames = std::move(frames);
  if (!w.frames.empty()) into->joined_at.push_back(w.frames.front().timestamp);
  into->joined_at.insert(into->joined_at.end(), w.joined_at.begin(), w.joined_at.end());
  std::sort(into->joined_at.begin(), into->joined_at.end());
  return true;
}

WindowQueue::WindowQueue(WindowQueueOptions options) : o_(options) { o_.capacity = std::max<size_t>(o_.capacity, 1); }

WindowQueue::PushResult WindowQueue::Push(ImageWindow window, bool sealed) {
  PushResult r;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (o_.merge_gap_s >= 0 && !sealed && !queue_.empty() && !queue_.back().sealed && !window.frames.empty() &&
        !queue_.back().window.frames.empty()) {
      Entry& last = queue_.back();
      const double gap = NsToSeconds(window.frames.front().timestamp - last.window.frames.back().timestamp);
      if (gap <= o_.merge_gap_s && MergeWindows(&last.window, window, o_.merge_max_frames)) {
        r.merged_into = last.window.id;
        last.joined.push_back(window.id);
        ++merged_;
        return r;  // nothing new to wake for: the window it joined was there already
      }
    }
    while (queue_.size() >= o_.capacity) {
      r.dropped.push_back(queue_.front().window.id);
      for (int64_t j : queue_.front().joined) r.dropped.push_back(j);
      dropped_ += 1 + queue_.front().joined.size();
      queue_.pop_front();
    }
    queue_.push_back({std::move(window), {}, sealed});
    Record();
  }
  cv_.notify_one();
  return r;
}

bool WindowQueue::Pop(ImageWindow* window, std::chrono::milliseconds timeout, std::vector<int64_t>* joined) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!cv_.wait_for(lock, timeout, [this] { return closed_ || !queue_.empty(); })) return false;
  if (queue_.empty()) return false;
  *window = std::move(queue_.front().window);
  if (joined) *joined = std::move(queue_.front().joined);
  queue_.pop_front();
  Record();
  return true;
}

void WindowQueue::Record() {
  history_.emplace_back(WallNowNs(), queue_.size());
  while (history_.size() > kHistory) history_.pop_front();
}

std::vector<std::pair<Timestamp, size_t>> WindowQueue::History() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return {history_.begin(), history_.end()};
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

uint64_t WindowQueue::merged() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return merged_;
}

}  // namespace rumi
