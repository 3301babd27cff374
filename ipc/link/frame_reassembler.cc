#include "ipc/link/frame_reassembler.h"

#include <algorithm>
#include <cstring>

namespace rumi {

void FrameReassembler::Reset(uint32_t next) {
  stats_.frames_dropped += pending_.size();
  pending_.clear();
  next_ = next;
  started_ = true;
}

void FrameReassembler::Add(const rl_message& m, int64_t now_us) {
  if (m.h.type != RL_FRAME) return;
  const uint32_t id = m.h.msg_id;
  if (!started_) {
    Reset(id);
  } else {
    const int32_t ahead = static_cast<int32_t>(id - next_);  // serial arithmetic: ids wrap
    const bool far = ahead < 0 ? static_cast<uint32_t>(-ahead) > o_.max_gap * 4
                               : static_cast<uint32_t>(ahead) > o_.max_gap;
    if (!far && ahead < 0) {
      ++stats_.late;
      return;
    }
    if (far) {
      // A restarted robot (ids from 0 again) or a long outage: resync, but
      // only once resync_fragments fragments in a row agree on the new place;
      // a stray id (garbage on an insecure link) is counted and dropped
      // before anything is allocated for it.
      if (candidate_hits_ > 0 && id - candidate_min_ <= o_.max_gap) {
        ++candidate_hits_;
      } else if (candidate_hits_ > 0 && candidate_min_ - id <= o_.max_gap) {
        ++candidate_hits_;
        candidate_min_ = id;
      } else {
        candidate_min_ = id;
        candidate_hits_ = 1;
      }
      if (candidate_hits_ < o_.resync_fragments) {
        ++stats_.out_of_window;
        return;
      }
      ++stats_.resyncs;
      Reset(candidate_min_);
    }
    candidate_hits_ = 0;
  }
  // Frames skipped over exist too: due now, NACKed as a whole.
  for (uint32_t k = next_; k != id; ++k)
    if (!pending_.count(k)) pending_[k].due_us = now_us;
  auto [it, fresh] = pending_.try_emplace(id);
  Partial& p = it->second;
  if (fresh) p.due_us = now_us;
  if (p.have.empty()) {
    p.have.assign(m.h.frag_count, false);
    p.f.frame_id = id;
    p.f.robot_time_us = m.h.time_us;
    p.f.width = m.u.frame.meta.width;
    p.f.height = m.u.frame.meta.height;
    p.f.format = m.u.frame.meta.format;
    p.f.quality = m.u.frame.meta.quality;
    p.f.data.assign(m.u.frame.meta.total_len, 0);
    p.f.first_us = now_us;
  } else if (p.have.size() != m.h.frag_count || p.f.data.size() != m.u.frame.meta.total_len ||
             p.f.robot_time_us != m.h.time_us) {
    ++stats_.inconsistent;
    return;
  }
  if (p.have[m.h.frag_index]) {
    ++stats_.duplicates;
    return;
  }
  // rl_parse checked offset + len <= total_len and the fixed offsets.
  std::memcpy(p.f.data.data() + m.u.frame.meta.offset, m.u.frame.data, m.u.frame.len);
  p.have[m.h.frag_index] = true;
  ++p.have_count;
  ++p.f.fragments;
  ++stats_.fragments;
  if (m.h.flags & RL_FLAG_RETRANSMIT) {
    ++p.f.recovered;
    ++stats_.fragments_recovered;
  }
  if (p.complete()) p.f.complete_us = now_us;
}

std::vector<LinkFrame> FrameReassembler::Poll(int64_t now_us, std::vector<NackRequest>* nacks,
                                              std::vector<uint32_t>* dropped) {
  std::vector<LinkFrame> out;
  while (!pending_.empty()) {
    auto it = pending_.find(next_);
    if (it == pending_.end()) break;  // nothing of next_ known: it is not late yet
    Partial& p = it->second;
    if (p.complete()) {
      ++stats_.frames_complete;
      if (p.f.recovered) ++stats_.frames_recovered;
      out.push_back(std::move(p.f));
    } else if (now_us - p.due_us >= o_.deadline_us) {
      ++stats_.frames_dropped;
      if (dropped) dropped->push_back(next_);
    } else {
      break;
    }
    pending_.erase(it);
    ++next_;
  }
  if (nacks) {
    if (now_us - nack_second_us_ >= 1000000) nack_second_us_ = now_us, nacks_this_second_ = 0;
    for (auto& [id, p] : pending_) {
      if (p.complete() || now_us - p.due_us < o_.nack_delay_us) continue;
      if (p.last_nack_us && now_us - p.last_nack_us < o_.nack_interval_us) continue;
      if (now_us - p.due_us >= o_.deadline_us) continue;
      if (nacks_this_second_ >= o_.max_nacks_per_s) {
        ++stats_.nacks_suppressed;  // a NACK storm helps nobody on a link that is already losing
        continue;
      }
      ++nacks_this_second_;
      NackRequest r;
      r.frame_id = id;
      for (size_t i = 0; i < p.have.size() && r.missing.size() < RL_NACK_MAX; ++i)
        if (!p.have[i]) r.missing.push_back(static_cast<uint16_t>(i));
      nacks->push_back(std::move(r));
      p.last_nack_us = now_us;
      ++stats_.nacks;
    }
  }
  return out;
}

}  // namespace rumi
