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

Timestamp FrameReplay::NextListed(Timestamp t) const {
  const std::vector<Timestamp>& ts = source_->timestamps();
  auto it = std::upper_bound(ts.begin(), ts.end(), t);
  return it == ts.end() ? -1 : *it;
}

bool FrameReplay::Next(Frame* frame, std::vector<Timestamp>* skipped, const std::atomic<bool>* stop) {
  for (;;) {
    if (stop && stop->load()) return false;
    if (!source_->Next(frame)) return false;
    if (o_.max) {
      ++delivered_;
      return true;
    }
    if (!started_) {
      started_ = true;
      t0_ = frame->timestamp;
      wall0_ = clock_->NowNs();
    }
    // A newer frame has already "arrived": this one was overwritten in the
    // camera's buffer while the consumer was busy.
    const Timestamp next = NextListed(frame->timestamp);
    if (next >= 0 && clock_->NowNs() >= DueNs(next)) {
      ++skipped_;
      if (skipped) skipped->push_back(frame->timestamp);
      continue;
    }
    clock_->SleepUntilNs(DueNs(frame->timestamp), stop);
    if (stop && stop->load()) return false;
    ++delivered_;
    return true;
  }
}

}  // namespace rumi
