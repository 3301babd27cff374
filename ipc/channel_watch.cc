#include "ipc/channel_watch.h"

#include <spdlog/spdlog.h>

#include <thread>

#include "common/timestamp.h"

namespace rumi {

const char* ToString(ProducerEnd e) {
  switch (e) {
    case ProducerEnd::kRunning: return "running";
    case ProducerEnd::kClosed: return "closed";
    case ProducerEnd::kDied: return "died";
    case ProducerEnd::kNeverAppeared: return "never_appeared";
  }
  return "?";
}

ProducerWatch::ProducerWatch(std::string what, double wait_for_producer_s)
    : what_(std::move(what)), wait_s_(wait_for_producer_s), start_(std::chrono::steady_clock::now()) {}

void ProducerWatch::Update(RingConsumer& ring, PopStatus st, uint64_t closed_before) {
  if (st == PopStatus::kIncompatible && ring.last_error() != last_error_) {
    last_error_ = ring.last_error();
    spdlog::error("{} channel: {}", what_, last_error_);
  }
  const bool connected = ring.connected();
  const bool closed = ring.closed_segments() != closed_before;
  if (connected && (!seen_ || end_ == ProducerEnd::kClosed || end_ == ProducerEnd::kNeverAppeared)) {
    spdlog::info("{} producer attached ({})", what_, ring.name());
    end_ = ProducerEnd::kRunning;
  }
  seen_ |= connected || closed;
  if (st == PopStatus::kOk) {
    if (end_ == ProducerEnd::kDied) spdlog::info("{} producer is back", what_);
    end_ = ProducerEnd::kRunning;
    return;
  }
  if (closed && !connected) {
    // Left a closed, drained segment (and no new producer's segment yet).
    spdlog::info("{} producer closed its channel (drained)", what_);
    end_ = ProducerEnd::kClosed;
  } else if (connected && st == PopStatus::kEmpty && SecondsSince(last_liveness_check_) > 0.5) {
    // A crashed producer leaves its segment: dead pid + empty ring = ended,
    // until a restarted producer takes the segment over.
    last_liveness_check_ = std::chrono::steady_clock::now();
    const RingStats rs = ring.Stats();
    const bool dead = rs.producer_pid != 0 && !rs.producer_alive && !rs.closed && rs.head == rs.tail;
    if (dead && end_ != ProducerEnd::kDied) {
      spdlog::warn("{} producer (pid {}) died without closing its channel", what_, rs.producer_pid);
      end_ = ProducerEnd::kDied;
    } else if (!dead && end_ == ProducerEnd::kDied) {
      spdlog::info("{} producer is back (pid {})", what_, rs.producer_pid);
      end_ = ProducerEnd::kRunning;
    }
  } else if (!seen_ && !ended() && wait_s_ > 0 && SecondsSince(start_) > wait_s_) {
    spdlog::warn("no {} producer appeared within {} s", what_, wait_s_);
    end_ = ProducerEnd::kNeverAppeared;
  }
}

ConsumerProgress Consumer(const RingStats& s, bool attach_deadline_passed) {
  if (s.consumer_alive) return s.tail >= s.head ? ConsumerProgress::kDone : ConsumerProgress::kWaiting;
  if (s.consumer_generation > 0 || attach_deadline_passed) return ConsumerProgress::kGone;
  return ConsumerProgress::kWaiting;
}

ConsumerProgress WaitForConsumer(RingProducer& ring, double wait_s, const std::atomic<bool>* stop) {
  const auto start = std::chrono::steady_clock::now();
  for (;;) {
    const RingStats rs = ring.Stats();
    const bool out_of_time = SecondsSince(start) > wait_s;
    const ConsumerProgress p = Consumer(rs, out_of_time);
    if (p == ConsumerProgress::kDone) {
      spdlog::info("{}: the consumer has read all {} message(s)", ring.name(), rs.head);
      return p;
    }
    if (p == ConsumerProgress::kGone || out_of_time || (stop && stop->load())) {
      if (rs.tail < rs.head)
        spdlog::warn("{}: closing with {} of {} message(s) read (consumer {})", ring.name(), rs.tail, rs.head,
                     rs.consumer_alive ? "still reading" : (rs.consumer_generation > 0 ? "gone" : "never attached"));
      return p;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

}  // namespace rumi
