#include "front/frame_replay.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <thread>

namespace rumi {

int64_t SteadyReplayClock::NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

void SteadyReplayClock::SleepUntilNs(int64_t t_ns, const std::atomic<bool>* stop) {
  constexpr int64_t kSliceNs = 50'000'000;
  for (;;) {
    if (stop && stop->load()) return;
    const int64_t left = t_ns - NowNs();
    if (left <= 0) return;
    std::this_thread::sleep_for(std::chrono::nanoseconds(std::min(left, kSliceNs)));
  }
}

bool FrameReplayOptions::Check(std::string* why) const {
  if (!max && !(rate > 0 && std::isfinite(rate))) {
    if (why) *why = "rate must be a positive number or max";
    return false;
  }
  return true;
}

bool ParseReplayRate(const std::string& text, FrameReplayOptions* o) {
  if (text == "max") {
    o->max = true;
    return true;
  }
  if (text.empty()) return false;
  char* end = nullptr;
  const double r = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !(r > 0) || !std::isfinite(r)) return false;
  o->max = false;
  o->rate = r;
  return true;
}

FrameReplay::FrameReplay(FrameSource* source, const FrameReplayOptions& options, ReplayClock* clock)
    : source_(source), o_(options), clock_(clock ? clock : &steady_) {}

int64_t FrameReplay::DueNs(Timestamp t) const {
  return wall0_ + static_cast<int64_t>(std::llround(static_cast<double>(t - t0_) / o_.rate));
}

Timestamp FrameReplay::NextStreamTime(size_t i) const {
  const std::vector<Timestamp>& ts = source_->timestamps();
  if (i + 1 < ts.size()) return ts[i + 1] + offset_;
  return o_.loop && !ts.empty() ? ts.front() + offset_ + period_ : -1;
}

bool FrameReplay::Next(Frame* frame, std::vector<Timestamp>* skipped, const std::atomic<bool>* stop) {
  const std::vector<Timestamp>& ts = source_->timestamps();
  if (!started_) {
    started_ = true;
    t0_ = ts.empty() ? 0 : ts.front();
    wall0_ = o_.start_ns > 0 ? o_.start_ns : clock_->NowNs();
    if (ts.size() >= 2) {
      std::vector<Timestamp> dt(ts.size() - 1);
      for (size_t i = 1; i < ts.size(); ++i) dt[i - 1] = ts[i] - ts[i - 1];
      std::nth_element(dt.begin(), dt.begin() + dt.size() / 2, dt.end());
      period_ = ts.back() - ts.front() + dt[dt.size() / 2];
    }
  }
  for (;;) {
    if (stop && stop->load()) return false;
    if (index_ >= ts.size()) {  // end of the list
      if (!o_.loop || period_ <= 0) return false;
      source_->Rewind();
      index_ = 0;
      offset_ += period_;
      ++loops_;
    }
    const Timestamp t = ts[index_] + offset_;
    if (!o_.max) {
      // A newer frame has already "arrived": this one was overwritten in the
      // camera's buffer while the consumer was busy (or nobody was there).
      const Timestamp next = NextStreamTime(index_);
      if (next >= 0 && clock_->NowNs() >= DueNs(next)) {
        source_->Skip();
        ++index_;
        ++skipped_;
        if (skipped) skipped->push_back(t);
        continue;
      }
    }
    if (!source_->Next(frame)) {  // only unreadable frames were left
      index_ = ts.size();
      continue;
    }
    // The source passes over unreadable images: follow it.
    index_ = static_cast<size_t>(std::upper_bound(ts.begin(), ts.end(), frame->timestamp) - ts.begin());
    frame->timestamp += offset_;
    if (!o_.max) {
      clock_->SleepUntilNs(DueNs(frame->timestamp), stop);
      if (stop && stop->load()) return false;
    }
    ++delivered_;
    return true;
  }
}

}  // namespace rumi
