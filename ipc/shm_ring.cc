#include "ipc/shm_ring.h"

#include <boost/interprocess/mapped_region.hpp>
#include <boost/interprocess/shared_memory_object.hpp>
#include <spdlog/spdlog.h>

#include <sys/mman.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <new>
#include <thread>

namespace bip = boost::interprocess;

namespace rumi {

class MappedSegment {
 public:
  bip::shared_memory_object shm;
  bip::mapped_region region;
  uint8_t* base() const { return static_cast<uint8_t*>(region.get_address()); }
  size_t size() const { return region.get_size(); }
};

namespace {

constexpr uint64_t kFree = 0, kWriting = 1, kReady = 2, kReading = 3;
constexpr uint64_t kAlign = 64;

uint64_t RoundUp(uint64_t v, uint64_t a) { return (v + a - 1) / a * a; }
uint64_t HeaderBytes() { return RoundUp(sizeof(RingHeader), kAlign); }
uint64_t SlotStride(uint64_t slot_bytes) { return RoundUp(sizeof(SlotHeader) + slot_bytes, kAlign); }

SlotHeader* SlotAt(RingHeader* h, uint64_t index) {
  uint8_t* base = reinterpret_cast<uint8_t*>(h) + HeaderBytes();
  return reinterpret_cast<SlotHeader*>(base + (index % h->slot_count) * h->slot_stride);
}
uint8_t* Payload(SlotHeader* s) { return reinterpret_cast<uint8_t*>(s) + sizeof(SlotHeader); }

std::string Describe(uint64_t count, uint64_t bytes, uint64_t version) {
  return "layout v" + std::to_string(version) + ", " + std::to_string(count) + " slots x " +
         std::to_string(bytes) + " bytes";
}

// Checks that a mapped segment is an initialised ring of our layout version.
// ready == false: still being created (or died while being created).
bool HeaderUsable(const MappedSegment& seg, bool* initialising, std::string* why) {
  *initialising = false;
  if (seg.size() < sizeof(RingHeader)) {
    *why = "segment of " + std::to_string(seg.size()) + " bytes is smaller than a ring header";
    return false;
  }
  const auto* h = reinterpret_cast<const RingHeader*>(seg.base());
  if (h->magic != kRingMagic) {
    if (h->magic == 0) {
      *initialising = true;
      *why = "segment not initialised";
    } else {
      *why = "not a rumi ring (bad magic)";
    }
    return false;
  }
  if (h->layout_version != kRingLayoutVersion || h->header_bytes != sizeof(RingHeader)) {
    *why = "ring layout version " + std::to_string(h->layout_version) + " (header " +
           std::to_string(h->header_bytes) + " bytes), this build speaks version " +
           std::to_string(kRingLayoutVersion) + " (header " + std::to_string(sizeof(RingHeader)) + " bytes)";
    return false;
  }
  if (h->ready.load(std::memory_order_acquire) != kRingMagic) {
    *initialising = true;
    *why = "segment not initialised";
    return false;
  }
  if (h->slot_count == 0 || h->slot_stride != SlotStride(h->slot_bytes) ||
      h->segment_bytes != HeaderBytes() + h->slot_count * h->slot_stride || seg.size() < h->segment_bytes) {
    *why = "inconsistent slot geometry in header";
    return false;
  }
  return true;
}

ProcessId Producer(const RingHeader* h) {
  return {h->producer_pid.load(), h->producer_start.load()};
}
ProcessId Consumer(const RingHeader* h) {
  return {h->consumer_pid.load(), h->consumer_start.load()};
}
bool IsSelf(const ProcessId& id) {
  const ProcessId me = SelfProcessId();
  return id.pid == me.pid && id.start_ticks == me.start_ticks;
}

bool OpenExisting(const std::string& name, bip::mode_t mode, MappedSegment* seg) {
  try {
    bip::shared_memory_object shm(bip::open_only, name.c_str(), mode);
    bip::mapped_region region(shm, mode);
    seg->shm.swap(shm);
    seg->region.swap(region);
    return true;
  } catch (const bip::interprocess_exception&) {
    return false;
  }
}

}  // namespace

const char* ToString(OverflowPolicy p) {
  return p == OverflowPolicy::kDropOldest ? "drop_oldest" : "drop_newest";
}

bool ParseOverflowPolicy(const std::string& s, OverflowPolicy* p) {
  if (s == "drop_newest") {
    *p = OverflowPolicy::kDropNewest;
  } else if (s == "drop_oldest") {
    *p = OverflowPolicy::kDropOldest;
  } else {
    return false;
  }
  return true;
}

const char* ToString(PushStatus s) {
  switch (s) {
    case PushStatus::kOk: return "ok";
    case PushStatus::kDropped: return "dropped";
    case PushStatus::kTooLarge: return "too_large";
  }
  return "?";
}

const char* ToString(PopStatus s) {
  switch (s) {
    case PopStatus::kOk: return "ok";
    case PopStatus::kEmpty: return "empty";
    case PopStatus::kNotConnected: return "not_connected";
    case PopStatus::kIncompatible: return "incompatible";
  }
  return "?";
}

std::string SegmentName(const std::string& instance, const std::string& channel) {
  return "rumi_" + instance + "_" + channel;
}

bool RemoveSegment(const std::string& name) { return bip::shared_memory_object::remove(name.c_str()); }

// ---------------- producer ----------------

RingProducer::RingProducer(const std::string& name, const RingLayout& layout)
    : name_(name), seg_(std::make_unique<MappedSegment>()) {
  if (layout.slot_count < 1 || layout.slot_bytes < 1) throw IpcError(name + ": empty ring layout");
  const uint64_t stride = SlotStride(layout.slot_bytes);
  const uint64_t total = HeaderBytes() + layout.slot_count * stride;

  for (int attempt = 0; attempt < 3 && hdr_ == nullptr; ++attempt) {
    MappedSegment existing;
    if (OpenExisting(name, bip::read_write, &existing)) {
      bool initialising = false;
      std::string why;
      bool usable = HeaderUsable(existing, &initialising, &why);
      auto* h = reinterpret_cast<RingHeader*>(existing.base());
      if (usable && (h->slot_count != layout.slot_count || h->slot_bytes != layout.slot_bytes)) {
        usable = false;
        why = "segment has " + Describe(h->slot_count, h->slot_bytes, h->layout_version) + ", we want " +
              Describe(layout.slot_count, layout.slot_bytes, kRingLayoutVersion);
      }
      const bool has_ids = existing.size() >= sizeof(RingHeader) && h->magic == kRingMagic &&
                           h->header_bytes == sizeof(RingHeader);
      if (!usable) {
        if (has_ids) {
          const ProcessId p = Producer(h), c = Consumer(h);
          if (ProcessAlive(p) && !IsSelf(p)) {
            throw IpcError(name + ": " + why + "; producer pid " + std::to_string(p.pid) +
                           " is alive, refusing to replace the segment");
          }
          if (ProcessAlive(c)) {
            throw IpcError(name + ": " + why + "; consumer pid " + std::to_string(c.pid) +
                           " is alive, refusing to replace the segment");
          }
        }
        spdlog::warn("ipc {}: replacing stale segment ({})", name, why);
        RemoveSegment(name);
        continue;
      }
      const ProcessId p = Producer(h);
      if (ProcessAlive(p) && !IsSelf(p)) {
        throw IpcError(name + ": another producer (pid " + std::to_string(p.pid) +
                       ") is attached; is a second rumi instance using the same instance id?");
      }
      // Take over from a dead (or cleanly gone) producer.
      seg_->shm.swap(existing.shm);
      seg_->region.swap(existing.region);
      hdr_ = h;
      uint64_t head = hdr_->head.load();
      for (uint64_t i = 0; i < hdr_->slot_count; ++i) {
        SlotHeader* s = SlotAt(hdr_, i);
        const uint64_t st = s->state.load();
        if ((st & 3) == kWriting) s->state.store(kFree);  // dead producer was mid-write
        // Published but head not yet advanced when the producer died.
        if ((st & 3) >= kReady && (st >> 2) >= head) head = (st >> 2) + 1;
      }
      hdr_->head.store(head);
      head_ = head;
      spdlog::info("ipc {}: producer took over existing segment (head {}, previous producer pid {})", name,
                   head, p.pid);
    } else {
      try {
        // Frames and maps are the robot's: only the user that runs rumi
        // reads them (Boost's default is 0644, whatever the umask).
        bip::permissions owner_only(0600);
        bip::shared_memory_object shm(bip::create_only, name.c_str(), bip::read_write, owner_only);
        shm.truncate(static_cast<bip::offset_t>(total));
        bip::mapped_region region(shm, bip::read_write);
        seg_->shm.swap(shm);
        seg_->region.swap(region);
      } catch (const bip::interprocess_exception& e) {
        if (attempt == 2) throw IpcError(name + ": cannot create shared memory: " + e.what());
        continue;  // lost a creation race; reopen
      }
      auto* h = new (seg_->base()) RingHeader();  // zero-initialised by truncate
      h->layout_version = kRingLayoutVersion;
      h->header_bytes = sizeof(RingHeader);
      h->slot_count = layout.slot_count;
      h->slot_bytes = layout.slot_bytes;
      h->slot_stride = stride;
      h->segment_bytes = total;
      std::strncpy(h->channel, name.c_str(), sizeof(h->channel) - 1);
      for (uint64_t i = 0; i < layout.slot_count; ++i) {
        new (seg_->base() + HeaderBytes() + i * stride) SlotHeader();
      }
      hdr_ = h;
      head_ = 0;
      h->magic = kRingMagic;
    }
  }
  if (!hdr_) throw IpcError(name + ": could not open or create the segment");
  const ProcessId me = SelfProcessId();
  hdr_->producer_pid.store(me.pid);
  hdr_->producer_start.store(me.start_ticks);
  hdr_->producer_generation.fetch_add(1);
  hdr_->policy.store(static_cast<uint64_t>(layout.policy));
  hdr_->closed.store(0);
  hdr_->ready.store(kRingMagic, std::memory_order_release);
}

RingProducer::~RingProducer() {
  if (!hdr_) return;
  if (keep_) {
    return;  // as if the process died: header keeps our pid
  }
  hdr_->producer_pid.store(0);
  hdr_->closed.store(1, std::memory_order_release);
  if (remove_on_close_) RemoveSegment(name_);
}

uint64_t RingProducer::slot_bytes() const { return hdr_->slot_bytes; }

PushStatus RingProducer::Acquire(size_t bytes, uint8_t** dst) {
  if (bytes > hdr_->slot_bytes) {
    hdr_->dropped_too_large.fetch_add(1, std::memory_order_relaxed);
    return PushStatus::kTooLarge;
  }
  const uint64_t h = head_;
  const auto policy = static_cast<OverflowPolicy>(hdr_->policy.load(std::memory_order_relaxed));
  SlotHeader* slot = SlotAt(hdr_, h);
  uint64_t s = slot->state.load(std::memory_order_acquire);
  const uint64_t mine = h << 2 | kWriting;
  for (int tries = 0;; ++tries) {
    const uint64_t tag = s & 3;
    if (tries >= 4) {
      hdr_->dropped_full.fetch_add(1, std::memory_order_relaxed);
      return PushStatus::kDropped;
    }
    if (tag == kFree || tag == kWriting) {
      // Nobody but the producer moves a slot out of kFree.
      slot->state.store(mine, std::memory_order_relaxed);
      break;
    }
    if (tag == kReady) {
      if (policy == OverflowPolicy::kDropNewest) {
        hdr_->dropped_full.fetch_add(1, std::memory_order_relaxed);
        return PushStatus::kDropped;
      }
      if (slot->state.compare_exchange_strong(s, mine, std::memory_order_acq_rel)) {
        hdr_->dropped_oldest.fetch_add(1, std::memory_order_relaxed);
        break;
      }
      continue;  // the consumer got there first; s reloaded
    }
    // kReading: the consumer holds the oldest message.
    if (policy == OverflowPolicy::kDropNewest || ConsumerAlive()) {
      hdr_->dropped_full.fetch_add(1, std::memory_order_relaxed);
      return PushStatus::kDropped;
    }
    if (slot->state.compare_exchange_strong(s, mine, std::memory_order_acq_rel)) {
      hdr_->reclaimed.fetch_add(1, std::memory_order_relaxed);
      hdr_->dropped_oldest.fetch_add(1, std::memory_order_relaxed);
      break;
    }
  }
  // Make the kWriting mark visible before the payload is touched.
  std::atomic_thread_fence(std::memory_order_seq_cst);
  *dst = Payload(slot);
  acquired_ = true;
  return PushStatus::kOk;
}

bool RingProducer::ConsumerAlive() {
  const ProcessId c = Consumer(hdr_);
  const int64_t now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                          std::chrono::steady_clock::now().time_since_epoch())
                          .count();
  if (c.pid != cached_consumer_.pid || c.start_ticks != cached_consumer_.start_ticks ||
      now - cached_at_ns_ > 100000000) {
    cached_consumer_ = c;
    cached_alive_ = ProcessAlive(c);
    cached_at_ns_ = now;
  }
  return cached_alive_;
}

void RingProducer::Commit(size_t bytes) {
  if (!acquired_) throw IpcError(name_ + ": Commit without Acquire");
  acquired_ = false;
  SlotHeader* slot = SlotAt(hdr_, head_);
  slot->bytes.store(bytes, std::memory_order_relaxed);
  slot->state.store(head_ << 2 | kReady, std::memory_order_release);
  ++head_;
  hdr_->head.store(head_, std::memory_order_release);
  hdr_->pushed.fetch_add(1, std::memory_order_relaxed);
}

PushStatus RingProducer::PushCopy(const void* data, size_t bytes) {
  return Push(bytes, [&](uint8_t* dst) { std::memcpy(dst, data, bytes); });
}

RingStats RingProducer::Stats() const {
  RingStats s;
  ReadRingStats(name_, &s);
  return s;
}

// ---------------- consumer ----------------

RingConsumer::RingConsumer(std::string name, RingLayout expected)
    : name_(std::move(name)), expected_(expected) {}

RingConsumer::~RingConsumer() { Detach(); }

void RingConsumer::Detach() {
  if (!hdr_) return;
  if (holding_) {  // hand the unfinished message to whoever attaches next
    SlotAt(hdr_, cursor_)->state.store(cursor_ << 2 | kReady, std::memory_order_release);
    holding_ = false;
  }
  if (IsSelf(Consumer(hdr_))) hdr_->consumer_pid.store(0);
  hdr_ = nullptr;
  seg_.reset();
}

bool RingConsumer::TryAttach() {
  auto seg = std::make_unique<MappedSegment>();
  if (!OpenExisting(name_, bip::read_write, seg.get())) {
    last_error_.clear();
    return false;
  }
  bool initialising = false;
  std::string why;
  if (!HeaderUsable(*seg, &initialising, &why)) {
    last_error_ = initialising ? "" : name_ + ": " + why;
    return false;
  }
  auto* h = reinterpret_cast<RingHeader*>(seg->base());
  if (expected_.slot_count != 0 &&
      (h->slot_count != expected_.slot_count || h->slot_bytes != expected_.slot_bytes)) {
    last_error_ = name_ + ": segment has " + Describe(h->slot_count, h->slot_bytes, h->layout_version) +
                  ", we expect " + Describe(expected_.slot_count, expected_.slot_bytes, kRingLayoutVersion);
    return false;
  }
  if (h->closed.load(std::memory_order_acquire) && h->tail.load() >= h->head.load()) {
    // The producer left and nothing is unread: it finished (counted once), and
    // the next producer makes the segment new.
    const uint64_t generation = h->producer_generation.load();
    if (generation != counted_closed_generation_) {
      counted_closed_generation_ = generation;
      ++closed_segments_;
    }
    last_error_.clear();
    return false;
  }
  const ProcessId c = Consumer(h);
  if (ProcessAlive(c) && !IsSelf(c)) {
    last_error_ = name_ + ": another consumer (pid " + std::to_string(c.pid) + ") is attached";
    return false;
  }
  const ProcessId me = SelfProcessId();
  h->consumer_pid.store(me.pid);
  h->consumer_start.store(me.start_ticks);
  h->consumer_generation.fetch_add(1);
  // The message a dead consumer was reading is delivered again.
  for (uint64_t i = 0; i < h->slot_count; ++i) {
    SlotHeader* s = SlotAt(h, i);
    uint64_t st = s->state.load();
    if ((st & 3) == kReading &&
        s->state.compare_exchange_strong(st, (st & ~uint64_t{3}) | kReady)) {
      h->redelivered.fetch_add(1);
    }
  }
  cursor_ = h->tail.load();
  seg_ = std::move(seg);
  hdr_ = h;
  last_error_.clear();
  spdlog::debug("ipc {}: consumer attached at sequence {}", name_, cursor_);
  return true;
}

PopStatus RingConsumer::TryPeekOnce(const uint8_t** data, size_t* bytes) {
  const uint64_t n = hdr_->slot_count;
  for (;;) {
    const uint64_t head = hdr_->head.load(std::memory_order_acquire);
    if (cursor_ >= head) return PopStatus::kEmpty;
    if (head - cursor_ > n) {  // overwritten while we were away
      hdr_->skipped.fetch_add(head - n - cursor_, std::memory_order_relaxed);
      cursor_ = head - n;
    }
    SlotHeader* slot = SlotAt(hdr_, cursor_);
    uint64_t s = slot->state.load(std::memory_order_acquire);
    if (s == (cursor_ << 2 | kReady)) {
      if (slot->state.compare_exchange_strong(s, cursor_ << 2 | kReading, std::memory_order_acq_rel)) {
        const uint64_t b = slot->bytes.load(std::memory_order_relaxed);
        if (b > hdr_->slot_bytes) {  // a consumer died freeing it (FreePages), or a broken producer: skip it
          slot->state.store(cursor_ << 2 | kFree, std::memory_order_release);
        } else {
          *data = Payload(slot);
          *bytes = b;
          holding_ = true;
          return PopStatus::kOk;
        }
      } else {
        continue;  // the producer overwrote it (kDropOldest): look again
      }
    }
    // Overwritten by a later message, or lost: move on.
    hdr_->skipped.fetch_add(1, std::memory_order_relaxed);
    ++cursor_;
    hdr_->tail.store(cursor_, std::memory_order_release);
  }
}

PopStatus RingConsumer::Peek(const uint8_t** data, size_t* bytes, double timeout_s) {
  if (holding_) Release();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  int sleep_us = 20;
  for (;;) {
    PopStatus st;
    if (!hdr_ && !TryAttach()) {
      st = last_error_.empty() ? PopStatus::kNotConnected : PopStatus::kIncompatible;
    } else {
      st = TryPeekOnce(data, bytes);
      if (st == PopStatus::kEmpty && hdr_->closed.load(std::memory_order_acquire)) {
        Detach();  // drained; the next producer makes a new segment
        ++closed_segments_;
        st = PopStatus::kNotConnected;
      }
    }
    if (st == PopStatus::kOk) return st;
    const auto now = std::chrono::steady_clock::now();
    if (now >= deadline) return st;
    const auto left = std::chrono::duration_cast<std::chrono::microseconds>(deadline - now);
    std::this_thread::sleep_for(std::min(left, std::chrono::microseconds(sleep_us)));
    sleep_us = std::min(sleep_us * 2, 1000);
  }
}

void RingConsumer::Release() {
  if (!holding_ || !hdr_) return;
  holding_ = false;
  SlotHeader* slot = SlotAt(hdr_, cursor_);
  FreePages(slot);
  slot->state.store(cursor_ << 2 | kFree, std::memory_order_release);
  ++cursor_;
  hdr_->tail.store(cursor_, std::memory_order_release);
  hdr_->popped.fetch_add(1, std::memory_order_relaxed);
}

void RingConsumer::FreePages(SlotHeader* slot) {
  // A tmpfs page stays allocated once written, so without this a ring would
  // hold every slot's largest message for good (the front's resident size
  // crept up with its submaps). The slot is still ours (kReading): the
  // producer cannot be writing into it.
  static const uint64_t page = static_cast<uint64_t>(::sysconf(_SC_PAGESIZE));
  const auto begin = reinterpret_cast<uintptr_t>(Payload(slot));
  const uint64_t first = RoundUp(begin, page);
  const uint64_t last = (begin + slot->bytes.load(std::memory_order_relaxed)) / page * page;
  if (last <= first || last - first < kFreePagesMinBytes) return;
  // Killed between here and the release, the next consumer must not get the
  // zeroed message again as a redelivery: an impossible size makes it skip
  // the slot (TryPeekOnce).
  slot->bytes.store(~uint64_t{0}, std::memory_order_release);
  if (::madvise(reinterpret_cast<void*>(first), last - first, MADV_REMOVE) == 0) {
    freed_bytes_ += last - first;
  } else if (!free_pages_failed_) {
    free_pages_failed_ = true;
    spdlog::warn("{}: could not free read slots' pages (madvise MADV_REMOVE: {}); the ring keeps them",
                 name_, std::strerror(errno));
  }
}

RingStats RingConsumer::Stats() const {
  RingStats s;
  ReadRingStats(name_, &s);
  return s;
}

// ---------------- status ----------------

bool ReadRingStats(const std::string& name, RingStats* out, std::string* error) {
  MappedSegment seg;
  if (!OpenExisting(name, bip::read_only, &seg)) {
    if (error) *error = name + ": no such segment";
    return false;
  }
  bool initialising = false;
  std::string why;
  if (!HeaderUsable(seg, &initialising, &why)) {
    if (error) *error = name + ": " + why;
    return false;
  }
  const auto* h = reinterpret_cast<const RingHeader*>(seg.base());
  RingStats s;
  s.name = name;
  s.slot_count = h->slot_count;
  s.slot_bytes = h->slot_bytes;
  s.policy = static_cast<OverflowPolicy>(h->policy.load());
  s.head = h->head.load();
  s.tail = h->tail.load();
  s.pushed = h->pushed.load();
  s.popped = h->popped.load();
  s.dropped_full = h->dropped_full.load();
  s.dropped_oldest = h->dropped_oldest.load();
  s.dropped_too_large = h->dropped_too_large.load();
  s.reclaimed = h->reclaimed.load();
  s.skipped = h->skipped.load();
  s.redelivered = h->redelivered.load();
  s.producer_pid = h->producer_pid.load();
  s.consumer_pid = h->consumer_pid.load();
  s.producer_alive = ProcessAlive(Producer(h));
  s.consumer_alive = ProcessAlive(Consumer(h));
  s.closed = h->closed.load() != 0;
  s.producer_generation = h->producer_generation.load();
  s.consumer_generation = h->consumer_generation.load();
  *out = s;
  return true;
}

std::string FormatRingStats(const RingStats& s) {
  return s.name + ": " + std::to_string(s.slot_count) + " x " + std::to_string(s.slot_bytes) + " B, " +
         ToString(s.policy) + ", head " + std::to_string(s.head) + " tail " + std::to_string(s.tail) +
         ", pushed " + std::to_string(s.pushed) + " popped " + std::to_string(s.popped) +
         ", dropped full " + std::to_string(s.dropped_full) + " oldest " + std::to_string(s.dropped_oldest) +
         " too_large " + std::to_string(s.dropped_too_large) + ", reclaimed " + std::to_string(s.reclaimed) +
         " skipped " + std::to_string(s.skipped) + " redelivered " + std::to_string(s.redelivered) +
         ", producer pid " + std::to_string(s.producer_pid) + (s.producer_alive ? " (alive)" : " (gone)") +
         " gen " + std::to_string(s.producer_generation) + ", consumer pid " + std::to_string(s.consumer_pid) +
         (s.consumer_alive ? " (alive)" : " (gone)") + " gen " + std::to_string(s.consumer_generation) +
         (s.closed ? ", closed" : "");
}

}  // namespace rumi
