#pragma once
// Bounded single-producer / single-consumer ring of byte messages in a POSIX
// shared-memory segment (Boost.Interprocess shared_memory_object).
//
// Realtime rule: the producer never waits. Push either publishes (kOk) or
// drops (kDropped / kTooLarge) and counts it in the segment; no lock is ever
// taken, so a consumer that is slow, stopped or SIGKILLed costs nothing.
// Synchronisation is one atomic state word per slot (seq << 2 | tag) plus the
// producer's head and consumer's tail counters. The consumer reads a message
// in place and releases the slot afterwards.
//
// Crash recovery: each side records (pid, start time) in the header. A new
// producer takes over a segment whose producer is dead (continuing its
// sequence), a new consumer takes over from a dead consumer (the message the
// dead one was reading is delivered again). With kDropOldest, a producer that
// finds the oldest slot held by a dead reader reclaims it. A segment with a
// different layout is replaced only when nobody alive uses it; otherwise both
// sides refuse with an error naming both layouts.
//
// The producer owns the segment: it creates it and removes it on clean exit
// (marking it closed first, so a consumer reattaches to the next one), or
// leaves it closed for a consumer that attaches later (KeepSegmentOnClose: a
// consumer attaches to a closed segment only while it holds unread messages).
#include <atomic>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>

#include "common/process/process_info.h"

namespace rumi {

enum class OverflowPolicy : uint32_t {
  kDropNewest = 0,  // full ring: the message being pushed is refused (caller knows which)
  kDropOldest = 1,  // full ring: the oldest unread message is overwritten
};
const char* ToString(OverflowPolicy p);
bool ParseOverflowPolicy(const std::string& s, OverflowPolicy* p);

enum class PushStatus { kOk, kDropped, kTooLarge };
const char* ToString(PushStatus s);

enum class PopStatus { kOk, kEmpty, kNotConnected, kIncompatible };
const char* ToString(PopStatus s);

class IpcError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

constexpr uint64_t kRingMagic = 0x474e4952494d5552ULL;  // "RUMIRING"
constexpr uint32_t kRingLayoutVersion = 1;

static_assert(std::atomic<uint64_t>::is_always_lock_free,
              "shared-memory atomics must be lock-free (address-free)");

// The segment header. Everything after `ready` that changes at run time is an
// atomic; the rest is written once before `ready` is published.
struct alignas(64) RingHeader {
  uint64_t magic;
  uint32_t layout_version;
  uint32_t header_bytes;
  uint64_t slot_count;
  uint64_t slot_bytes;   // payload capacity of one slot
  uint64_t slot_stride;  // bytes from one slot header to the next
  uint64_t segment_bytes;
  char channel[48];
  std::atomic<uint64_t> ready;  // kRingMagic once initialised

  alignas(64) std::atomic<uint64_t> producer_pid;
  std::atomic<uint64_t> producer_start;
  std::atomic<uint64_t> producer_generation;  // +1 per producer attach
  std::atomic<uint64_t> policy;
  std::atomic<uint64_t> closed;               // producer left cleanly
  std::atomic<uint64_t> pushed;
  std::atomic<uint64_t> dropped_full;         // refused: ring full (or oldest being read)
  std::atomic<uint64_t> dropped_oldest;       // overwritten unread (kDropOldest)
  std::atomic<uint64_t> dropped_too_large;
  std::atomic<uint64_t> reclaimed;            // slots taken back from a dead reader
  alignas(64) std::atomic<uint64_t> head;     // next sequence number to publish

  alignas(64) std::atomic<uint64_t> consumer_pid;
  std::atomic<uint64_t> consumer_start;
  std::atomic<uint64_t> consumer_generation;
  std::atomic<uint64_t> popped;
  std::atomic<uint64_t> skipped;              // seen lost by the consumer
  std::atomic<uint64_t> redelivered;          // in flight when a consumer died
  alignas(64) std::atomic<uint64_t> tail;     // next sequence number to consume
};

struct alignas(64) SlotHeader {
  std::atomic<uint64_t> state;  // seq << 2 | tag
  std::atomic<uint64_t> bytes;
};

struct RingLayout {
  uint64_t slot_count = 4;
  uint64_t slot_bytes = 1 << 20;
  OverflowPolicy policy = OverflowPolicy::kDropNewest;
};

// Snapshot of a segment's counters (for status tools and tests).
struct RingStats {
  std::string name;
  uint64_t slot_count = 0, slot_bytes = 0;
  OverflowPolicy policy = OverflowPolicy::kDropNewest;
  uint64_t head = 0, tail = 0;
  uint64_t pushed = 0, popped = 0, dropped_full = 0, dropped_oldest = 0, dropped_too_large = 0;
  uint64_t reclaimed = 0, skipped = 0, redelivered = 0;
  uint64_t producer_pid = 0, consumer_pid = 0;
  bool producer_alive = false, consumer_alive = false, closed = false;
  uint64_t producer_generation = 0, consumer_generation = 0;
};
// Reads a segment without attaching. False with *error when absent or foreign.
bool ReadRingStats(const std::string& segment_name, RingStats* stats, std::string* error = nullptr);
std::string FormatRingStats(const RingStats& s);

// "rumi_<instance>_<channel>".
std::string SegmentName(const std::string& instance, const std::string& channel);
// Removes a segment by name (tests, crash cleanup). True when it existed.
bool RemoveSegment(const std::string& segment_name);

class MappedSegment;

class RingProducer {
 public:
  // Creates or takes over the segment. Throws IpcError when a live producer
  // owns it or a live peer uses another layout.
  RingProducer(const std::string& segment_name, const RingLayout& layout);
  ~RingProducer();  // marks closed and removes the segment
  RingProducer(const RingProducer&) = delete;
  RingProducer& operator=(const RingProducer&) = delete;

  // Publishes `bytes` bytes written by fill(uint8_t* dst) straight into the
  // slot. Never waits.
  template <typename Fill>
  PushStatus Push(size_t bytes, Fill&& fill) {
    uint8_t* dst = nullptr;
    const PushStatus st = Acquire(bytes, &dst);
    if (st != PushStatus::kOk) return st;
    fill(dst);
    Commit(bytes);
    return PushStatus::kOk;
  }
  PushStatus PushCopy(const void* data, size_t bytes);

  // Two-phase form of Push: Acquire a slot, write, then Commit exactly once.
  PushStatus Acquire(size_t bytes, uint8_t** dst);
  void Commit(size_t bytes);

  RingStats Stats() const;
  const std::string& name() const { return name_; }
  uint64_t slot_bytes() const;
  // Leaves the segment in place on destruction (tests simulating a crash).
  void KeepSegmentOnExit() { keep_ = true; }
  // On destruction: mark the channel closed but leave the segment, so a
  // consumer that attaches later still reads what is unread (rumid removes
  // the instance's segments once every process is gone).
  void KeepSegmentOnClose() { remove_on_close_ = false; }

 private:
  std::string name_;
  std::unique_ptr<MappedSegment> seg_;
  RingHeader* hdr_ = nullptr;
  uint64_t head_ = 0;
  bool acquired_ = false;
  bool keep_ = false;
  bool remove_on_close_ = true;
  // Liveness of the consumer, re-checked at most every 100 ms (it costs a
  // syscall and two /proc reads) or when another consumer attached.
  bool ConsumerAlive();
  ProcessId cached_consumer_;
  bool cached_alive_ = true;
  int64_t cached_at_ns_ = 0;
};

class RingConsumer {
 public:
  // Attaches lazily: a missing segment is not an error (the producer may
  // start later); each call retries.
  // expected: when slot_count/slot_bytes are non-zero, a segment of another
  // geometry is refused (kIncompatible, last_error() names both layouts).
  explicit RingConsumer(std::string segment_name, RingLayout expected = {0, 0, OverflowPolicy::kDropNewest});
  ~RingConsumer();
  RingConsumer(const RingConsumer&) = delete;
  RingConsumer& operator=(const RingConsumer&) = delete;

  // Oldest unread message, read in place: *data stays valid until Release().
  // Waits up to timeout_s with bounded sleeps (0: poll once).
  PopStatus Peek(const uint8_t** data, size_t* bytes, double timeout_s = 0.0);
  void Release();

  // Peek + f(data, bytes) + Release.
  template <typename F>
  PopStatus Pop(F&& f, double timeout_s = 0.0) {
    const uint8_t* d = nullptr;
    size_t n = 0;
    const PopStatus st = Peek(&d, &n, timeout_s);
    if (st != PopStatus::kOk) return st;
    f(d, n);
    Release();
    return st;
  }

  bool connected() const { return hdr_ != nullptr; }
  // Segments this consumer left because their producer closed them and they
  // were drained (also counts one attached and left within a single Peek).
  uint64_t closed_segments() const { return closed_segments_; }
  // Why the last attach failed (incompatible layout, another live consumer).
  const std::string& last_error() const { return last_error_; }
  RingStats Stats() const;
  const std::string& name() const { return name_; }
  // Bytes of read messages handed back to the system (Release frees the
  // pages of a message of at least kFreePagesMinBytes).
  uint64_t freed_bytes() const { return freed_bytes_; }
  static constexpr uint64_t kFreePagesMinBytes = 1 << 20;

 private:
  bool TryAttach();
  void FreePages(SlotHeader* slot);
  void Detach();
  PopStatus TryPeekOnce(const uint8_t** data, size_t* bytes);

  std::string name_;
  RingLayout expected_;
  std::unique_ptr<MappedSegment> seg_;
  RingHeader* hdr_ = nullptr;
  uint64_t cursor_ = 0;
  bool holding_ = false;
  uint64_t closed_segments_ = 0;
  uint64_t freed_bytes_ = 0;
  bool free_pages_failed_ = false;
  // Generation of the last closed, drained segment counted without attaching
  // (a consumer that starts after its producer finished: rumid's restarts).
  uint64_t counted_closed_generation_ = 0;
  std::string last_error_;
};

}  // namespace rumi
