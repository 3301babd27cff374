/* libFuzzer target for the link's parser and the robot's datagram handler
 * (whatever reaches the robot or the ground station over Wi-Fi).
 * Checks, beyond "no crash, no sanitizer report":
 *  - a datagram that parses re-encodes to one that parses to the same fields
 *    and re-encodes to the same bytes (encode and parse agree);
 *  - the robot survives it (no out-of-bounds, bounded replies). */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rumi_link.h"
#include "rumi_robot.h"

static uint64_t fake_now(void* ctx) {
  uint64_t* t = (uint64_t*)ctx;
  return *t += 1000;
}
static int fake_send(void* ctx, const uint8_t* d, size_t n) {
  rl_message m;
  (void)ctx;
  /* Everything the robot sends must parse. */
  if (rl_parse(d, n, &m) != RL_OK) abort();
  return 0;
}
static int fake_camera(void* ctx, int w, int h, int q, int f) {
  (void)ctx, (void)w, (void)h, (void)q, (void)f;
  return 0;
}

static int fake_random(void* ctx, uint8_t* out, size_t n) {
  size_t i;
  (void)ctx;
  for (i = 0; i < n; ++i) out[i] = (uint8_t)(i * 13 + 1);
  return 0;
}

static rr_robot robot;       /* large: static, initialised once per input */
static rr_robot keyed_robot; /* the same datagrams to a robot with a key (authentication paths) */

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static uint8_t a[RL_MAX_DATAGRAM], b[RL_MAX_DATAGRAM];
  static rl_message m1, m2;
  uint64_t clock = 0;
  rr_hw hw;
  size_t n1, n2;
  if (rl_parse(data, size, &m1) == RL_OK) {
    /* The tag is rl_seal's, not the encoder's: round-trip the rest. */
    m1.h.flags &= (uint8_t)~RL_FLAG_AUTH;
    n1 = rl_encode(&m1, a, sizeof(a));
    if (n1 == 0) abort();
    if (rl_parse(a, n1, &m2) != RL_OK) abort();
    n2 = rl_encode(&m2, b, sizeof(b));
    if (n2 != n1 || memcmp(a, b, n1) != 0) abort();
    if (m1.h.type != m2.h.type || m1.h.seq != m2.h.seq || m1.h.msg_id != m2.h.msg_id ||
        m1.h.time_us != m2.h.time_us || m1.h.payload_len != m2.h.payload_len)
      abort();
  }
  memset(&hw, 0, sizeof(hw));
  hw.ctx = &clock;
  hw.now_us = fake_now;
  hw.send = fake_send;
  hw.set_camera = fake_camera;
  hw.random = fake_random;
  rr_init(&robot, &hw, NULL);
  {
    rr_config kc;
    rr_config_default(&kc);
    kc.has_key = 1;
    memset(kc.key, 0x5A, sizeof(kc.key));
    rr_init(&keyed_robot, &hw, &kc);
    rr_on_datagram(&keyed_robot, data, size);
    rr_poll(&keyed_robot);
  }
  {
    /* A frame kept for NACKs, so a fuzzed NACK can hit it. */
    static uint8_t img[3000];
    rr_send_frame(&robot, img, sizeof(img), 320, 240, RL_FORMAT_JPEG, 12, 5);
  }
  /* The input as one datagram, then cut into datagrams at its own 2-byte
   * length prefixes (sequences of messages reach deeper states). */
  rr_on_datagram(&robot, data, size);
  {
    size_t off = 0;
    while (off + 2 <= size) {
      size_t n = (size_t)data[off] | ((size_t)data[off + 1] << 8);
      off += 2;
      if (n > size - off) n = size - off;
      rr_on_datagram(&robot, data + off, n);
      rr_poll(&robot);
      off += n;
    }
  }
  return 0;
}
