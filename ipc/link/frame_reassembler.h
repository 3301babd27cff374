#pragma once
// Puts the robot's frames back together from their fragments (the link's
// rl_message FRAME datagrams), asks for what is missing, and hands frames on
// in frame order.
//  - Fragments may arrive lost, duplicated, reordered or long after: each is
//    placed by its index (the protocol fixes every fragment's offset), a
//    duplicate is counted and ignored, a fragment of a frame already handed
//    on or given up is counted as late.
//  - A frame still incomplete nack_delay after its first fragment (or a frame
//    whose id was skipped: nothing of it came) is NACKed, again every
//    nack_interval, until its deadline; at the deadline it is dropped and
//    counted.
//  - Frames are handed on in frame-id order, so timestamps never go back; a
//    complete frame waits for an older incomplete one at most until that
//    one's deadline: a lost fragment delays later frames by a bounded time,
//    never blocks them.
//  - A robot that restarts (frame ids from 0 again) or a jump of more than
//    max_gap ids resets the order (counted as a resync) once resync_fragments
//    fragments in a row agree on it; a lone far id is dropped (out_of_window).
//  - At most max_nacks_per_s NACKs a second, at most one per frame every
//    nack_interval: bounded whatever arrives.
#include <cstdint>
#include <map>
#include <vector>

#include "rumi_link.h"

namespace rumi {

struct FrameReassemblerOptions {
  int64_t deadline_us = 500000;      // a frame not complete this long after it was first due: dropped
  int64_t nack_delay_us = 60000;     // first NACK this long after the frame's first fragment
  int64_t nack_interval_us = 100000; // then again every this long
  uint32_t max_gap = 64;             // frame-id jump beyond which the order is reset
  int resync_fragments = 3;          // ... by this many fragments in a row agreeing on it
  int max_nacks_per_s = 100;         // NACKs beyond this in one second are not sent
};

struct LinkFrame {
  uint32_t frame_id = 0;
  uint64_t robot_time_us = 0;     // capture, robot clock
  uint16_t width = 0, height = 0;
  uint8_t format = 0, quality = 0;
  std::vector<uint8_t> data;
  int64_t first_us = 0;           // ground clock: first fragment arrived
  int64_t complete_us = 0;        // ground clock: last fragment arrived
  int fragments = 0;
  int recovered = 0;              // fragments that came by retransmission
};

struct NackRequest {
  uint32_t frame_id = 0;
  std::vector<uint16_t> missing;  // empty: the whole frame
};

struct ReassemblerStats {
  uint64_t frames_complete = 0;
  uint64_t frames_dropped = 0;     // deadline passed incomplete (or never seen)
  uint64_t frames_recovered = 0;   // complete thanks to retransmission
  uint64_t fragments = 0;          // accepted
  uint64_t fragments_recovered = 0;
  uint64_t duplicates = 0;
  uint64_t late = 0;               // for a frame already handed on or dropped
  uint64_t inconsistent = 0;       // disagreed with the frame's other fragments
  uint64_t nacks = 0;
  uint64_t resyncs = 0;
  uint64_t out_of_window = 0;      // far outside the window, not (yet) a resync: dropped
  uint64_t nacks_suppressed = 0;   // beyond max_nacks_per_s
};

class FrameReassembler {
 public:
  explicit FrameReassembler(const FrameReassemblerOptions& o = {}) : o_(o) {}

  // One parsed FRAME datagram received at now_us (ground clock).
  void Add(const rl_message& m, int64_t now_us);
  // Frames ready, in order; NACKs due now go to *nacks, the ids of frames
  // given up to *dropped (each optional).
  std::vector<LinkFrame> Poll(int64_t now_us, std::vector<NackRequest>* nacks,
                              std::vector<uint32_t>* dropped = nullptr);
  const ReassemblerStats& stats() const { return stats_; }
  size_t pending() const { return pending_.size(); }

 private:
  struct Partial {
    LinkFrame f;
    std::vector<bool> have;       // empty until a fragment told the count
    int have_count = 0;
    int64_t due_us = 0;           // when it was first known to exist
    int64_t last_nack_us = 0;
    bool complete() const { return !have.empty() && have_count == static_cast<int>(have.size()); }
  };
  void Reset(uint32_t next);

  FrameReassemblerOptions o_;
  ReassemblerStats stats_;
  bool started_ = false;
  uint32_t next_ = 0;             // the next frame id to hand on
  std::map<uint32_t, Partial> pending_;
  uint32_t candidate_min_ = 0;    // a resync being confirmed: its lowest id
  int candidate_hits_ = 0;
  int64_t nack_second_us_ = 0;
  int nacks_this_second_ = 0;
};

}  // namespace rumi
