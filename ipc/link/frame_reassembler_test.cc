#include "ipc/link/frame_reassembler.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>

namespace rumi {
namespace {

// The fragments of one frame, as the robot would send them.
struct Fragments {
  std::vector<uint8_t> image;
  std::vector<rl_message> msgs;
};

Fragments MakeFrame(uint32_t id, size_t bytes, uint64_t t_us) {
  Fragments f;
  f.image.resize(bytes);
  for (size_t i = 0; i < bytes; ++i) f.image[i] = static_cast<uint8_t>(i * 7 + id);
  const uint16_t count = static_cast<uint16_t>((bytes + RL_FRAGMENT_DATA_MAX - 1) / RL_FRAGMENT_DATA_MAX);
  for (uint16_t k = 0; k < count; ++k) {
    rl_message m;
    std::memset(&m, 0, sizeof(m));
    m.h.type = RL_FRAME;
    m.h.msg_id = id;
    m.h.frag_index = k;
    m.h.frag_count = count;
    m.h.time_us = t_us;
    m.u.frame.meta = {static_cast<uint32_t>(bytes), k * RL_FRAGMENT_DATA_MAX, 320, 240, RL_FORMAT_JPEG, 12};
    m.u.frame.len = static_cast<uint16_t>(std::min<size_t>(RL_FRAGMENT_DATA_MAX, bytes - k * RL_FRAGMENT_DATA_MAX));
    f.msgs.push_back(m);
  }
  return f;
}

// rl_message.frame.data points into the image: keep the Fragments alive.
void Feed(FrameReassembler* r, Fragments& f, size_t k, int64_t now, bool resent = false) {
  rl_message m = f.msgs[k];
  m.u.frame.data = f.image.data() + m.u.frame.meta.offset;
  if (resent) m.h.flags = RL_FLAG_RETRANSMIT;
  r->Add(m, now);
}

TEST(FrameReassembler, ReorderedAndDuplicatedFragmentsMakeTheFrame) {
  FrameReassembler r;
  Fragments f = MakeFrame(10, 5000, 123);
  Feed(&r, f, 3, 0);
  Feed(&r, f, 1, 1);
  Feed(&r, f, 1, 2);  // duplicate
  Feed(&r, f, 0, 3);
  EXPECT_TRUE(r.Poll(4, nullptr).empty());
  Feed(&r, f, 2, 5);
  auto out = r.Poll(6, nullptr);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].data, f.image);
  EXPECT_EQ(out[0].robot_time_us, 123u);
  EXPECT_EQ(out[0].first_us, 0);
  EXPECT_EQ(out[0].complete_us, 5);
  EXPECT_EQ(r.stats().duplicates, 1u);
  // A fragment of it arriving after it was handed on: late, ignored.
  Feed(&r, f, 0, 7);
  EXPECT_EQ(r.stats().late, 1u);
  EXPECT_TRUE(r.Poll(8, nullptr).empty());
}

TEST(FrameReassembler, MissingFragmentsAreNackedThenRecoveredInOrder) {
  FrameReassemblerOptions o;
  o.nack_delay_us = 50;
  o.nack_interval_us = 100;
  o.deadline_us = 1000;
  FrameReassembler r(o);
  Fragments a = MakeFrame(0, 4000, 1), b = MakeFrame(1, 4000, 2);
  Feed(&r, a, 0, 0);
  Feed(&r, a, 2, 0);  // a's fragment 1 lost
  for (size_t k = 0; k < 3; ++k) Feed(&r, b, k, 10);
  std::vector<NackRequest> nacks;
  EXPECT_TRUE(r.Poll(20, &nacks).empty());  // b waits for a
  EXPECT_TRUE(nacks.empty());               // too early to NACK
  EXPECT_TRUE(r.Poll(60, &nacks).empty());
  ASSERT_EQ(nacks.size(), 1u);
  EXPECT_EQ(nacks[0].frame_id, 0u);
  EXPECT_EQ(nacks[0].missing, std::vector<uint16_t>{1});
  nacks.clear();
  r.Poll(100, &nacks);
  EXPECT_TRUE(nacks.empty());  // not again before the interval
  r.Poll(170, &nacks);
  EXPECT_EQ(nacks.size(), 1u);  // again
  Feed(&r, a, 1, 200, true);
  auto out = r.Poll(201, nullptr);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].frame_id, 0u);
  EXPECT_EQ(out[0].recovered, 1);
  EXPECT_EQ(out[1].frame_id, 1u);
  EXPECT_EQ(r.stats().frames_recovered, 1u);
}

TEST(FrameReassembler, AFrameNeverSeenIsNackedWholeAndDroppedAtItsDeadline) {
  FrameReassemblerOptions o;
  o.nack_delay_us = 50;
  o.deadline_us = 300;
  FrameReassembler r(o);
  Fragments a = MakeFrame(5, 100, 1), c = MakeFrame(7, 100, 3);
  Feed(&r, a, 0, 0);
  EXPECT_EQ(r.Poll(1, nullptr).size(), 1u);
  Feed(&r, c, 0, 10);  // frame 6 skipped entirely
  std::vector<NackRequest> nacks;
  std::vector<uint32_t> dropped;
  EXPECT_TRUE(r.Poll(100, &nacks, &dropped).empty());
  ASSERT_EQ(nacks.size(), 1u);
  EXPECT_EQ(nacks[0].frame_id, 6u);
  EXPECT_TRUE(nacks[0].missing.empty());  // the whole frame
  auto out = r.Poll(310, &nacks, &dropped);  // 6's deadline passed: 7 goes on
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].frame_id, 7u);
  EXPECT_EQ(dropped, std::vector<uint32_t>{6});
  EXPECT_EQ(r.stats().frames_dropped, 1u);
}

// A restarted robot's ids (from 0 again) resync once three fragments agree;
// the frames whose fragments confirmed it are NACKed and recovered.
TEST(FrameReassembler, ARestartedRobotResyncs) {
  FrameReassembler r;
  Fragments a = MakeFrame(5000, 100, 1);
  Feed(&r, a, 0, 0);
  EXPECT_EQ(r.Poll(1, nullptr).size(), 1u);
  std::vector<Fragments> b;
  for (uint32_t id = 0; id < 3; ++id) b.push_back(MakeFrame(id, 100, 2 + id));
  for (uint32_t id = 0; id < 3; ++id) Feed(&r, b[id], 0, 2 + id);  // ids from 0 again
  EXPECT_EQ(r.stats().resyncs, 1u);
  EXPECT_EQ(r.stats().out_of_window, 2u);
  std::vector<NackRequest> nacks;
  EXPECT_TRUE(r.Poll(100000, &nacks).empty());  // 0 and 1 first
  ASSERT_EQ(nacks.size(), 2u);
  for (uint32_t id = 0; id < 2; ++id) Feed(&r, b[id], 0, 100001, true);
  auto out = r.Poll(100002, nullptr);
  ASSERT_EQ(out.size(), 3u);
  for (uint32_t id = 0; id < 3; ++id) EXPECT_EQ(out[id].frame_id, id);
}

// Far-off ids one at a time (garbage that passed the CRC) never move the
// window and allocate nothing; the real frames go on.
TEST(FrameReassembler, StrayFarIdsAreDroppedNotResynced) {
  FrameReassembler r;
  std::mt19937 rng(3);
  std::vector<Fragments> real;
  for (uint32_t id = 0; id < 20; ++id) real.push_back(MakeFrame(id, 100, id));
  size_t delivered = 0;
  for (uint32_t id = 0; id < 20; ++id) {
    Feed(&r, real[id], 0, id * 1000);
    for (int k = 0; k < 5; ++k) {
      Fragments junk = MakeFrame(100000 + rng() % 1000000000u, 100, 0);
      Feed(&r, junk, 0, id * 1000);
    }
    EXPECT_LE(r.pending(), 2u);
    delivered += r.Poll(id * 1000 + 1, nullptr).size();
  }
  EXPECT_EQ(delivered, 20u);
  EXPECT_EQ(r.stats().resyncs, 0u);
  EXPECT_EQ(r.stats().out_of_window, 100u);
}

TEST(FrameReassembler, NacksAreBoundedPerSecond) {
  FrameReassemblerOptions o;
  o.max_nacks_per_s = 10;
  o.nack_interval_us = 1000;
  o.deadline_us = 10000000;
  FrameReassembler r(o);
  std::vector<Fragments> f;
  for (uint32_t id = 0; id < 30; ++id) f.push_back(MakeFrame(id, 3000, id));
  for (uint32_t id = 0; id < 30; ++id) Feed(&r, f[id], 0, 0);  // every frame misses fragments 1, 2
  size_t sent = 0;
  for (int64_t t = 100000; t < 1000000; t += 5000) {
    std::vector<NackRequest> nacks;
    r.Poll(t, &nacks);
    sent += nacks.size();
  }
  EXPECT_LE(sent, 10u);
  EXPECT_GT(r.stats().nacks_suppressed, 0u);
}

TEST(FrameReassembler, InconsistentFragmentsAreRejected) {
  FrameReassembler r;
  Fragments a = MakeFrame(1, 3000, 1), b = MakeFrame(1, 5000, 1);  // same id, other size
  Feed(&r, a, 0, 0);
  Feed(&r, b, 1, 0);
  EXPECT_EQ(r.stats().inconsistent, 1u);
}

// Loss, duplication and reordering at random, with NACK retransmission by an
// ideal robot: every frame comes out, in order, intact.
TEST(FrameReassembler, RandomLossWithRetransmissionDeliversEverythingInOrder) {
  FrameReassemblerOptions o;
  o.nack_delay_us = 30;
  o.nack_interval_us = 30;
  o.deadline_us = 100000;
  o.max_nacks_per_s = 1 << 30;  // time runs 1000x fast here: the per-second bound is not what is tested
  FrameReassembler r(o);
  std::mt19937 rng(3);
  std::vector<Fragments> frames;
  for (uint32_t i = 0; i < 200; ++i) frames.push_back(MakeFrame(i, 1000 + (rng() % 20000), i));
  std::vector<LinkFrame> got;
  int64_t t = 0;
  for (uint32_t i = 0; i < frames.size(); ++i) {
    std::vector<size_t> order(frames[i].msgs.size());
    for (size_t k = 0; k < order.size(); ++k) order[k] = k;
    std::shuffle(order.begin(), order.end(), rng);
    for (size_t k : order) {
      if (rng() % 10 == 0) continue;  // lost
      Feed(&r, frames[i], k, t);
      if (rng() % 20 == 0) Feed(&r, frames[i], k, t);  // duplicated
    }
    for (int step = 0; step < 10; ++step) {
      t += 10;
      std::vector<NackRequest> nacks;
      for (auto& f : r.Poll(t, &nacks)) got.push_back(std::move(f));
      for (auto& n : nacks) {
        Fragments& fr = frames[n.frame_id];
        if (n.missing.empty())
          for (size_t k = 0; k < fr.msgs.size(); ++k) n.missing.push_back(static_cast<uint16_t>(k));
        for (uint16_t k : n.missing)
          if (rng() % 10 != 0) Feed(&r, fr, k, t, true);
      }
    }
  }
  for (int step = 0; step < 100; ++step) {
    t += 10;
    std::vector<NackRequest> nacks;
    for (auto& f : r.Poll(t, &nacks)) got.push_back(std::move(f));
    for (auto& n : nacks)
      for (uint16_t k : n.missing) Feed(&r, frames[n.frame_id], k, t, true);
  }
  ASSERT_EQ(got.size(), frames.size() - (r.pending() ? 1 : 0));
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].frame_id, i);
    EXPECT_EQ(got[i].data, frames[i].image);
  }
  EXPECT_GT(r.stats().frames_recovered, 50u);
  EXPECT_EQ(r.stats().frames_dropped, 0u);
}

}  // namespace
}  // namespace rumi
