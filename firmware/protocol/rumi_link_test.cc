#include "rumi_link.h"
#include "rumi_link_auth.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace {

using Bytes = std::vector<uint8_t>;

Bytes Encode(const rl_message& m) {
  Bytes out(RL_MAX_DATAGRAM);
  size_t n = rl_encode(&m, out.data(), out.size());
  out.resize(n);
  return out;
}

rl_message Header(uint8_t type, uint32_t msg_id = 7) {
  rl_message m;
  std::memset(&m, 0, sizeof(m));
  m.h.type = type;
  m.h.robot_id = 3;
  m.h.seq = 0xDEADBEEF;
  m.h.msg_id = msg_id;
  m.h.frag_count = 1;
  m.h.time_us = 0x0123456789ABCDEFull;
  return m;
}

// One valid datagram of every type (also the seed corpus of the fuzzer).
std::map<std::string, Bytes> Samples() {
  std::map<std::string, Bytes> s;
  static uint8_t image[3000];
  for (size_t i = 0; i < sizeof(image); ++i) image[i] = static_cast<uint8_t>(i * 31);
  for (uint16_t k = 0; k < 3; ++k) {
    rl_message m = Header(RL_FRAME, 42);
    m.h.frag_index = k;
    m.h.frag_count = 3;
    m.u.frame.meta = {3000, k * RL_FRAGMENT_DATA_MAX, 320, 240, RL_FORMAT_JPEG, 12};
    m.u.frame.data = image + k * RL_FRAGMENT_DATA_MAX;
    m.u.frame.len = static_cast<uint16_t>(k < 2 ? RL_FRAGMENT_DATA_MAX : 3000 - 2 * RL_FRAGMENT_DATA_MAX);
    s["frame_" + std::to_string(k)] = Encode(m);
  }
  rl_message imu = Header(RL_IMU);
  imu.u.imu.count = 5;
  for (int i = 0; i < 5; ++i) imu.u.imu.sample[i] = {1000u + i * 5000u, {0.1f, 9.81f, -0.2f}, {0.01f * i, -0.5f, 1e-3f}};
  s["imu"] = Encode(imu);
  rl_message c = Header(RL_CONTROL, 9);
  c.u.control = {RL_CMD_FRAME_SIZE, {320, 240, 0}};
  s["control_size"] = Encode(c);
  c.u.control = {RL_CMD_HALT, {0, 0, 0}};
  s["control_halt"] = Encode(c);
  rl_message a = Header(RL_ACK, 9);
  a.u.ack = {RL_CMD_HALT, RL_ACK_OK, 1};
  s["ack"] = Encode(a);
  rl_message hb = Header(RL_HEARTBEAT, 0);
  hb.u.heartbeat = {RL_ROLE_ROBOT, 0, 0, -61, 100, 2, 17, 2000, 12345};
  s["heartbeat"] = Encode(hb);
  rl_message tq = Header(RL_TIME_REQ, 5);
  tq.u.time.t1 = 111;
  s["time_req"] = Encode(tq);
  rl_message tr = Header(RL_TIME_RESP, 5);
  tr.u.time = {111, 222, 333};
  s["time_resp"] = Encode(tr);
  rl_message n = Header(RL_NACK, 42);
  n.u.nack.count = 2;
  n.u.nack.index[0] = 0;
  n.u.nack.index[1] = 2;
  s["nack"] = Encode(n);
  rl_message all = Header(RL_NACK, 43);
  s["nack_all"] = Encode(all);
  rl_message hello = Header(RL_HELLO, 0);
  hello.u.hello.role = RL_ROLE_ROBOT;
  for (size_t i = 0; i < RL_NONCE_SIZE; ++i) hello.u.hello.nonce_robot[i] = static_cast<uint8_t>(i + 1);
  s["hello"] = Encode(hello);
  // An authenticated heartbeat (the tag of a fixed key): the fuzzer starts
  // from tagged datagrams too.
  rl_message ahb = Header(RL_HEARTBEAT, 0);
  ahb.u.heartbeat = {RL_ROLE_GROUND, 1, 0, 0, 0, 0, 0, 0, 0};
  ahb.h.flags = RL_FLAG_AUTH;
  Bytes sealed(RL_MAX_DATAGRAM);
  const size_t n0 = rl_encode(&ahb, sealed.data(), sealed.size());
  uint8_t key[RL_KEY_SIZE];
  std::memset(key, 0x5A, sizeof(key));  // the fuzz target's keyed robot's key
  sealed.resize(rl_seal(key, sealed.data(), n0, sealed.size()));
  s["heartbeat_auth"] = sealed;
  return s;
}

TEST(RumiLink, Crc32IsIeee) {
  const char* text = "123456789";
  EXPECT_EQ(rl_crc32(0, reinterpret_cast<const uint8_t*>(text), 9), 0xCBF43926u);
  // Continued over two parts = over the whole.
  uint32_t c = rl_crc32(0, reinterpret_cast<const uint8_t*>(text), 4);
  EXPECT_EQ(rl_crc32(c, reinterpret_cast<const uint8_t*>(text) + 4, 5), 0xCBF43926u);
}

TEST(RumiLink, EveryTypeRoundTrips) {
  auto s = Samples();
  rl_message m;
  ASSERT_EQ(rl_parse(s["frame_2"].data(), s["frame_2"].size(), &m), RL_OK);
  EXPECT_EQ(m.h.type, RL_FRAME);
  EXPECT_EQ(m.h.robot_id, 3);
  EXPECT_EQ(m.h.seq, 0xDEADBEEFu);
  EXPECT_EQ(m.h.msg_id, 42u);
  EXPECT_EQ(m.h.frag_index, 2);
  EXPECT_EQ(m.h.frag_count, 3);
  EXPECT_EQ(m.h.time_us, 0x0123456789ABCDEFull);
  EXPECT_EQ(m.u.frame.meta.total_len, 3000u);
  EXPECT_EQ(m.u.frame.meta.offset, 2 * RL_FRAGMENT_DATA_MAX);
  EXPECT_EQ(m.u.frame.meta.width, 320);
  EXPECT_EQ(m.u.frame.len, 3000 - 2 * RL_FRAGMENT_DATA_MAX);
  EXPECT_EQ(m.u.frame.data[0], static_cast<uint8_t>(2 * RL_FRAGMENT_DATA_MAX * 31));

  ASSERT_EQ(rl_parse(s["imu"].data(), s["imu"].size(), &m), RL_OK);
  ASSERT_EQ(m.u.imu.count, 5);
  EXPECT_EQ(m.u.imu.sample[4].t_us, 21000u);
  EXPECT_FLOAT_EQ(m.u.imu.sample[4].gyro[0], 0.04f);
  EXPECT_FLOAT_EQ(m.u.imu.sample[1].accel[1], 9.81f);

  ASSERT_EQ(rl_parse(s["control_size"].data(), s["control_size"].size(), &m), RL_OK);
  EXPECT_EQ(m.u.control.command, RL_CMD_FRAME_SIZE);
  EXPECT_EQ(m.u.control.arg[1], 240);
  ASSERT_EQ(rl_parse(s["heartbeat"].data(), s["heartbeat"].size(), &m), RL_OK);
  EXPECT_EQ(m.u.heartbeat.rssi, -61);
  EXPECT_EQ(m.u.heartbeat.uptime_ms, 12345u);
  ASSERT_EQ(rl_parse(s["time_resp"].data(), s["time_resp"].size(), &m), RL_OK);
  EXPECT_EQ(m.u.time.t3, 333u);
  ASSERT_EQ(rl_parse(s["nack"].data(), s["nack"].size(), &m), RL_OK);
  EXPECT_EQ(m.u.nack.count, 2);
  EXPECT_EQ(m.u.nack.index[1], 2);
  ASSERT_EQ(rl_parse(s["hello"].data(), s["hello"].size(), &m), RL_OK);
  EXPECT_EQ(m.u.hello.role, RL_ROLE_ROBOT);
  EXPECT_EQ(m.u.hello.nonce_robot[15], 16);
  EXPECT_EQ(m.u.hello.nonce_ground[0], 0);
  EXPECT_EQ(m.tag, nullptr);
  for (auto& [name, bytes] : s) {
    ASSERT_EQ(rl_parse(bytes.data(), bytes.size(), &m), RL_OK) << name;
    // (a tag is not the encoder's: rl_seal appends it)
    EXPECT_EQ(Encode(m), Bytes(bytes.begin(), bytes.end() - (m.tag ? RL_TAG_SIZE : 0)))
        << name << ": parse then encode gives other bytes";
    EXPECT_LE(bytes.size(), RL_MAX_DATAGRAM);
  }
}

TEST(RumiLink, TruncatedAndCorruptedDatagramsAreRejected) {
  rl_message m;
  for (auto& [name, bytes] : Samples()) {
    for (size_t n = 0; n < bytes.size(); ++n)
      EXPECT_NE(rl_parse(bytes.data(), n, &m), RL_OK) << name << " cut to " << n;
    // Every single-bit flip is caught (by the CRC if by nothing else; in
    // the tag, which the CRC does not cover, by the tag's check).
    ASSERT_EQ(rl_parse(bytes.data(), bytes.size(), &m), RL_OK);
    const size_t tagged = m.tag ? bytes.size() - RL_TAG_SIZE : bytes.size();
    uint8_t key[RL_KEY_SIZE];
    std::memset(key, 0x5A, sizeof(key));
    for (size_t i = 0; i < bytes.size(); ++i) {
      for (int b = 0; b < 8; ++b) {
        Bytes x = bytes;
        x[i] ^= static_cast<uint8_t>(1 << b);
        if (i < tagged) {
          ASSERT_NE(rl_parse(x.data(), x.size(), &m), RL_OK) << name << " byte " << i << " bit " << b;
        } else {
          ASSERT_EQ(rl_parse(x.data(), x.size(), &m), RL_OK);
          ASSERT_FALSE(rl_verify(key, x.data(), x.size(), &m)) << name << " tag byte " << i << " bit " << b;
        }
      }
    }
    Bytes longer = bytes;
    longer.push_back(0);
    EXPECT_EQ(rl_parse(longer.data(), longer.size(), &m), RL_ERR_LENGTH) << name;
  }
  EXPECT_EQ(rl_parse(nullptr, 100, &m), RL_ERR_SHORT);
  Bytes junk(64, 0xAB);
  EXPECT_EQ(rl_parse(junk.data(), junk.size(), &m), RL_ERR_MAGIC);
  Bytes v = Samples()["ack"];
  v[2] = 1;  // version 1 (no tag, no HELLO): refused
  EXPECT_EQ(rl_parse(v.data(), v.size(), &m), RL_ERR_VERSION);
  EXPECT_STREQ(rl_error_string(RL_ERR_CRC), "CRC mismatch (corrupted)");
}

TEST(RumiLink, ImpossibleFragmentsAreRejectedEvenWithAGoodCrc) {
  static uint8_t image[3000];
  auto frag = [&](uint16_t index, uint16_t count, uint32_t total, uint32_t offset, uint16_t len) {
    rl_message m = Header(RL_FRAME);
    m.h.frag_index = index;
    m.h.frag_count = count;
    m.u.frame.meta = {total, offset, 320, 240, RL_FORMAT_JPEG, 12};
    m.u.frame.data = image;
    m.u.frame.len = len;
    Bytes b = Encode(m);
    rl_message out;
    return rl_parse(b.data(), b.size(), &out);
  };
  const uint16_t full = RL_FRAGMENT_DATA_MAX;
  EXPECT_EQ(frag(0, 3, 3000, 0, full), RL_OK);
  EXPECT_EQ(frag(3, 3, 3000, 3 * full, 10), RL_ERR_FRAGMENT);        // index >= count
  EXPECT_EQ(frag(0, 0, 3000, 0, full), RL_ERR_FRAGMENT);             // no fragments
  EXPECT_EQ(frag(1, 3, 3000, 7, full), RL_ERR_FRAGMENT);             // offset not at its slot
  EXPECT_EQ(frag(0, 2, 3000, 0, full), RL_ERR_FRAGMENT);             // count disagrees with size
  EXPECT_EQ(frag(0, 3, 3000, 0, 100), RL_ERR_FRAGMENT);              // short middle fragment
  EXPECT_EQ(frag(2, 3, 3000, 2 * full, 10), RL_ERR_FRAGMENT);        // last one too short
  EXPECT_EQ(frag(0, 1, 0, 0, 0), RL_ERR_PAYLOAD);                    // empty image
  EXPECT_EQ(frag(0, 200, 200 * full, 0, full), RL_ERR_FRAGMENT);     // beyond RL_MAX_FRAGMENTS
}

TEST(RumiLink, EncodeRefusesWhatCannotBeSent) {
  rl_message m = Header(RL_IMU);
  m.u.imu.count = RL_IMU_MAX_SAMPLES + 1;
  uint8_t out[RL_MAX_DATAGRAM];
  EXPECT_EQ(rl_encode(&m, out, sizeof(out)), 0u);
  m.u.imu.count = 1;
  EXPECT_EQ(rl_encode(&m, out, RL_HEADER_SIZE + 10), 0u);  // no room
  EXPECT_GT(rl_encode(&m, out, sizeof(out)), 0u);
  m.h.type = 99;
  EXPECT_EQ(rl_encode(&m, out, sizeof(out)), 0u);
}

TEST(RumiLink, RandomBytesNeverParseAsValid) {
  std::mt19937 rng(1);
  rl_message m;
  int accepted = 0;
  for (int i = 0; i < 20000; ++i) {
    Bytes b(rng() % 200);
    for (auto& x : b) x = static_cast<uint8_t>(rng());
    if (b.size() >= 4 && i % 2) {  // half of them with a valid magic/version/type
      b[0] = 0x52, b[1] = 0x4C, b[2] = RL_VERSION, b[3] = static_cast<uint8_t>(1 + rng() % 9);
    }
    accepted += rl_parse(b.data(), b.size(), &m) == RL_OK;
  }
  EXPECT_EQ(accepted, 0);
}

// The committed fuzz corpus holds a valid datagram of every type. With
// RUMI_WRITE_LINK_CORPUS=DIR this test (re)writes the seeds there.
TEST(RumiLink, FuzzCorpusHoldsEveryType) {
  const char* out = std::getenv("RUMI_WRITE_LINK_CORPUS");
  if (out) {
    for (auto& [name, bytes] : Samples()) {
      std::ofstream f(std::string(out) + "/seed_" + name, std::ios::binary);
      f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    }
  }
  std::set<int> types;
  for (auto& e : std::filesystem::directory_iterator(RUMI_SOURCE_DIR "/firmware/protocol/fuzz_corpus")) {
    std::ifstream f(e.path(), std::ios::binary);
    Bytes b((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    rl_message m;
    if (rl_parse(b.data(), b.size(), &m) == RL_OK) types.insert(m.h.type);
  }
  EXPECT_EQ(types.size(), 9u);
}

}  // namespace
