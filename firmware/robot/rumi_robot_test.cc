#include "rumi_robot.h"

#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <vector>

namespace {

struct FakeHw {
  uint64_t now = 1000000;
  std::vector<std::vector<uint8_t>> sent;
  std::vector<std::pair<int, int>> motion;  // (moving, gait) calls
  int camera_calls = 0;
  bool camera_fails = false;

  static int Send(void* c, const uint8_t* d, size_t n) {
    static_cast<FakeHw*>(c)->sent.emplace_back(d, d + n);
    return 0;
  }
  static uint64_t Now(void* c) { return static_cast<FakeHw*>(c)->now; }
  static void Motion(void* c, int moving, int gait) { static_cast<FakeHw*>(c)->motion.push_back({moving, gait}); }
  static int Camera(void* c, int, int, int, int) {
    auto* h = static_cast<FakeHw*>(c);
    ++h->camera_calls;
    return h->camera_fails ? -1 : 0;
  }
  static int Rssi(void* c) { return static_cast<FakeHw*>(c)->rssi; }
  // Deterministic "randomness": a counter, so every nonce differs.
  static int Random(void* c, uint8_t* out, size_t n) {
    auto* h = static_cast<FakeHw*>(c);
    for (size_t i = 0; i < n; ++i) out[i] = static_cast<uint8_t>(h->random_counter++ * 37 + i);
    return 0;
  }
  int rssi = -61;
  unsigned random_counter = 1;
  rr_hw Hw() { return {this, Send, Now, Motion, Camera, Rssi, Random}; }

  std::vector<rl_message> Parsed(int type) const {
    std::vector<rl_message> out;
    for (auto& d : sent) {
      rl_message m;
      EXPECT_EQ(rl_parse(d.data(), d.size(), &m), RL_OK);
      if (m.h.type == type) out.push_back(m);
    }
    return out;
  }
};

class RobotTest : public ::testing::Test {
 protected:
  void SetUp() override {
    robot_ = std::make_unique<rr_robot>();
    rr_config c;
    rr_config_default(&c);
    c.robot_id = 5;
    rr_hw hw = hw_.Hw();
    rr_init(robot_.get(), &hw, &c);
    Receive(GroundHeartbeat());  // the station is there: the robot walks
  }
  static rl_message GroundHeartbeat(int halted = 0) {
    rl_message hb = Msg(RL_HEARTBEAT);
    hb.u.heartbeat.role = RL_ROLE_GROUND;
    hb.u.heartbeat.halted = static_cast<uint8_t>(halted);
    return hb;
  }
  // A datagram from the ground station.
  void Receive(rl_message m) {
    m.h.robot_id = 5;
    m.h.seq = ground_seq_++;
    uint8_t buf[RL_MAX_DATAGRAM];
    size_t n = rl_encode(&m, buf, sizeof(buf));
    ASSERT_GT(n, 0u);
    rr_on_datagram(robot_.get(), buf, n);
  }
  static rl_message Msg(uint8_t type, uint32_t id = 0) {
    rl_message m;
    std::memset(&m, 0, sizeof(m));
    m.h.type = type;
    m.h.msg_id = id;
    m.h.frag_count = 1;
    return m;
  }
  static rl_message Control(uint32_t id, uint8_t cmd, int32_t a0 = 0, int32_t a1 = 0) {
    rl_message m = Msg(RL_CONTROL, id);
    m.u.control.command = cmd;
    m.u.control.arg[0] = a0;
    m.u.control.arg[1] = a1;
    return m;
  }
  FakeHw hw_;
  std::unique_ptr<rr_robot> robot_;
  uint32_t ground_seq_ = 100;
};

TEST_F(RobotTest, FramesAreFragmentedAndResentOnNack) {
  std::vector<uint8_t> img(5000);
  for (size_t i = 0; i < img.size(); ++i) img[i] = static_cast<uint8_t>(i);
  ASSERT_EQ(rr_send_frame(robot_.get(), img.data(), img.size(), 320, 240, RL_FORMAT_JPEG, 12, 777), 0);
  auto frags = hw_.Parsed(RL_FRAME);
  ASSERT_EQ(frags.size(), 4u);  // 5000 / 1420
  std::vector<uint8_t> back(5000);
  for (auto& f : frags) {
    EXPECT_EQ(f.h.time_us, 777u);
    EXPECT_EQ(f.h.frag_count, 4);
    std::memcpy(back.data() + f.u.frame.meta.offset, f.u.frame.data, f.u.frame.len);
  }
  EXPECT_EQ(back, img);

  hw_.sent.clear();
  rl_message nack = Msg(RL_NACK, 0);
  nack.u.nack.count = 2;
  nack.u.nack.index[0] = 1;
  nack.u.nack.index[1] = 3;
  Receive(nack);
  auto resent = hw_.Parsed(RL_FRAME);
  ASSERT_EQ(resent.size(), 2u);
  EXPECT_EQ(resent[0].h.frag_index, 1);
  EXPECT_EQ(resent[1].h.frag_index, 3);
  EXPECT_TRUE(resent[0].h.flags & RL_FLAG_RETRANSMIT);
  EXPECT_EQ(robot_->stats.fragments_resent, 2u);

  // A whole-frame NACK (none of it arrived) resends everything.
  hw_.sent.clear();
  Receive(Msg(RL_NACK, 0));
  EXPECT_EQ(hw_.Parsed(RL_FRAME).size(), 4u);

  // Frames older than the send buffer are gone: counted, nothing sent.
  for (int i = 0; i < RR_KEEP_FRAMES; ++i) rr_send_frame(robot_.get(), img.data(), 100, 320, 240, RL_FORMAT_JPEG, 12, 0);
  hw_.sent.clear();
  Receive(Msg(RL_NACK, 0));
  EXPECT_TRUE(hw_.Parsed(RL_FRAME).empty());
  EXPECT_EQ(robot_->stats.nacks_too_old, 1u);
}

TEST_F(RobotTest, TooLargeFramesAreSkippedAndCounted) {
  std::vector<uint8_t> big(RL_MAX_FRAME_BYTES + 1);
  EXPECT_EQ(rr_send_frame(robot_.get(), big.data(), big.size(), 640, 480, RL_FORMAT_JPEG, 12, 0), -1);
  EXPECT_EQ(robot_->stats.frames_skipped, 1u);
  EXPECT_TRUE(hw_.sent.empty());
}

TEST_F(RobotTest, ARobotStandsUntilItFirstHearsTheGroundStation) {
  FakeHw hw;
  rr_robot robot;
  rr_config c;
  rr_config_default(&c);
  c.robot_id = 5;
  const rr_hw h = hw.Hw();
  rr_init(&robot, &h, &c);
  ASSERT_FALSE(hw.motion.empty());
  EXPECT_EQ(hw.motion.back().first, 0);
  EXPECT_FALSE(rr_moving(&robot));
  // Nobody there for 5 s: still standing, and that is no fail-safe stop.
  for (int i = 0; i < 50; ++i) {
    hw.now += 100000;
    rr_poll(&robot);
  }
  EXPECT_FALSE(rr_moving(&robot));
  EXPECT_EQ(robot.stats.failsafe_stops, 0u);
  // Its heartbeats say why it stands.
  hw.sent.clear();
  hw.now += 500000;
  rr_poll(&robot);
  auto hbs = hw.Parsed(RL_HEARTBEAT);
  ASSERT_EQ(hbs.size(), 1u);
  EXPECT_EQ(hbs[0].u.heartbeat.failsafe, 1);
  EXPECT_EQ(hbs[0].u.heartbeat.rssi, -61);  // and how well it hears the access point
  hw.rssi = -300;                           // a driver's nonsense is clamped
  hw.now += 500000;
  rr_poll(&robot);
  EXPECT_EQ(hw.Parsed(RL_HEARTBEAT).back().u.heartbeat.rssi, -128);
  // The station comes up: the robot walks.
  rl_message hb = GroundHeartbeat();
  hb.h.robot_id = 5;
  uint8_t buf[RL_MAX_DATAGRAM];
  const size_t n = rl_encode(&hb, buf, sizeof(buf));
  ASSERT_GT(n, 0u);
  rr_on_datagram(&robot, buf, n);
  EXPECT_TRUE(rr_moving(&robot));
  EXPECT_EQ(hw.motion.back().first, 1);
}

TEST_F(RobotTest, AHaltHeardFirstKeepsTheRobotStanding) {
  FakeHw hw;
  rr_robot robot;
  rr_config c;
  rr_config_default(&c);
  c.robot_id = 5;
  const rr_hw h = hw.Hw();
  rr_init(&robot, &h, &c);
  // The station's first word is a halt (rumi calibrate --link): the legs
  // are never told to walk, not even for the length of one message.
  rl_message halt = Control(1, RL_CMD_HALT);
  halt.h.robot_id = 5;
  uint8_t buf[RL_MAX_DATAGRAM];
  const size_t n = rl_encode(&halt, buf, sizeof(buf));
  ASSERT_GT(n, 0u);
  rr_on_datagram(&robot, buf, n);
  EXPECT_FALSE(rr_moving(&robot));
  EXPECT_EQ(robot.failsafe, 0);
  for (const auto& m : hw.motion) EXPECT_EQ(m.first, 0);
  EXPECT_EQ(hw.Parsed(RL_ACK).size(), 1u);
}

TEST_F(RobotTest, HaltResumeAreAckedAppliedOnceAndMoveTheServos) {
  ASSERT_EQ(hw_.motion.back().first, 1);  // walks once the station is heard
  Receive(Control(1, RL_CMD_HALT));
  EXPECT_FALSE(rr_moving(robot_.get()));
  EXPECT_EQ(hw_.motion.back().first, 0);
  auto acks = hw_.Parsed(RL_ACK);
  ASSERT_EQ(acks.size(), 1u);
  EXPECT_EQ(acks[0].h.msg_id, 1u);
  EXPECT_EQ(acks[0].u.ack.result, RL_ACK_OK);
  EXPECT_EQ(acks[0].u.ack.halted, 1);
  // The ack was lost, the ground station retries: acked again, applied once.
  const size_t motions = hw_.motion.size();
  Receive(Control(1, RL_CMD_HALT));
  EXPECT_EQ(hw_.Parsed(RL_ACK).size(), 2u);
  EXPECT_EQ(robot_->stats.controls, 1u);
  EXPECT_EQ(hw_.motion.size(), motions);
  Receive(Control(2, RL_CMD_RESUME));
  EXPECT_TRUE(rr_moving(robot_.get()));
  EXPECT_EQ(hw_.motion.back().first, 1);
}

TEST_F(RobotTest, AStaleHeartbeatDoesNotUndoAHalt) {
  rl_message hb = GroundHeartbeat();
  // Sent before the halt (lower sequence number) but delivered after it.
  ground_seq_ = 200;
  Receive(Control(3, RL_CMD_HALT));
  ground_seq_ = 150;
  Receive(hb);
  EXPECT_FALSE(rr_moving(robot_.get()));
  // A newer heartbeat that still wants the robot halted: halted.
  ground_seq_ = 300;
  hb.u.heartbeat.halted = 1;
  Receive(hb);
  EXPECT_FALSE(rr_moving(robot_.get()));
  // The halt control and all its retries were lost, the heartbeat says resume.
  hb.u.heartbeat.halted = 0;
  Receive(hb);
  EXPECT_TRUE(rr_moving(robot_.get()));
}

TEST_F(RobotTest, FailsafeStopsARobotThatHearsNothing) {
  ASSERT_TRUE(rr_moving(robot_.get()));
  hw_.now += 1999000;
  rr_poll(robot_.get());
  EXPECT_TRUE(rr_moving(robot_.get()));
  hw_.now += 2000;
  rr_poll(robot_.get());
  EXPECT_FALSE(rr_moving(robot_.get()));
  EXPECT_EQ(hw_.motion.back().first, 0);
  EXPECT_EQ(robot_->stats.failsafe_stops, 1u);
  // Heartbeats still go out while stopped, and say so.
  auto hbs = hw_.Parsed(RL_HEARTBEAT);
  ASSERT_FALSE(hbs.empty());
  EXPECT_EQ(hbs.back().u.heartbeat.failsafe, 1);
  // The ground station is back (a restarted one: sequence numbers from 0).
  ground_seq_ = 0;
  Receive(GroundHeartbeat());
  EXPECT_TRUE(rr_moving(robot_.get()));
  Receive(Control(1, RL_CMD_HALT));  // its first control id: applied
  EXPECT_FALSE(rr_moving(robot_.get()));
}

TEST_F(RobotTest, TimeSyncEchoesAndStampsBothEnds) {
  rl_message q = Msg(RL_TIME_REQ, 9);
  q.u.time.t1 = 123456;
  hw_.now = 5000000;
  Receive(q);
  auto r = hw_.Parsed(RL_TIME_RESP);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].h.msg_id, 9u);
  EXPECT_EQ(r[0].u.time.t1, 123456u);
  EXPECT_EQ(r[0].u.time.t2, 5000000u);
  EXPECT_GE(r[0].u.time.t3, r[0].u.time.t2);
}

TEST_F(RobotTest, ImuIsBatchedBySizeAndAge) {
  rl_imu_sample s = {0, {0, 0, 9.8f}, {0, 0, 0}};
  for (int i = 0; i < 25; ++i) {
    s.t_us = hw_.now + i * 5000;
    rr_add_imu(robot_.get(), &s);
  }
  EXPECT_EQ(hw_.Parsed(RL_IMU).size(), 2u);  // 10 + 10, 5 waiting
  hw_.now += 200000;
  rr_poll(robot_.get());
  auto b = hw_.Parsed(RL_IMU);
  ASSERT_EQ(b.size(), 3u);
  EXPECT_EQ(b[2].u.imu.count, 5);
  EXPECT_EQ(b[2].h.msg_id, 2u);
}

TEST_F(RobotTest, CameraCommandsValidateTheirArguments) {
  Receive(Control(1, RL_CMD_QUALITY, 99));
  Receive(Control(2, RL_CMD_QUALITY, 10));
  Receive(Control(3, RL_CMD_FRAME_SIZE, 320, 240));
  Receive(Control(4, 77));  // a command this firmware does not know
  auto acks = hw_.Parsed(RL_ACK);
  ASSERT_EQ(acks.size(), 4u);
  EXPECT_EQ(acks[0].u.ack.result, RL_ACK_BAD_ARGUMENT);
  EXPECT_EQ(acks[1].u.ack.result, RL_ACK_OK);
  EXPECT_EQ(acks[2].u.ack.result, RL_ACK_OK);
  EXPECT_EQ(acks[3].u.ack.result, RL_ACK_UNSUPPORTED);
  EXPECT_EQ(hw_.camera_calls, 2);
  EXPECT_EQ(robot_->quality, 10);
  EXPECT_EQ(robot_->width, 320);
}

TEST_F(RobotTest, GarbageAndOtherRobotsAreCountedAndIgnored) {
  std::vector<uint8_t> junk(100, 0x55);
  rr_on_datagram(robot_.get(), junk.data(), junk.size());
  rl_message c = Control(1, RL_CMD_HALT);
  c.h.robot_id = 6;
  uint8_t buf[RL_MAX_DATAGRAM];
  size_t n = rl_encode(&c, buf, sizeof(buf));
  rr_on_datagram(robot_.get(), buf, n);
  EXPECT_EQ(robot_->stats.bad_datagrams, 2u);
  EXPECT_TRUE(rr_moving(robot_.get()));
  EXPECT_TRUE(hw_.Parsed(RL_ACK).empty());
}

// ---- the authenticated link ------------------------------------------------

class KeyedRobotTest : public RobotTest {
 protected:
  void SetUp() override {
    for (size_t i = 0; i < RL_KEY_SIZE; ++i) key_[i] = static_cast<uint8_t>(i * 11 + 3);
    robot_ = std::make_unique<rr_robot>();
    rr_config c;
    rr_config_default(&c);
    c.robot_id = 5;
    c.has_key = 1;
    std::memcpy(c.key, key_, RL_KEY_SIZE);
    rr_hw hw = hw_.Hw();
    rr_init(robot_.get(), &hw, &c);
    rr_poll(robot_.get());  // the first HELLO
  }
  // Encodes m as the ground station would, tagged with key (none: untagged).
  std::vector<uint8_t> Datagram(rl_message m, const uint8_t* key, uint32_t seq) {
    m.h.robot_id = 5;
    m.h.seq = seq;
    if (key) m.h.flags |= RL_FLAG_AUTH;
    std::vector<uint8_t> buf(RL_MAX_DATAGRAM);
    size_t n = rl_encode(&m, buf.data(), buf.size());
    EXPECT_GT(n, 0u);
    if (key) n = rl_seal(key, buf.data(), n, buf.size());
    EXPECT_GT(n, 0u);
    buf.resize(n);
    return buf;
  }
  void Deliver(const std::vector<uint8_t>& d) { rr_on_datagram(robot_.get(), d.data(), d.size()); }
  // Answers the robot's newest HELLO as the real ground station; returns the bytes.
  std::vector<uint8_t> AnswerHello(uint8_t ground_nonce_byte = 0x77) {
    const std::vector<rl_message> hellos = hw_.Parsed(RL_HELLO);
    EXPECT_FALSE(hellos.empty());
    rl_message a = Msg(RL_HELLO);
    a.u.hello.role = RL_ROLE_GROUND;
    std::memcpy(a.u.hello.nonce_robot, hellos.back().u.hello.nonce_robot, RL_NONCE_SIZE);
    std::memset(a.u.hello.nonce_ground, ground_nonce_byte, RL_NONCE_SIZE);
    EXPECT_EQ(rl_session_key(key_, a.u.hello.nonce_robot, a.u.hello.nonce_ground, session_), 0);
    std::vector<uint8_t> d = Datagram(a, key_, ground_seq_++);
    Deliver(d);
    return d;
  }
  // Every datagram the robot sent carries a tag that key (or the session's) made.
  void ExpectAllTagged() {
    for (auto& d : hw_.sent) {
      rl_message m;
      ASSERT_EQ(rl_parse(d.data(), d.size(), &m), RL_OK);
      ASSERT_NE(m.tag, nullptr) << rl_type_name(m.h.type);
      EXPECT_TRUE(rl_verify(m.h.type == RL_HELLO ? key_ : session_, d.data(), d.size(), &m)) << rl_type_name(m.h.type);
    }
  }
  uint8_t key_[RL_KEY_SIZE];
  uint8_t session_[RL_KEY_SIZE] = {};
};

TEST_F(KeyedRobotTest, SaysHelloAndNothingElseBeforeASession) {
  static uint8_t img[3000];
  EXPECT_EQ(rr_send_frame(robot_.get(), img, sizeof(img), 320, 240, RL_FORMAT_JPEG, 12, 5), -1);
  EXPECT_EQ(robot_->stats.frames_no_session, 1u);
  hw_.now += 600000;
  rr_poll(robot_.get());
  EXPECT_EQ(hw_.Parsed(RL_HELLO).size(), 2u);
  EXPECT_EQ(hw_.sent.size(), 2u);  // no heartbeat, no frame
  ExpectAllTagged();
  EXPECT_FALSE(rr_moving(robot_.get()));
  EXPECT_FALSE(rr_authenticated(robot_.get()));
}

TEST_F(KeyedRobotTest, AnAnsweredHelloStartsASessionAndEverythingIsTagged) {
  AnswerHello();
  EXPECT_TRUE(rr_authenticated(robot_.get()));
  EXPECT_EQ(robot_->stats.sessions, 1u);
  EXPECT_TRUE(rr_moving(robot_.get()));  // the station is heard
  static uint8_t img[3000];
  EXPECT_GE(rr_send_frame(robot_.get(), img, sizeof(img), 320, 240, RL_FORMAT_JPEG, 12, 5), 0);
  rr_poll(robot_.get());
  EXPECT_FALSE(hw_.Parsed(RL_HEARTBEAT).empty());
  EXPECT_EQ(hw_.Parsed(RL_FRAME).size(), 3u);
  ExpectAllTagged();
}

TEST_F(KeyedRobotTest, SpoofedControlsAreRefused) {
  AnswerHello();
  Deliver(Datagram(GroundHeartbeat(0), session_, ground_seq_++));
  ASSERT_TRUE(rr_moving(robot_.get()));
  uint8_t wrong[RL_KEY_SIZE];
  std::memset(wrong, 0x42, sizeof(wrong));
  Deliver(Datagram(Control(7, RL_CMD_HALT), nullptr, ground_seq_ + 1000));  // no tag, a huge sequence number
  EXPECT_EQ(robot_->stats.unauthenticated, 1u);
  Deliver(Datagram(Control(8, RL_CMD_HALT), wrong, ground_seq_ + 1));  // a tag of another key
  Deliver(Datagram(Control(9, RL_CMD_HALT), key_, ground_seq_ + 1));   // the robot's key, not the session's
  EXPECT_EQ(robot_->stats.auth_failures, 2u);
  Deliver(Datagram(Control(10, RL_CMD_HALT), session_, ground_seq_ + RL_REPLAY_MAX_JUMP + 1));  // a jump
  EXPECT_EQ(robot_->stats.replays, 1u);
  EXPECT_TRUE(rr_moving(robot_.get()));
  EXPECT_TRUE(hw_.Parsed(RL_ACK).empty());
  EXPECT_EQ(robot_->stats.controls, 0u);
  // The real station's next control still works: nothing above moved its window.
  Deliver(Datagram(Control(11, RL_CMD_HALT), session_, ground_seq_++));
  EXPECT_FALSE(rr_moving(robot_.get()));
  EXPECT_EQ(hw_.Parsed(RL_ACK).size(), 1u);
}

TEST_F(KeyedRobotTest, AReplayedControlIsRefused) {
  AnswerHello();
  const std::vector<uint8_t> halt = Datagram(Control(20, RL_CMD_HALT), session_, ground_seq_++);
  Deliver(halt);
  EXPECT_FALSE(rr_moving(robot_.get()));
  Deliver(Datagram(Control(21, RL_CMD_RESUME), session_, ground_seq_++));
  EXPECT_TRUE(rr_moving(robot_.get()));
  Deliver(halt);  // captured and sent again
  EXPECT_TRUE(rr_moving(robot_.get()));
  EXPECT_EQ(robot_->stats.replays, 1u);
  // Reordered (older, never seen) datagrams within the window still count.
  const uint32_t later = ground_seq_ + 5;
  Deliver(Datagram(GroundHeartbeat(0), session_, later));
  Deliver(Datagram(GroundHeartbeat(0), session_, later - 2));
  EXPECT_EQ(robot_->stats.replays, 1u);
}

TEST_F(KeyedRobotTest, AFailsafeEndsTheSessionAndOldAnswersDoNotRestoreIt) {
  const std::vector<uint8_t> old_answer = AnswerHello(0x11);
  const std::vector<uint8_t> old_control = Datagram(Control(30, RL_CMD_RESUME), session_, ground_seq_++);
  hw_.now += 3000000;  // nothing heard for longer than failsafe_ms
  rr_poll(robot_.get());
  EXPECT_FALSE(rr_authenticated(robot_.get()));
  EXPECT_FALSE(rr_moving(robot_.get()));
  Deliver(old_answer);  // for the old nonce
  Deliver(old_control);
  EXPECT_FALSE(rr_authenticated(robot_.get()));
  EXPECT_FALSE(rr_moving(robot_.get()));
  EXPECT_EQ(robot_->stats.unauthenticated, 2u);
  AnswerHello(0x22);  // the (restarted) station answers the new HELLO
  EXPECT_TRUE(rr_authenticated(robot_.get()));
  EXPECT_EQ(robot_->stats.sessions, 2u);
  EXPECT_TRUE(rr_moving(robot_.get()));
}

}  // namespace
