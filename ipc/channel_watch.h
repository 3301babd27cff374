#pragma once
// What each end of a channel knows about the other, written once for the
// front, the back and the manager.
//
// ProducerWatch (consumer side): after every receive attempt it tells whether
// the producer is running, closed its channel (end of stream, drained), died
// without closing it (a crash: dead pid and an empty ring), or never appeared
// within a deadline. A producer that comes back (a restart) undoes the end.
//
// ConsumerProgress / WaitForConsumer (producer side): whether the consumer
// has read everything, is still reading, or is gone; a producer that closes
// its channel before the consumer read it takes the messages with it.
#include <atomic>
#include <chrono>
#include <string>

#include "ipc/shm_ring.h"

namespace rumi {

enum class ProducerEnd { kRunning, kClosed, kDied, kNeverAppeared };
const char* ToString(ProducerEnd e);

class ProducerWatch {
 public:
  // what: "front submaps", for the log lines. wait_for_producer_s: a producer
  // not seen after this long counts as never appeared (0: wait forever).
  ProducerWatch(std::string what, double wait_for_producer_s);
  // Call after each receive attempt on `ring`: st is what it returned,
  // closed_before the ring's closed_segments() before the attempt.
  void Update(RingConsumer& ring, PopStatus st, uint64_t closed_before);
  ProducerEnd end() const { return end_; }
  bool ended() const { return end_ != ProducerEnd::kRunning; }
  bool seen() const { return seen_; }  // a producer's segment was attached at least once

 private:
  std::string what_;
  double wait_s_;
  std::chrono::steady_clock::time_point start_, last_liveness_check_{};
  bool seen_ = false;
  ProducerEnd end_ = ProducerEnd::kRunning;
  std::string last_error_;
};

enum class ConsumerProgress { kWaiting, kDone, kGone };
// Done: attached and has read everything. Gone: attached once and left or
// died, or never attached before attach_deadline passed. Else waiting.
ConsumerProgress Consumer(const RingStats& s, bool attach_deadline_passed);

// Waits (bounded by wait_s, or a set *stop) until the consumer of `ring` has
// read everything or is gone. Returns the last progress seen.
ConsumerProgress WaitForConsumer(RingProducer& ring, double wait_s, const std::atomic<bool>* stop);

}  // namespace rumi
