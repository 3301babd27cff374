#pragma once
// Replays a FrameSource as a camera would deliver it: frame i is due at
// (t_i - t_0) / rate after the first frame was read, or as fast as possible
// (`max`). A consumer that is still busy when a later frame is already due
// misses the frames in between, as with a live camera that only keeps the
// newest image: frame i is skipped when frame i+1 is already due. Skipped
// frames are reported, so the per-frame log can show them as not tracked.
// The clock is injected so tests run deterministically without sleeping.
#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "common/dataset.h"

namespace rumi {

class ReplayClock {
 public:
  virtual ~ReplayClock() = default;
  virtual int64_t NowNs() = 0;
  // Sleeps until NowNs() >= t_ns, or returns early when *stop becomes true.
  virtual void SleepUntilNs(int64_t t_ns, const std::atomic<bool>* stop) = 0;
};

// std::chrono::steady_clock; sleeps in slices of at most 50 ms to notice stop.
class SteadyReplayClock : public ReplayClock {
 public:
  int64_t NowNs() override;
  void SleepUntilNs(int64_t t_ns, const std::atomic<bool>* stop) override;
};

struct FrameReplayOptions {
  double rate = 1.0;       // x recorded speed
  bool max = false;        // as fast as possible: no pacing, no skipping
  // At the end, start again; timestamps go on increasing (one period = the
  // sequence's duration + its median frame interval), so frame identity
  // stays unique (rumid's soak runs, a dataset as an endless camera).
  bool loop = false;
  // Clock time (ReplayClock::NowNs) at which the first frame is due; 0: when
  // it is read. A later start skips what is past without reading it: a
  // restarted front joins the stream where it is, as with a live camera.
  int64_t start_ns = 0;
  bool Check(std::string* why = nullptr) const;
};
// "max" or a positive number ("1", "0.5", "2.0"); false for anything else.
bool ParseReplayRate(const std::string& text, FrameReplayOptions* o);

class FrameReplay {
 public:
  // source and clock must outlive the replay; clock nullptr: steady clock.
  FrameReplay(FrameSource* source, const FrameReplayOptions& options, ReplayClock* clock = nullptr);

  // Next frame to process, after waiting until it is due. Frames that were
  // overtaken meanwhile are appended to *skipped (timestamps, time order)
  // when skipped is not null. False at the end of the stream or on *stop.
  bool Next(Frame* frame, std::vector<Timestamp>* skipped = nullptr, const std::atomic<bool>* stop = nullptr);

  size_t delivered() const { return delivered_; }
  size_t skipped() const { return skipped_; }
  int loops() const { return loops_; }        // times the sequence started again
  Timestamp offset() const { return offset_; }  // added to the listed timestamps now

 private:
  int64_t DueNs(Timestamp t) const;
  // Stream time of the listed frame after index i, or -1 (none).
  Timestamp NextStreamTime(size_t i) const;

  FrameSource* source_;
  FrameReplayOptions o_;
  SteadyReplayClock steady_;
  ReplayClock* clock_;
  bool started_ = false;
  Timestamp t0_ = 0;
  int64_t wall0_ = 0;
  size_t index_ = 0;      // listed frame the source reads next
  Timestamp offset_ = 0;  // loops x period
  Timestamp period_ = 0;
  int loops_ = 0;
  size_t delivered_ = 0, skipped_ = 0;
};

}  // namespace rumi
