#pragma once
// The windows waiting for the back (one is built at a time). A window that
// starts within merge_gap_s of the end of the last waiting one (or overlaps
// it) joins it, so close losses cost one COLMAP run, not two, and the queue
// keeps their frames instead of dropping them. When the queue is full, the
// oldest waiting window is dropped: a newer window covers more recent frames,
// which the manager needs more. Merges and drops are counted.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <vector>

#include "common/window.h"

namespace rumi {

struct WindowQueueOptions {
  size_t capacity = 2;         // windows waiting
  double merge_gap_s = 3.0;    // joins the last waiting window when it starts this close to its end; < 0: never
  int merge_max_frames = 300;  // a join that would exceed this many frames is not made
};

// Joins w into `into` when both have the same camera and the union has at
// most max_frames frames: frames in time order, one per timestamp (the dense
// S2 sample wins over S3, S3 over S1). False (both untouched) otherwise.
bool MergeWindows(ImageWindow* into, const ImageWindow& w, int max_frames);

class WindowQueue {
 public:
  explicit WindowQueue(WindowQueueOptions options);

  struct PushResult {
    int64_t merged_into = -1;      // the waiting window it joined; -1: queued on its own
    std::vector<int64_t> dropped;  // windows dropped to make room (and the ones they had joined)
  };
  // sealed: nothing joins it, and it joins nothing (a window retried after
  // the back died on it must not take other windows down with it).
  PushResult Push(ImageWindow window, bool sealed = false);
  // Waits up to timeout for a window; false on timeout or after Close().
  // *joined gets the ids of the windows that joined it.
  bool Pop(ImageWindow* window, std::chrono::milliseconds timeout, std::vector<int64_t>* joined = nullptr);
  void Close();

  size_t size() const;
  uint64_t dropped() const;
  uint64_t merged() const;
  // (system-clock time, length) after every change of the length, the last
  // kHistory of them: the stress benchmark's queue over time.
  static constexpr size_t kHistory = 4096;
  std::vector<std::pair<Timestamp, size_t>> History() const;

 private:
  WindowQueueOptions o_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  struct Entry {
    ImageWindow window;
    std::vector<int64_t> joined;  // ids of the windows merged into it
    bool sealed = false;
  };
  void Record();  // appends to history_ (mutex_ held)
  std::deque<Entry> queue_;
  std::deque<std::pair<Timestamp, size_t>> history_;
  uint64_t dropped_ = 0, merged_ = 0;
  bool closed_ = false;
};

}  // namespace rumi
