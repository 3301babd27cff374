#include "ipc/shm_ring.h"

#include <gtest/gtest.h>

#include <csignal>
#include <cstring>
#include <sys/stat.h>
#include <sys/wait.h>
#include <atomic>
#include <chrono>
#include <thread>
#include <unistd.h>

#include "ipc/channels.h"

namespace rumi {
namespace {

std::string UniqueName(const char* what) {
  static int n = 0;
  return "rumi_test" + std::to_string(getpid()) + "_" + std::to_string(n++) + "_" + what;
}

// Removes the segment even when a test fails half-way.
struct SegmentGuard {
  std::string name;
  ~SegmentGuard() { RemoveSegment(name); }
};

PushStatus PushValue(RingProducer& p, uint64_t v, size_t bytes = 8) {
  return p.Push(bytes, [&](uint8_t* d) {
    std::memset(d, 0, bytes);
    std::memcpy(d, &v, sizeof(v));
  });
}

// Pops one message and returns its first 8 bytes, or ~0 when none.
uint64_t PopValue(RingConsumer& c, double timeout = 0.0) {
  uint64_t v = ~uint64_t{0};
  c.Pop([&](const uint8_t* d, size_t n) { if (n >= 8) std::memcpy(&v, d, 8); }, timeout);
  return v;
}

// Runs f in a child process; f must end with raise(SIGKILL) while its
// objects are alive (no destructors run, as in a crash).
template <typename F>
void InChildThenSigkill(F&& f) {
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    f();
    raise(SIGKILL);
    _exit(0);
  }
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFSIGNALED(status));
  ASSERT_EQ(WTERMSIG(status), SIGKILL);
}

TEST(ShmRing, FifoAndDropNewestWhenFull) {
  SegmentGuard g{UniqueName("fifo")};
  RingProducer p(g.name, {4, 64, OverflowPolicy::kDropNewest});
  RingConsumer c(g.name);
  for (uint64_t i = 0; i < 4; ++i) EXPECT_EQ(PushValue(p, i), PushStatus::kOk);
  EXPECT_EQ(PushValue(p, 99), PushStatus::kDropped);  // full: the new one is refused
  EXPECT_EQ(PushValue(p, 1, 65), PushStatus::kTooLarge);
  for (uint64_t i = 0; i < 4; ++i) EXPECT_EQ(PopValue(c), i);
  EXPECT_EQ(PopValue(c), ~uint64_t{0});
  EXPECT_EQ(PushValue(p, 4), PushStatus::kOk);
  EXPECT_EQ(PopValue(c), 4u);
  const RingStats s = p.Stats();
  EXPECT_EQ(s.pushed, 5u);
  EXPECT_EQ(s.popped, 5u);
  EXPECT_EQ(s.dropped_full, 1u);
  EXPECT_EQ(s.dropped_too_large, 1u);
  EXPECT_TRUE(s.producer_alive);
  EXPECT_TRUE(s.consumer_alive);
}

// Another local user reads no frame and no map (#50.8: segments were 0644).
TEST(ShmRing, ASegmentIsTheOwnersOnly) {
  SegmentGuard g{UniqueName("mode")};
  const mode_t old_umask = ::umask(0);  // Boost's permissions are the segment's, whatever the umask
  RingProducer p(g.name, {2, 64, OverflowPolicy::kDropNewest});
  ::umask(old_umask);
  struct stat st {};
  ASSERT_EQ(::stat(("/dev/shm/" + g.name).c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u) << std::oct << (st.st_mode & 0777);
}

TEST(ShmRing, DropOldestKeepsNewestAndConsumerSkips) {
  SegmentGuard g{UniqueName("oldest")};
  RingProducer p(g.name, {3, 16, OverflowPolicy::kDropOldest});
  RingConsumer c(g.name);
  for (uint64_t i = 0; i < 7; ++i) EXPECT_EQ(PushValue(p, i), PushStatus::kOk);
  for (uint64_t i = 4; i < 7; ++i) EXPECT_EQ(PopValue(c), i);
  EXPECT_EQ(PopValue(c), ~uint64_t{0});
  const RingStats s = c.Stats();
  EXPECT_EQ(s.dropped_oldest, 4u);
  EXPECT_EQ(s.skipped, 4u);
}

TEST(ShmRing, ProducerNeverOverwritesTheMessageBeingRead) {
  SegmentGuard g{UniqueName("inplace")};
  RingProducer p(g.name, {2, 16, OverflowPolicy::kDropOldest});
  RingConsumer c(g.name);
  PushValue(p, 10);
  PushValue(p, 11);
  const uint8_t* d = nullptr;
  size_t n = 0;
  ASSERT_EQ(c.Peek(&d, &n), PopStatus::kOk);  // reading 10 in place
  EXPECT_EQ(PushValue(p, 12), PushStatus::kDropped);  // its slot is busy: newest dropped
  uint64_t v;
  std::memcpy(&v, d, 8);
  EXPECT_EQ(v, 10u);
  c.Release();
  EXPECT_EQ(PushValue(p, 13), PushStatus::kOk);
  EXPECT_EQ(PopValue(c), 11u);
  EXPECT_EQ(PopValue(c), 13u);
}

// Bytes of tmpfs the segment holds (allocated blocks, not its size).
int64_t SegmentAllocatedBytes(const std::string& name) {
  struct stat st {};
  if (::stat(("/dev/shm/" + name).c_str(), &st) != 0) return -1;
  return static_cast<int64_t>(st.st_blocks) * 512;
}

TEST(ShmRing, ReadLargeMessagesGiveTheirPagesBack) {
  SegmentGuard g{UniqueName("pages")};
  const size_t big = 8 << 20;
  RingProducer p(g.name, {3, 16 << 20, OverflowPolicy::kDropNewest});
  RingConsumer c(g.name);
  const int64_t empty = SegmentAllocatedBytes(g.name);
  ASSERT_GE(empty, 0) << "no /dev/shm/" << g.name;
  // Three large messages in three slots: 24 MiB of pages written.
  for (uint64_t i = 0; i < 3; ++i) ASSERT_EQ(PushValue(p, 100 + i, big), PushStatus::kOk);
  EXPECT_GE(SegmentAllocatedBytes(g.name) - empty, static_cast<int64_t>(3 * big));
  // The message being read keeps its pages until it is released.
  const uint8_t* d = nullptr;
  size_t n = 0;
  ASSERT_EQ(c.Peek(&d, &n), PopStatus::kOk);
  ASSERT_EQ(n, big);
  uint64_t v = 0;
  std::memcpy(&v, d, 8);
  EXPECT_EQ(v, 100u);
  EXPECT_EQ(d[big - 1], 0);
  EXPECT_GE(SegmentAllocatedBytes(g.name) - empty, static_cast<int64_t>(3 * big));
  c.Release();
  EXPECT_EQ(PopValue(c), 101u);
  EXPECT_EQ(PopValue(c), 102u);
  // All three read: at most a page at each message's ends stays.
  EXPECT_LT(SegmentAllocatedBytes(g.name) - empty, 1 << 20);
  EXPECT_GE(c.freed_bytes(), 3 * big - 3 * 8192);
  // Slot headers survive the freed pages, and the slots are used again.
  for (uint64_t i = 0; i < 3; ++i) ASSERT_EQ(PushValue(p, 200 + i, big), PushStatus::kOk);
  for (uint64_t i = 0; i < 3; ++i) EXPECT_EQ(PopValue(c), 200 + i);
  // Small messages keep their pages (no system call per pose).
  const uint64_t freed = c.freed_bytes();
  ASSERT_EQ(PushValue(p, 7, 4096 * 8), PushStatus::kOk);
  EXPECT_EQ(PopValue(c), 7u);
  EXPECT_EQ(c.freed_bytes(), freed);
  EXPECT_EQ(p.Stats().popped, 7u);
}

TEST(ShmRing, ConsumerBeforeProducerAndProducerCleanExit) {
  const std::string name = UniqueName("late");
  SegmentGuard g{name};
  RingConsumer c(name);
  EXPECT_EQ(PopValue(c), ~uint64_t{0});
  EXPECT_FALSE(c.connected());
  {
    RingProducer p(name, {2, 16, OverflowPolicy::kDropNewest});
    EXPECT_EQ(PopValue(c), ~uint64_t{0});  // attaches
    EXPECT_TRUE(c.connected());
    PushValue(p, 5);
  }  // clean exit: segment removed, but an attached consumer still drains it
  EXPECT_EQ(PopValue(c), 5u);
  RingStats s;
  EXPECT_FALSE(ReadRingStats(name, &s));
  // A new producer makes a new segment; the consumer follows.
  RingProducer p2(name, {2, 16, OverflowPolicy::kDropNewest});
  PushValue(p2, 6);
  EXPECT_EQ(PopValue(c, 1.0), 6u);
}

TEST(ShmRing, SecondLiveProducerIsRefused) {
  SegmentGuard g{UniqueName("dup")};
  RingProducer p(g.name, {2, 16, OverflowPolicy::kDropNewest});
  // Same process re-opening counts as a take-over of itself; another live
  // process must be refused.
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    try {
      RingProducer q(g.name, {2, 16, OverflowPolicy::kDropNewest});
      _exit(1);
    } catch (const IpcError& e) {
      _exit(std::strstr(e.what(), "another producer") ? 0 : 2);
    }
  }
  int status = 0;
  waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
}

TEST(ShmRing, LayoutMismatchWithLivePeerRefusedClearly) {
  SegmentGuard g{UniqueName("layout")};
  RingConsumer c(g.name, {4, 32, OverflowPolicy::kDropNewest});
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {  // a producer with another geometry stays alive for a while
    RingProducer p(g.name, {2, 16, OverflowPolicy::kDropNewest});
    usleep(300000);
    p.KeepSegmentOnExit();
    _exit(0);
  }
  PopStatus st = PopStatus::kNotConnected;
  const uint8_t* d = nullptr;
  size_t n = 0;
  for (int i = 0; i < 200 && st == PopStatus::kNotConnected; ++i) st = c.Peek(&d, &n, 0.005);
  EXPECT_EQ(st, PopStatus::kIncompatible);
  EXPECT_NE(c.last_error().find("2 slots x 16 bytes"), std::string::npos) << c.last_error();
  EXPECT_NE(c.last_error().find("4 slots x 32 bytes"), std::string::npos) << c.last_error();
  // A producer of the other geometry may not replace it while its owner lives.
  try {
    RingProducer q(g.name, {4, 32, OverflowPolicy::kDropNewest});
    ADD_FAILURE() << "replaced a live producer's segment";
  } catch (const IpcError& e) {
    EXPECT_NE(std::string(e.what()).find("is alive"), std::string::npos) << e.what();
  }
  int status = 0;
  waitpid(pid, &status, 0);
  // Owner dead now: the stale segment of the other layout is replaced.
  RingProducer q(g.name, {4, 32, OverflowPolicy::kDropNewest});
  PushValue(q, 77);
  EXPECT_EQ(PopValue(c, 1.0), 77u);
}

TEST(ShmRing, CrashedConsumerMessageRedeliveredToNextConsumer) {
  SegmentGuard g{UniqueName("redeliver")};
  RingProducer p(g.name, {3, 16, OverflowPolicy::kDropNewest});
  PushValue(p, 1);
  PushValue(p, 2);
  InChildThenSigkill([&] {
    RingConsumer c(g.name);
    const uint8_t* d;
    size_t n;
    c.Peek(&d, &n);  // dies holding message 1 in place
    raise(SIGKILL);
  });
  RingConsumer c(g.name);
  EXPECT_EQ(PopValue(c), 1u);
  EXPECT_EQ(PopValue(c), 2u);
  EXPECT_EQ(c.Stats().redelivered, 1u);
}

TEST(ShmRing, DropOldestReclaimsSlotFromDeadReader) {
  SegmentGuard g{UniqueName("reclaim")};
  RingProducer p(g.name, {2, 16, OverflowPolicy::kDropOldest});
  PushValue(p, 1);
  PushValue(p, 2);
  InChildThenSigkill([&] {
    RingConsumer c(g.name);
    const uint8_t* d;
    size_t n;
    c.Peek(&d, &n);
    raise(SIGKILL);
  });
  // The dead reader's slot is taken back instead of blocking the ring forever.
  EXPECT_EQ(PushValue(p, 3), PushStatus::kOk);
  EXPECT_EQ(p.Stats().reclaimed, 1u);
  RingConsumer c(g.name);
  EXPECT_EQ(PopValue(c), 2u);
  EXPECT_EQ(PopValue(c), 3u);
}

TEST(ShmRing, CrashedProducerIsTakenOverAndSequenceContinues) {
  SegmentGuard g{UniqueName("takeover")};
  RingConsumer c(g.name);
  InChildThenSigkill([&] {
    RingProducer p(g.name, {4, 16, OverflowPolicy::kDropNewest});
    PushValue(p, 1);
    PushValue(p, 2);
    uint8_t* d;
    p.Acquire(8, &d);  // dies in the middle of writing message 3
    std::memset(d, 0xab, 8);
    raise(SIGKILL);
  });
  EXPECT_EQ(PopValue(c), 1u);
  RingProducer p(g.name, {4, 16, OverflowPolicy::kDropNewest});
  PushValue(p, 3);
  EXPECT_EQ(PopValue(c), 2u);
  EXPECT_EQ(PopValue(c), 3u);
  EXPECT_EQ(PopValue(c), ~uint64_t{0});
  EXPECT_EQ(p.Stats().producer_generation, 2u);
}

TEST(ShmRing, TwoInstancesSideBySide) {
  IpcOptions a, b;
  a.instance = "t" + std::to_string(getpid()) + "a";
  b.instance = "t" + std::to_string(getpid()) + "b";
  a.submap_slot_bytes = b.submap_slot_bytes = 1 << 16;
  a.window_slot_bytes = b.window_slot_bytes = 1 << 16;
  SubmapSender sa(a, SubmapSource::kFront), sb(b, SubmapSource::kFront);
  SubmapReceiver ra(a, SubmapSource::kFront), rb(b, SubmapSource::kFront);
  Submap m;
  m.id = 1;
  EXPECT_EQ(sa.Send(m), PushStatus::kOk);
  m.id = 2;
  EXPECT_EQ(sb.Send(m), PushStatus::kOk);
  Submap out;
  ASSERT_EQ(rb.Receive(&out), PopStatus::kOk);
  EXPECT_EQ(out.id, 2);
  ASSERT_EQ(ra.Receive(&out), PopStatus::kOk);
  EXPECT_EQ(out.id, 1);
  EXPECT_EQ(ra.Receive(&out), PopStatus::kEmpty);
  EXPECT_EQ(sa.ring().name(), "rumi_" + a.instance + "_front_submaps");
}

// Producer and consumer threads hammer a small ring under both policies;
// every message read in place must be intact and in order (races between
// overwrite and read would show up as torn or reordered payloads).
void StressRing(OverflowPolicy policy) {
  SegmentGuard g{UniqueName("stress")};
  RingProducer p(g.name, {3, 4096, policy});
  constexpr uint64_t kN = 10000;
  std::atomic<bool> done{false};
  uint64_t received = 0, bad = 0, last = 0;
  bool order_ok = true;
  std::thread consumer([&] {
    RingConsumer c(g.name);
    for (;;) {
      const bool finished = done.load();
      const PopStatus st = c.Pop([&](const uint8_t* d, size_t n) {
        uint64_t seq;
        std::memcpy(&seq, d, 8);
        for (size_t i = 8; i < n; ++i) bad += d[i] != static_cast<uint8_t>(seq * 13 + i);
        bad += n != 8 + seq % 4000;
        if (received && seq <= last) order_ok = false;
        last = seq;
        ++received;
      });
      if (st != PopStatus::kOk && finished) break;
    }
  });
  while (p.Stats().consumer_pid == 0) std::this_thread::yield();  // consumer attached
  uint64_t ok = 0;
  for (uint64_t seq = 1; seq <= kN; ++seq) {
    const size_t n = 8 + seq % 4000;
    const PushStatus r = p.Push(n, [&](uint8_t* d) {
      std::memcpy(d, &seq, 8);
      for (size_t i = 8; i < n; ++i) d[i] = static_cast<uint8_t>(seq * 13 + i);
    });
    ok += r == PushStatus::kOk;
    // Bursts of 4 then a short nap, so both threads run interleaved on 2
    // shared cores (the ring then sees full, overwrite and read-in-place races).
    if (seq % 4 == 0) std::this_thread::sleep_for(std::chrono::microseconds(20));
  }
  done = true;
  consumer.join();
  std::printf("%s: %llu ok, %llu received\n", ToString(policy), static_cast<unsigned long long>(ok),
              static_cast<unsigned long long>(received));
  EXPECT_EQ(bad, 0u);
  EXPECT_TRUE(order_ok);
  EXPECT_GT(received, 0u);
  EXPECT_LE(received, ok);
  const RingStats st = p.Stats();
  EXPECT_EQ(st.pushed, ok);
  EXPECT_EQ(st.pushed + st.dropped_full, kN);
  if (policy == OverflowPolicy::kDropNewest) {
    EXPECT_EQ(received, ok);  // nothing overwritten
  } else {
    EXPECT_EQ(received + st.dropped_oldest, ok);
  }
}

TEST(ShmRing, ThreadStressDropNewest) { StressRing(OverflowPolicy::kDropNewest); }
TEST(ShmRing, ThreadStressDropOldest) { StressRing(OverflowPolicy::kDropOldest); }

TEST(ProcessInfo, LivenessUsesPidAndStartTime) {
  const ProcessId me = SelfProcessId();
  EXPECT_EQ(me.pid, static_cast<uint64_t>(getpid()));
  EXPECT_GT(me.start_ticks, 0u);
  EXPECT_TRUE(ProcessAlive(me));
  ProcessId reused = me;
  reused.start_ticks += 1;  // same pid, another process (pid reuse)
  EXPECT_FALSE(ProcessAlive(reused));
  const pid_t child = fork();
  if (child == 0) {
    pause();
    _exit(0);
  }
  const ProcessId c{static_cast<uint64_t>(child), ProcessStartTicks(child)};
  EXPECT_TRUE(ProcessAlive(c));
  kill(child, SIGKILL);
  usleep(20000);
  EXPECT_FALSE(ProcessAlive(c));  // zombie counts as dead
  waitpid(child, nullptr, 0);
  EXPECT_FALSE(ProcessAlive(c));
  EXPECT_FALSE(ProcessAlive(ProcessId{}));
}

TEST(IpcOptions, CheckAndRead) {
  IpcOptions o;
  EXPECT_TRUE(o.Check());
  o.instance = "a/b";
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("instance"), std::string::npos);
  auto cfg = LoadConfigString(
      "instance: robot_2\nwindow_slots: 2\nwindow_slot_bytes: 1048576\nsubmap_slots: 4\n"
      "submap_slot_bytes: 65536\noverflow_policy: drop_oldest\n");
  IpcOptions r;
  ReadOptions(cfg, &r);
  cfg.Finish();
  EXPECT_EQ(r.instance, "robot_2");
  EXPECT_EQ(r.window_slots, 2);
  EXPECT_EQ(r.window_slot_bytes, 1048576);
  EXPECT_EQ(r.submap_slots, 4);
  EXPECT_EQ(r.policy(), OverflowPolicy::kDropOldest);
  auto bad = LoadConfigString("overflow_policy: block\n");
  EXPECT_THROW(ReadOptions(bad, &r), ConfigError);
  auto bad_id = LoadConfigString("instance: a b\n");
  try {
    IpcOptions fresh;
    ReadOptions(bad_id, &fresh);
    ADD_FAILURE() << "accepted a bad instance id";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("'instance'"), std::string::npos) << e.what();
  }
  auto small = LoadConfigString("window_slot_bytes: 10\n");
  EXPECT_THROW(ReadOptions(small, &r), ConfigError);
}

}  // namespace
}  // namespace rumi
