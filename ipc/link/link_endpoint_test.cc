#include "ipc/link/link_endpoint.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <atomic>
#include <cstring>
#include <iostream>
#include <random>
#include <thread>

#include "ipc/link/robot_sim.h"

namespace rumi {
namespace {

using namespace std::chrono_literals;

// The robot's key, in a 0600 file as `rumi link keygen` writes it.
const LinkKey& TestKey() {
  static const LinkKey k = [] {
    LinkKey k;
    for (size_t i = 0; i < k.size(); ++i) k[i] = static_cast<uint8_t>(i * 29 + 5);
    return k;
  }();
  return k;
}

std::string TestKeyFile() {
  static const std::string path = [] {
    const std::string p = ::testing::TempDir() + "/link_endpoint_test_" + std::to_string(::getpid()) + ".key";
    std::string why;
    EXPECT_TRUE(WriteLinkKey(p, TestKey(), true, &why)) << why;
    return p;
  }();
  return path;
}

// An authenticated ground station (the default a user gets).
LinkOptions Ground() {
  LinkOptions o;
  o.bind = "127.0.0.1:0";
  o.sync_interval_ms = 50;
  o.queue_frames = 1000;  // the test reads at the end
  o.key_file = TestKeyFile();
  return o;
}

SimRobotOptions Robot(int ground_port, double loss, double latency_ms, double jitter_ms) {
  SimRobotOptions o;
  o.ground = "127.0.0.1:" + std::to_string(ground_port);
  o.up = {loss, 1, latency_ms, jitter_ms, 0};
  o.down = {loss, 1, latency_ms, jitter_ms, 0};
  o.has_key = true;
  o.key = TestKey();
  return o;
}

std::vector<uint8_t> Image(int i, size_t bytes) {
  std::vector<uint8_t> v(bytes);
  for (size_t k = 0; k < bytes; ++k) v[k] = static_cast<uint8_t>(k * 13 + i);
  return v;
}

// Waits (bounded) for cond.
template <typename F>
bool WaitFor(F cond, std::chrono::milliseconds limit) {
  const auto until = std::chrono::steady_clock::now() + limit;
  while (!cond()) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(10ms);
  }
  return true;
}

// 8-fragment frames at 10 % loss each way and 50 +- 30 ms: without
// retransmission fewer than half would arrive (0.9^8 = 43 %).
TEST(LinkEndpoint, FramesSurviveLossAndJitterInOrder) {
  LinkEndpoint ground(Ground());
  SimRobot robot(Robot(ground.port(), 0.10, 50, 30));
  ASSERT_TRUE(WaitFor([&] { return robot.authenticated(); }, 10s));
  const int n = 60;
  const size_t bytes = 7 * RL_FRAGMENT_DATA_MAX + 100;  // 8 fragments
  for (int i = 0; i < n; ++i) {
    robot.SendFrame(Image(i, bytes), 320, 240, RL_FORMAT_JPEG, 12);
    std::this_thread::sleep_for(50ms);
  }
  ASSERT_TRUE(WaitFor([&] {
    auto s = ground.stats();
    return s.frames.frames_complete + s.frames.frames_dropped >= static_cast<uint64_t>(n - 1);
  }, 10s));
  std::vector<LinkFrameOut> got;
  LinkFrameOut f;
  while (ground.NextFrame(&f, 0)) got.push_back(f);
  ASSERT_GE(got.size(), static_cast<size_t>(0.9 * n)) << ground.stats().ToJson().dump();
  for (size_t i = 1; i < got.size(); ++i) EXPECT_GT(got[i].frame.frame_id, got[i - 1].frame.frame_id);
  for (auto& g : got) EXPECT_EQ(g.frame.data, Image(static_cast<int>(g.frame.frame_id), bytes));
  const LinkStats s = ground.stats();
  EXPECT_GT(s.frames.fragments_recovered, 0u);
  EXPECT_GT(s.frames.nacks, 0u);
  EXPECT_GT(robot.stats().fragments_resent, 0u);
  // Every frame is accounted for: delivered or counted as dropped (the last may be pending).
  EXPECT_GE(s.frames.frames_complete + s.frames.frames_dropped, static_cast<uint64_t>(n - 1));
  // Latency from capture: at least the link's minimum (20 ms), bounded by the deadline.
  EXPECT_GT(s.latency_p50_ms, 15);
  EXPECT_LT(s.latency_max_ms, 1000);
}

TEST(LinkEndpoint, HaltResumeAreAcknowledgedThroughLoss) {
  LinkEndpoint ground(Ground());
  SimRobot robot(Robot(ground.port(), 0.3, 20, 10));
  // The ground station learns the robot's address from its heartbeat.
  ASSERT_TRUE(WaitFor([&] { return ground.stats().robot_heard; }, 5s));
  // The robot stands until it hears the station, then walks.
  ASSERT_TRUE(WaitFor([&] { return robot.moving(); }, 5s));
  ground.SetHalt(true);
  ASSERT_TRUE(WaitFor([&] { return !robot.moving() && ground.HaltAcknowledged(); }, 10s));
  EXPECT_TRUE(WaitFor([&] { return ground.stats().robot_halted; }, 5s));
  EXPECT_EQ(ground.stats().robot_rssi, -55);  // the robot's heartbeat says how well it hears Wi-Fi
  ground.SetHalt(false);
  ASSERT_TRUE(WaitFor([&] { return robot.moving() && ground.HaltAcknowledged(); }, 10s));
  EXPECT_GE(ground.stats().controls_acked, 2u);
}

TEST(LinkEndpoint, ClockOffsetAndDriftAreEstimated) {
  LinkEndpoint ground(Ground());
  SimRobotOptions ro = Robot(ground.port(), 0.05, 50, 30);
  ro.clock_offset_ms = -12345.678;
  ro.drift_ppm = 50;
  SimRobot robot(ro);
  ASSERT_TRUE(WaitFor([&] { return ground.stats().clock_round_trips >= 60; }, 20s));
  const int64_t now = LinkNowUs();
  const double truth_ms = (robot.RobotClockAt(now) - now) * 1e-3;
  const LinkStats s = ground.stats();
  // Each round trip alone is off by up to 30 ms; loopback under load adds
  // its own asymmetry. The bench (rumi robot-sim) reports the real figure.
  EXPECT_NEAR(s.clock_offset_ms, truth_ms, 5.0) << s.ToJson().dump();
}

TEST(LinkEndpoint, GarbageIsCountedAndFramesStillFlow) {
  LinkEndpoint ground(Ground());
  SimRobot robot(Robot(ground.port(), 0, 0, 0));
  int fd = socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<uint16_t>(ground.port()));
  inet_pton(AF_INET, "127.0.0.1", &to.sin_addr);
  for (int i = 0; i < 50; ++i) {
    std::vector<uint8_t> junk = Image(i, static_cast<size_t>(1 + i * 29));
    sendto(fd, junk.data(), junk.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof(to));
  }
  close(fd);
  ASSERT_TRUE(WaitFor([&] { return robot.authenticated(); }, 10s));
  for (int i = 0; i < 5; ++i) robot.SendFrame(Image(i, 3000), 320, 240, RL_FORMAT_JPEG, 12);
  ASSERT_TRUE(WaitFor([&] { return ground.stats().frames.frames_complete >= 5; }, 5s));
  EXPECT_EQ(ground.stats().bad_datagrams, 50u);
}

TEST(LinkEndpoint, TheRobotStopsWhenTheGroundStationGoesAway) {
  SimRobot* robot = nullptr;
  std::unique_ptr<SimRobot> holder;
  {
    LinkOptions go = Ground();
    LinkEndpoint ground(go);
    SimRobotOptions ro = Robot(ground.port(), 0, 0, 0);
    ro.failsafe_ms = 400;
    holder = std::make_unique<SimRobot>(ro);
    robot = holder.get();
    ASSERT_TRUE(WaitFor([&] { return ground.stats().robot_heard; }, 5s));
    ASSERT_TRUE(WaitFor([&] { return robot->moving(); }, 5s));
    std::this_thread::sleep_for(600ms);  // heartbeats keep it walking
    EXPECT_TRUE(robot->moving());
    EXPECT_EQ(robot->stats().failsafe_stops, 0u);
  }
  EXPECT_TRUE(WaitFor([&] { return !robot->moving(); }, 3s));
  EXPECT_GE(robot->stats().failsafe_stops, 1u);
}

TEST(LinkEndpoint, ALinkTooSlowForTheFramesGetsALowerFrameRate) {
  LinkEndpoint ground(Ground());
  SimRobotOptions ro = Robot(ground.port(), 0, 10, 0);
  ro.up.bandwidth_kbps = 800;  // 30 fps of 6 kB frames need 1,440 kbit/s
  SimRobot robot(ro);
  // A camera at 30 fps that obeys the rate asked for, as robot-sim does.
  const auto t0 = std::chrono::steady_clock::now();
  auto next = t0;
  int i = 0;
  ASSERT_TRUE(WaitFor([&] { return robot.authenticated(); }, 10s));
  while (std::chrono::steady_clock::now() - t0 < 20s && ground.stats().rate_cuts == 0) {
    robot.SendFrame(Image(i++, 6000), 320, 240, RL_FORMAT_JPEG, 12);
    const double fps = robot.asked_fps() > 0 ? robot.asked_fps() : 30.0;
    next += std::chrono::microseconds(static_cast<int64_t>(1e6 / fps));
    std::this_thread::sleep_until(next);
    LinkFrameOut f;
    while (ground.NextFrame(&f, 0)) {
    }
  }
  const LinkStats s = ground.stats();
  ASSERT_GE(s.rate_cuts, 1) << s.ToJson().dump();
  EXPECT_GT(s.rate_asked_fps, 0);
  EXPECT_LT(s.rate_asked_fps, 30);
  // The control reached the robot, acknowledged.
  EXPECT_TRUE(WaitFor([&] { return std::abs(robot.asked_fps() - ground.stats().rate_asked_fps) < 0.01; }, 10s))
      << robot.asked_fps() << " " << ground.stats().ToJson().dump();
  EXPECT_TRUE(ground.stats().ToJson()["rate_control"].contains("asked_fps"));
}

TEST(LinkEndpoint, ABadAddressIsAClearError) {
  LinkOptions o;
  o.insecure = true;
  o.bind = "localhost";
  EXPECT_THROW({ LinkEndpoint e(o); }, std::runtime_error);
  o.bind = "203.0.113.7:5600";  // not this host's address
  try {
    LinkEndpoint e(o);
    FAIL() << "bound a foreign address";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("203.0.113.7:5600"), std::string::npos) << e.what();
  }
}

// ---- authentication and floods (docs/robot_link.md, "Security") -----------

// A UDP socket on loopback: the attacker, or a hand-made robot.
struct Udp {
  int fd = -1;
  int port = 0;
  Udp() {
    fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
    bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a));
    socklen_t l = sizeof(a);
    getsockname(fd, reinterpret_cast<sockaddr*>(&a), &l);
    port = ntohs(a.sin_port);
  }
  ~Udp() { close(fd); }
  void SendTo(int to_port, const std::vector<uint8_t>& d) const {
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(static_cast<uint16_t>(to_port));
    inet_pton(AF_INET, "127.0.0.1", &to.sin_addr);
    sendto(fd, d.data(), d.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof(to));
  }
  // One datagram within timeout; empty when none came.
  std::vector<uint8_t> Recv(int timeout_ms) const {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, timeout_ms) <= 0) return {};
    std::vector<uint8_t> b(RL_MAX_DATAGRAM + 64);
    const ssize_t n = recv(fd, b.data(), b.size(), 0);
    b.resize(n > 0 ? static_cast<size_t>(n) : 0);
    return b;
  }
};

rl_message Msg(uint8_t type, uint32_t id, uint32_t seq, uint16_t robot_id = 1) {
  rl_message m;
  std::memset(&m, 0, sizeof(m));
  m.h.type = type;
  m.h.msg_id = id;
  m.h.seq = seq;
  m.h.robot_id = robot_id;
  m.h.frag_count = 1;
  return m;
}

// Encoded, with a valid CRC; tagged with key when given.
std::vector<uint8_t> Encode(rl_message m, const uint8_t* key = nullptr) {
  if (key) m.h.flags |= RL_FLAG_AUTH;
  std::vector<uint8_t> b(RL_MAX_DATAGRAM);
  size_t n = rl_encode(&m, b.data(), b.size());
  if (n && key) n = rl_seal(key, b.data(), n, b.size());
  b.resize(n);
  return b;
}

TEST(LinkEndpoint, AnInsecureLinkStillWorksWhenAskedFor) {
  LinkOptions go = Ground();
  go.key_file.clear();
  go.insecure = true;
  LinkEndpoint ground(go);
  SimRobotOptions ro = Robot(ground.port(), 0, 0, 0);
  ro.has_key = false;
  SimRobot robot(ro);
  ASSERT_TRUE(WaitFor([&] { return robot.moving(); }, 5s));
  for (int i = 0; i < 3; ++i) robot.SendFrame(Image(i, 3000), 320, 240, RL_FORMAT_JPEG, 12);
  ASSERT_TRUE(WaitFor([&] { return ground.stats().frames.frames_complete >= 3; }, 5s));
  EXPECT_TRUE(ground.stats().insecure);
  EXPECT_FALSE(ground.stats().authenticated);
}

TEST(LinkEndpoint, AKeyedStationIgnoresARobotWithoutKey) {
  LinkEndpoint ground(Ground());
  SimRobotOptions ro = Robot(ground.port(), 0, 0, 0);
  ro.has_key = false;
  SimRobot robot(ro);
  ASSERT_TRUE(WaitFor([&] { return ground.stats().unauthenticated >= 2; }, 5s));
  robot.SendFrame(Image(0, 3000), 320, 240, RL_FORMAT_JPEG, 12);
  std::this_thread::sleep_for(300ms);
  const LinkStats s = ground.stats();
  EXPECT_FALSE(s.robot_heard);
  EXPECT_EQ(s.frames.fragments, 0u);
  EXPECT_FALSE(robot.moving());  // it never heard the station either
}

// The attack of the issue: a spoofed HALT (valid CRC, a huge sequence number;
// without a tag, with another key's tag, with the robot's long-term key) does
// not stop a walking robot, and the real station's commands still work.
TEST(LinkEndpoint, ASpoofedHaltDoesNotStopTheRobot) {
  LinkEndpoint ground(Ground());
  SimRobot robot(Robot(ground.port(), 0, 0, 0));
  ASSERT_TRUE(WaitFor([&] { return robot.authenticated() && robot.moving(); }, 5s));
  Udp attacker;
  LinkKey wrong = TestKey();
  wrong[0] ^= 1;
  for (int i = 0; i < 20; ++i) {
    rl_message halt = Msg(RL_CONTROL, 0x7FFFFFF0u + i, 0xFFFFFF00u + i);
    halt.u.control.command = RL_CMD_HALT;
    attacker.SendTo(robot.port(), Encode(halt));
    attacker.SendTo(robot.port(), Encode(halt, wrong.data()));
    attacker.SendTo(robot.port(), Encode(halt, TestKey().data()));
    rl_message hb = Msg(RL_HEARTBEAT, 0, 0xFFFFFF80u + i);
    hb.u.heartbeat.role = RL_ROLE_GROUND;
    hb.u.heartbeat.halted = 1;
    attacker.SendTo(robot.port(), Encode(hb));
  }
  std::this_thread::sleep_for(500ms);
  EXPECT_TRUE(robot.moving());
  const rr_stats rs = robot.stats();
  EXPECT_GE(rs.unauthenticated, 40u);
  EXPECT_GE(rs.auth_failures, 40u);
  EXPECT_EQ(rs.controls, 0u);
  EXPECT_TRUE(attacker.Recv(100).empty());  // no ack, nothing to the spoofer
  ground.SetHalt(true);
  EXPECT_TRUE(WaitFor([&] { return !robot.moving() && ground.HaltAcknowledged(); }, 5s));
  ground.SetHalt(false);
  EXPECT_TRUE(WaitFor([&] { return robot.moving() && ground.HaltAcknowledged(); }, 5s));
}

// A spoofer that speaks before the robot does not become "the robot": the
// station answers only HELLOs under the robot's key and talks only to the
// address a session was made from.
TEST(LinkEndpoint, ASpooferBeforeTheRobotDoesNotCaptureTheStation) {
  LinkEndpoint ground(Ground());
  Udp attacker;
  LinkKey wrong = TestKey();
  wrong[31] ^= 0x80;
  rl_message hb = Msg(RL_HEARTBEAT, 0, 1);
  hb.u.heartbeat.role = RL_ROLE_ROBOT;
  attacker.SendTo(ground.port(), Encode(hb));
  attacker.SendTo(ground.port(), Encode(hb, wrong.data()));
  rl_message hello = Msg(RL_HELLO, 0, 2);
  hello.u.hello.role = RL_ROLE_ROBOT;
  attacker.SendTo(ground.port(), Encode(hello, wrong.data()));
  ASSERT_TRUE(WaitFor([&] { return ground.stats().auth_failures >= 2; }, 5s));
  EXPECT_EQ(ground.stats().unauthenticated, 1u);
  SimRobot robot(Robot(ground.port(), 0, 0, 0));
  ASSERT_TRUE(WaitFor([&] { return robot.authenticated() && robot.moving(); }, 5s));
  std::this_thread::sleep_for(300ms);  // heartbeats, time syncs
  EXPECT_TRUE(attacker.Recv(0).empty()) << "the station talked to the spoofer";
  const LinkStats s = ground.stats();
  EXPECT_EQ(s.sessions, 1u);
  EXPECT_TRUE(s.authenticated);
  EXPECT_TRUE(s.robot_heard);
}

// A hand-made robot with the key: the HELLO exchange, a datagram accepted
// once, its replay refused, and the same session's datagram from another
// address refused.
TEST(LinkEndpoint, ReplaysAndOtherSourcesAreRefused) {
  LinkEndpoint ground(Ground());
  Udp robot, other;
  rl_message hello = Msg(RL_HELLO, 0, 1);
  hello.u.hello.role = RL_ROLE_ROBOT;
  for (size_t i = 0; i < RL_NONCE_SIZE; ++i) hello.u.hello.nonce_robot[i] = static_cast<uint8_t>(0xA0 + i);
  robot.SendTo(ground.port(), Encode(hello, TestKey().data()));
  const std::vector<uint8_t> answer = robot.Recv(5000);
  rl_message a;
  ASSERT_EQ(rl_parse(answer.data(), answer.size(), &a), RL_OK);
  ASSERT_EQ(a.h.type, RL_HELLO);
  ASSERT_TRUE(rl_verify(TestKey().data(), answer.data(), answer.size(), &a));
  ASSERT_EQ(std::memcmp(a.u.hello.nonce_robot, hello.u.hello.nonce_robot, RL_NONCE_SIZE), 0);
  LinkKey session;
  ASSERT_EQ(rl_session_key(TestKey().data(), a.u.hello.nonce_robot, a.u.hello.nonce_ground, session.data()), 0);
  rl_message hb = Msg(RL_HEARTBEAT, 0, 10);
  hb.u.heartbeat.role = RL_ROLE_ROBOT;
  const std::vector<uint8_t> d = Encode(hb, session.data());
  robot.SendTo(ground.port(), d);
  ASSERT_TRUE(WaitFor([&] { return ground.stats().authenticated; }, 5s));
  robot.SendTo(ground.port(), d);  // the same bytes again
  ASSERT_TRUE(WaitFor([&] { return ground.stats().replays >= 1; }, 5s));
  hb.h.seq = 11;
  other.SendTo(ground.port(), Encode(hb, session.data()));  // authentic, but from elsewhere
  ASSERT_TRUE(WaitFor([&] { return ground.stats().wrong_source >= 1; }, 5s));
  const LinkStats s = ground.stats();
  EXPECT_EQ(s.sessions, 1u);
  EXPECT_EQ(s.replays, 1u);
  EXPECT_EQ(s.wrong_source, 1u);
  // The station's own datagrams go to the pinned robot only, tagged with the session key.
  const std::vector<uint8_t> out = robot.Recv(2000);
  rl_message m;
  ASSERT_EQ(rl_parse(out.data(), out.size(), &m), RL_OK);
  EXPECT_TRUE(rl_verify(session.data(), out.data(), out.size(), &m));
  EXPECT_TRUE(other.Recv(300).empty());
}

// Garbage with valid CRCs (random frame ids, 96 fragments, the largest
// sizes, replayed ids, NACK and control storms) sent at both ends while the
// robot streams: it costs counters, not frames. The robot streams 90 frames at
// 30 fps without, then with the flood; with it the station gets at least 90 %
// of the frames it got without it, never resyncs and NACKs no more than a
// few times per frame.
TEST(LinkEndpoint, AFloodOfForgedDatagramsDoesNotSlowTheRobot) {
  LinkEndpoint ground(Ground());
  SimRobot robot(Robot(ground.port(), 0, 0, 0));
  ASSERT_TRUE(WaitFor([&] { return robot.authenticated(); }, 5s));
  const size_t bytes = 3 * RL_FRAGMENT_DATA_MAX + 100;  // 4 fragments
  int next_image = 0;
  auto stream = [&](int frames) {
    const uint64_t before = ground.stats().frames.frames_complete;
    auto next = std::chrono::steady_clock::now();
    for (int i = 0; i < frames; ++i) {
      robot.SendFrame(Image(next_image++, bytes), 320, 240, RL_FORMAT_JPEG, 12);
      next += 33ms;
      std::this_thread::sleep_until(next);
    }
    std::this_thread::sleep_for(800ms);  // deadlines pass, NACKs are answered
    return ground.stats().frames.frames_complete - before;
  };
  const uint64_t calm = stream(90);
  ASSERT_GE(calm, 80u) << ground.stats().ToJson().dump();

  std::atomic<bool> flooding{true};
  std::atomic<uint64_t> forged{0};
  std::thread flood([&] {
    Udp attacker;
    std::mt19937 rng(7);
    std::vector<uint8_t> image(RL_FRAGMENT_DATA_MAX);
    const uint8_t* keys[2] = {nullptr, TestKey().data()};  // untagged, and tagged with the wrong key (the long-term one)
    auto next = std::chrono::steady_clock::now();
    while (flooding && forged < 40000) {
      for (int k = 0; k < 20; ++k, ++forged) {
        rl_message f = Msg(RL_FRAME, rng(), rng());
        f.h.frag_count = RL_MAX_FRAGMENTS;
        f.h.frag_index = static_cast<uint16_t>(rng() % (RL_MAX_FRAGMENTS - 1));
        f.u.frame.meta = {RL_MAX_FRAME_BYTES, f.h.frag_index * RL_FRAGMENT_DATA_MAX, 65535, 65535, RL_FORMAT_JPEG, 1};
        f.u.frame.data = image.data();
        f.u.frame.len = static_cast<uint16_t>(RL_FRAGMENT_DATA_MAX);
        attacker.SendTo(ground.port(), Encode(f, keys[k % 2]));
        rl_message n = Msg(RL_NACK, rng() % 8, rng());  // ids the robot keeps
        attacker.SendTo(robot.port(), Encode(n, keys[k % 2]));
      }
      next += 4ms;  // 5,000 forged datagrams a second each way
      std::this_thread::sleep_until(next);
    }
  });
  const uint64_t flooded = stream(90);
  flooding = false;
  flood.join();
  const LinkStats s = ground.stats();
  const rr_stats rs = robot.stats();
  std::cout << "flood: " << calm << " frames of 90 without, " << flooded << " with " << forged.load()
            << " forged datagrams each way; refused by the station " << s.unauthenticated + s.auth_failures
            << ", by the robot " << rs.unauthenticated + rs.auth_failures << "; NACKs " << s.frames.nacks << "\n";
  EXPECT_GE(static_cast<double>(flooded), 0.9 * static_cast<double>(calm)) << s.ToJson().dump();
  EXPECT_GT(forged.load(), 5000u);
  // Counted (the kernel may drop some of the flood before anyone sees it).
  EXPECT_GE(s.unauthenticated + s.auth_failures, forged.load() / 4);
  EXPECT_GE(rs.unauthenticated + rs.auth_failures, forged.load() / 4);
  EXPECT_EQ(s.frames.resyncs, 0u);
  EXPECT_LE(s.frames.nacks, 3u * 180u);
  EXPECT_LE(rs.fragments_resent, 4 * s.frames.nacks);  // only the station's own NACKs were answered
}

}  // namespace
}  // namespace rumi
