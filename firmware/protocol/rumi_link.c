#include "rumi_link.h"

#include <string.h>

/* ---- little-endian bytes ------------------------------------------------- */
static void put16(uint8_t* p, uint16_t v) {
  p[0] = (uint8_t)v;
  p[1] = (uint8_t)(v >> 8);
}
static void put32(uint8_t* p, uint32_t v) {
  put16(p, (uint16_t)v);
  put16(p + 2, (uint16_t)(v >> 16));
}
static void put64(uint8_t* p, uint64_t v) {
  put32(p, (uint32_t)v);
  put32(p + 4, (uint32_t)(v >> 32));
}
static uint16_t get16(const uint8_t* p) { return (uint16_t)(p[0] | (p[1] << 8)); }
static uint32_t get32(const uint8_t* p) { return (uint32_t)get16(p) | ((uint32_t)get16(p + 2) << 16); }
static uint64_t get64(const uint8_t* p) { return (uint64_t)get32(p) | ((uint64_t)get32(p + 4) << 32); }
/* IEEE 754 single as its bits: both ends are IEEE 754 (Xtensa LX6, x86, ARM). */
static void putf(uint8_t* p, float f) {
  uint32_t v;
  memcpy(&v, &f, 4);
  put32(p, v);
}
static float getf(const uint8_t* p) {
  uint32_t v = get32(p);
  float f;
  memcpy(&f, &v, 4);
  return f;
}

/* ---- CRC-32, a nibble table: 64 bytes of table, fine on the robot -------- */
uint32_t rl_crc32(uint32_t crc, const uint8_t* data, size_t len) {
  static const uint32_t t[16] = {
      0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u,
      0x4DB26158u, 0x5005713Cu, 0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu,
      0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu};
  size_t i;
  crc = ~crc;
  for (i = 0; i < len; ++i) {
    crc = (crc >> 4) ^ t[(crc ^ data[i]) & 0x0Fu];
    crc = (crc >> 4) ^ t[(crc ^ (uint32_t)(data[i] >> 4)) & 0x0Fu];
  }
  return ~crc;
}

/* ---- payload sizes --------------------------------------------------------- */
#define ACK_SIZE 4u
#define CONTROL_SIZE 16u
#define HEARTBEAT_SIZE 24u
#define TIME_REQ_SIZE 8u
#define TIME_RESP_SIZE 24u
#define HELLO_SIZE (4u + 2u * RL_NONCE_SIZE)

static int valid_type(int t) { return t >= RL_FRAME && t <= RL_HELLO; }

int rl_parse(const uint8_t* buf, size_t len, rl_message* m) {
  const uint8_t* p;
  uint16_t n, i;
  if (!buf || !m || len < RL_HEADER_SIZE) return RL_ERR_SHORT;
  if (get16(buf) != RL_MAGIC) return RL_ERR_MAGIC;
  if (buf[2] != RL_VERSION) return RL_ERR_VERSION;
  if (!valid_type(buf[3])) return RL_ERR_TYPE;
  memset(m, 0, sizeof(*m));
  m->h.type = buf[3];
  m->h.flags = buf[4];
  m->h.robot_id = get16(buf + 6);
  m->h.seq = get32(buf + 8);
  m->h.msg_id = get32(buf + 12);
  m->h.frag_index = get16(buf + 16);
  m->h.frag_count = get16(buf + 18);
  m->h.time_us = get64(buf + 20);
  m->h.payload_len = get16(buf + 28);
  {
    const size_t tag = (m->h.flags & RL_FLAG_AUTH) ? RL_TAG_SIZE : 0u;
    if (len > RL_MAX_DATAGRAM || len < RL_HEADER_SIZE + tag ||
        (size_t)m->h.payload_len != len - RL_HEADER_SIZE - tag)
      return RL_ERR_LENGTH;
    if (tag) m->tag = buf + RL_HEADER_SIZE + m->h.payload_len;
  }
  {
    uint32_t crc = rl_crc32(0, buf, 32);
    crc = rl_crc32(crc, buf + RL_HEADER_SIZE, m->h.payload_len);
    if (crc != get32(buf + 32)) return RL_ERR_CRC;
  }
  p = buf + RL_HEADER_SIZE;
  n = m->h.payload_len;
  if (m->h.type != RL_FRAME && (m->h.frag_index != 0 || m->h.frag_count != 1)) return RL_ERR_FRAGMENT;
  switch (m->h.type) {
    case RL_FRAME: {
      rl_frame_meta* f = &m->u.frame.meta;
      if (m->h.frag_count == 0 || m->h.frag_count > RL_MAX_FRAGMENTS || m->h.frag_index >= m->h.frag_count)
        return RL_ERR_FRAGMENT;
      if (n < RL_FRAME_META_SIZE) return RL_ERR_PAYLOAD;
      f->total_len = get32(p);
      f->offset = get32(p + 4);
      f->width = get16(p + 8);
      f->height = get16(p + 10);
      f->format = p[12];
      f->quality = p[13];
      m->u.frame.data = p + RL_FRAME_META_SIZE;
      m->u.frame.len = (uint16_t)(n - RL_FRAME_META_SIZE);
      if (f->format != RL_FORMAT_JPEG && f->format != RL_FORMAT_GREY) return RL_ERR_PAYLOAD;
      if (f->width == 0 || f->height == 0) return RL_ERR_PAYLOAD;
      if (f->total_len == 0 || f->total_len > RL_MAX_FRAME_BYTES) return RL_ERR_PAYLOAD;
      /* Fragments are cut at fixed RL_FRAGMENT_DATA_MAX steps: a receiver can
       * place each one without trusting anything else in the datagram. */
      if (f->offset != (uint32_t)m->h.frag_index * RL_FRAGMENT_DATA_MAX) return RL_ERR_FRAGMENT;
      if ((uint64_t)f->offset + m->u.frame.len > f->total_len) return RL_ERR_FRAGMENT;
      if ((f->total_len + RL_FRAGMENT_DATA_MAX - 1) / RL_FRAGMENT_DATA_MAX != m->h.frag_count) return RL_ERR_FRAGMENT;
      if (m->h.frag_index + 1u < m->h.frag_count ? m->u.frame.len != RL_FRAGMENT_DATA_MAX
                                                  : f->offset + m->u.frame.len != f->total_len)
        return RL_ERR_FRAGMENT;
      return RL_OK;
    }
    case RL_IMU:
      if (n < 4) return RL_ERR_PAYLOAD;
      m->u.imu.count = get16(p);
      if (m->u.imu.count == 0 || m->u.imu.count > RL_IMU_MAX_SAMPLES) return RL_ERR_PAYLOAD;
      if (n != 4u + m->u.imu.count * RL_IMU_SAMPLE_SIZE) return RL_ERR_PAYLOAD;
      for (i = 0; i < m->u.imu.count; ++i) {
        const uint8_t* s = p + 4 + i * RL_IMU_SAMPLE_SIZE;
        rl_imu_sample* o = &m->u.imu.sample[i];
        int k;
        o->t_us = get64(s);
        for (k = 0; k < 3; ++k) {
          o->accel[k] = getf(s + 8 + 4 * k);
          o->gyro[k] = getf(s + 20 + 4 * k);
        }
      }
      return RL_OK;
    case RL_CONTROL:
      if (n != CONTROL_SIZE) return RL_ERR_PAYLOAD;
      m->u.control.command = p[0];
      if (m->u.control.command == 0) return RL_ERR_PAYLOAD; /* unknown ones are acked as unsupported */
      for (i = 0; i < 3; ++i) m->u.control.arg[i] = (int32_t)get32(p + 4 + 4 * i);
      return RL_OK;
    case RL_ACK:
      if (n != ACK_SIZE) return RL_ERR_PAYLOAD;
      m->u.ack.command = p[0];
      m->u.ack.result = p[1];
      m->u.ack.halted = p[2];
      return m->u.ack.result <= RL_ACK_BAD_ARGUMENT ? RL_OK : RL_ERR_PAYLOAD;
    case RL_HEARTBEAT: {
      rl_heartbeat* b = &m->u.heartbeat;
      if (n != HEARTBEAT_SIZE) return RL_ERR_PAYLOAD;
      b->role = p[0];
      b->halted = p[1];
      b->failsafe = p[2];
      b->rssi = (int8_t)p[3];
      b->frames_sent = get32(p + 4);
      b->frames_skipped = get32(p + 8);
      b->fragments_resent = get32(p + 12);
      b->imu_samples = get32(p + 16);
      b->uptime_ms = get32(p + 20);
      return b->role == RL_ROLE_ROBOT || b->role == RL_ROLE_GROUND ? RL_OK : RL_ERR_PAYLOAD;
    }
    case RL_TIME_REQ:
      if (n != TIME_REQ_SIZE) return RL_ERR_PAYLOAD;
      m->u.time.t1 = get64(p);
      return RL_OK;
    case RL_TIME_RESP:
      if (n != TIME_RESP_SIZE) return RL_ERR_PAYLOAD;
      m->u.time.t1 = get64(p);
      m->u.time.t2 = get64(p + 8);
      m->u.time.t3 = get64(p + 16);
      return RL_OK;
    case RL_NACK:
      if (n < 4) return RL_ERR_PAYLOAD;
      m->u.nack.count = get16(p);
      if (m->u.nack.count > RL_NACK_MAX || n != 4u + 2u * m->u.nack.count) return RL_ERR_PAYLOAD;
      for (i = 0; i < m->u.nack.count; ++i) {
        m->u.nack.index[i] = get16(p + 4 + 2 * i);
        if (m->u.nack.index[i] >= RL_MAX_FRAGMENTS) return RL_ERR_PAYLOAD;
      }
      return RL_OK;
    case RL_HELLO:
      if (n != HELLO_SIZE) return RL_ERR_PAYLOAD;
      m->u.hello.role = p[0];
      memcpy(m->u.hello.nonce_robot, p + 4, RL_NONCE_SIZE);
      memcpy(m->u.hello.nonce_ground, p + 4 + RL_NONCE_SIZE, RL_NONCE_SIZE);
      return m->u.hello.role == RL_ROLE_ROBOT || m->u.hello.role == RL_ROLE_GROUND ? RL_OK : RL_ERR_PAYLOAD;
    default:
      return RL_ERR_TYPE;
  }
}

size_t rl_encode(const rl_message* m, uint8_t* out, size_t cap) {
  uint8_t* p;
  size_t n = 0;
  uint16_t i;
  if (!m || !out || cap < RL_HEADER_SIZE || !valid_type(m->h.type)) return 0;
  p = out + RL_HEADER_SIZE;
  switch (m->h.type) {
    case RL_FRAME:
      n = RL_FRAME_META_SIZE + (size_t)m->u.frame.len;
      if (m->u.frame.len > RL_FRAGMENT_DATA_MAX || RL_HEADER_SIZE + n > cap) return 0;
      put32(p, m->u.frame.meta.total_len);
      put32(p + 4, m->u.frame.meta.offset);
      put16(p + 8, m->u.frame.meta.width);
      put16(p + 10, m->u.frame.meta.height);
      p[12] = m->u.frame.meta.format;
      p[13] = m->u.frame.meta.quality;
      put16(p + 14, 0);
      if (m->u.frame.len) memcpy(p + RL_FRAME_META_SIZE, m->u.frame.data, m->u.frame.len);
      break;
    case RL_IMU:
      if (m->u.imu.count > RL_IMU_MAX_SAMPLES) return 0;
      n = 4u + (size_t)m->u.imu.count * RL_IMU_SAMPLE_SIZE;
      if (RL_HEADER_SIZE + n > cap) return 0;
      put16(p, m->u.imu.count);
      put16(p + 2, 0);
      for (i = 0; i < m->u.imu.count; ++i) {
        uint8_t* s = p + 4 + i * RL_IMU_SAMPLE_SIZE;
        const rl_imu_sample* o = &m->u.imu.sample[i];
        int k;
        put64(s, o->t_us);
        for (k = 0; k < 3; ++k) {
          putf(s + 8 + 4 * k, o->accel[k]);
          putf(s + 20 + 4 * k, o->gyro[k]);
        }
      }
      break;
    case RL_CONTROL:
      n = CONTROL_SIZE;
      if (RL_HEADER_SIZE + n > cap) return 0;
      memset(p, 0, n);
      p[0] = m->u.control.command;
      for (i = 0; i < 3; ++i) put32(p + 4 + 4 * i, (uint32_t)m->u.control.arg[i]);
      break;
    case RL_ACK:
      n = ACK_SIZE;
      if (RL_HEADER_SIZE + n > cap) return 0;
      p[0] = m->u.ack.command;
      p[1] = m->u.ack.result;
      p[2] = m->u.ack.halted;
      p[3] = 0;
      break;
    case RL_HEARTBEAT: {
      const rl_heartbeat* b = &m->u.heartbeat;
      n = HEARTBEAT_SIZE;
      if (RL_HEADER_SIZE + n > cap) return 0;
      p[0] = b->role;
      p[1] = b->halted;
      p[2] = b->failsafe;
      p[3] = (uint8_t)b->rssi;
      put32(p + 4, b->frames_sent);
      put32(p + 8, b->frames_skipped);
      put32(p + 12, b->fragments_resent);
      put32(p + 16, b->imu_samples);
      put32(p + 20, b->uptime_ms);
      break;
    }
    case RL_TIME_REQ:
      n = TIME_REQ_SIZE;
      if (RL_HEADER_SIZE + n > cap) return 0;
      put64(p, m->u.time.t1);
      break;
    case RL_TIME_RESP:
      n = TIME_RESP_SIZE;
      if (RL_HEADER_SIZE + n > cap) return 0;
      put64(p, m->u.time.t1);
      put64(p + 8, m->u.time.t2);
      put64(p + 16, m->u.time.t3);
      break;
    case RL_NACK:
      if (m->u.nack.count > RL_NACK_MAX) return 0;
      n = 4u + 2u * m->u.nack.count;
      if (RL_HEADER_SIZE + n > cap) return 0;
      put16(p, m->u.nack.count);
      put16(p + 2, 0);
      for (i = 0; i < m->u.nack.count; ++i) put16(p + 4 + 2 * i, m->u.nack.index[i]);
      break;
    case RL_HELLO:
      n = HELLO_SIZE;
      if (RL_HEADER_SIZE + n > cap) return 0;
      memset(p, 0, 4);
      p[0] = m->u.hello.role;
      memcpy(p + 4, m->u.hello.nonce_robot, RL_NONCE_SIZE);
      memcpy(p + 4 + RL_NONCE_SIZE, m->u.hello.nonce_ground, RL_NONCE_SIZE);
      break;
    default:
      return 0;
  }
  if (RL_HEADER_SIZE + n + ((m->h.flags & RL_FLAG_AUTH) ? RL_TAG_SIZE : 0u) > RL_MAX_DATAGRAM) return 0;
  put16(out, RL_MAGIC);
  out[2] = RL_VERSION;
  out[3] = m->h.type;
  out[4] = m->h.flags;
  out[5] = 0;
  put16(out + 6, m->h.robot_id);
  put32(out + 8, m->h.seq);
  put32(out + 12, m->h.msg_id);
  put16(out + 16, m->h.type == RL_FRAME ? m->h.frag_index : 0);
  put16(out + 18, m->h.type == RL_FRAME ? m->h.frag_count : 1);
  put64(out + 20, m->h.time_us);
  put16(out + 28, (uint16_t)n);
  put16(out + 30, 0);
  {
    uint32_t crc = rl_crc32(0, out, 32);
    crc = rl_crc32(crc, p, n);
    put32(out + 32, crc);
  }
  return RL_HEADER_SIZE + n;
}

const char* rl_error_string(int code) {
  switch (code) {
    case RL_OK: return "ok";
    case RL_ERR_SHORT: return "shorter than a header";
    case RL_ERR_MAGIC: return "bad magic (not a rumi link datagram)";
    case RL_ERR_VERSION: return "unsupported protocol version";
    case RL_ERR_TYPE: return "unknown message type";
    case RL_ERR_LENGTH: return "payload length disagrees with the datagram (truncated?)";
    case RL_ERR_CRC: return "CRC mismatch (corrupted)";
    case RL_ERR_FRAGMENT: return "impossible fragment index/count/offset";
    case RL_ERR_PAYLOAD: return "malformed payload";
    case RL_ERR_SPACE: return "output buffer too small";
    default: return "unknown error";
  }
}

const char* rl_type_name(int type) {
  switch (type) {
    case RL_FRAME: return "frame";
    case RL_IMU: return "imu";
    case RL_CONTROL: return "control";
    case RL_ACK: return "ack";
    case RL_HEARTBEAT: return "heartbeat";
    case RL_TIME_REQ: return "time_req";
    case RL_TIME_RESP: return "time_resp";
    case RL_NACK: return "nack";
    case RL_HELLO: return "hello";
    default: return "?";
  }
}
