#include "rumi_robot.h"

#include <string.h>

void rr_config_default(rr_config* c) {
  memset(c, 0, sizeof(*c));
  c->robot_id = 1;
  c->heartbeat_ms = 500;
  c->failsafe_ms = 2000;
  c->imu_batch = 10;
  c->imu_batch_ms = 50;
  c->gait = 1;
  c->start_halted = 0;
}

static uint64_t now(rr_robot* r) { return r->hw.now_us(r->hw.ctx); }

static void header(rr_robot* r, rl_message* m, uint8_t type, uint32_t msg_id, uint64_t t_us) {
  memset(&m->h, 0, sizeof(m->h));
  m->h.type = type;
  m->h.robot_id = r->cfg.robot_id;
  m->h.seq = r->seq++;
  m->h.msg_id = msg_id;
  m->h.frag_count = 1;
  m->h.time_us = t_us;
}

/* With a key every datagram is tagged: a HELLO with the robot's key, the
 * rest with the session's (and nothing but HELLOs leaves before there is one). */
static void send_message(rr_robot* r, rl_message* m) {
  size_t n;
  if (r->cfg.has_key) {
    if (m->h.type != RL_HELLO && !r->session) return;
    m->h.flags |= RL_FLAG_AUTH;
  }
  n = rl_encode(m, r->buf, sizeof(r->buf));
  if (n && r->cfg.has_key)
    n = rl_seal(m->h.type == RL_HELLO ? r->cfg.key : r->session_key, r->buf, n, sizeof(r->buf));
  if (n == 0 || r->hw.send(r->hw.ctx, r->buf, n) != 0) r->stats.send_failures++;
}

/* Asks the ground station for a session, with a nonce of this attempt. */
static void send_hello(rr_robot* r, uint64_t t) {
  rl_message m;
  header(r, &m, RL_HELLO, 0, t);
  memset(&m.u.hello, 0, sizeof(m.u.hello));
  m.u.hello.role = RL_ROLE_ROBOT;
  memcpy(m.u.hello.nonce_robot, r->nonce, RL_NONCE_SIZE);
  send_message(r, &m);
  r->last_hello_us = t;
}

/* Ends a session (or starts without one): a new nonce, HELLO at the next poll. */
static void new_session_request(rr_robot* r) {
  r->session = 0;
  memset(r->session_key, 0, sizeof(r->session_key));
  if (!r->hw.random || r->hw.random(r->hw.ctx, r->nonce, RL_NONCE_SIZE) != 0) {
    /* No randomness: no session can be trusted; stay unauthenticated (and
     * therefore deaf) rather than reuse a nonce. */
    memset(r->nonce, 0, sizeof(r->nonce));
    r->stats.send_failures++;
  }
  r->last_hello_us = 0;
}

/* Tells the servos when the walking state changes (and only then). */
static void update_motion(rr_robot* r) {
  int want = !r->halted && !r->failsafe;
  if (want == r->moving) return;
  r->moving = want;
  if (r->hw.set_motion) r->hw.set_motion(r->hw.ctx, want, r->gait);
}

void rr_init(rr_robot* r, const rr_hw* hw, const rr_config* cfg) {
  memset(r, 0, sizeof(*r));
  r->hw = *hw;
  if (cfg) {
    r->cfg = *cfg;
  } else {
    rr_config_default(&r->cfg);
  }
  if (r->cfg.imu_batch == 0 || r->cfg.imu_batch > RL_IMU_MAX_SAMPLES) r->cfg.imu_batch = RL_IMU_MAX_SAMPLES;
  r->gait = r->cfg.gait;
  r->halted = r->cfg.start_halted;
  r->start_us = r->last_heard_us = r->last_heartbeat_us = now(r);
  /* A robot that has not yet heard the ground station stands: nobody watches
   * its camera, and a station that comes up late must not find it walked off
   * (nor count that as a fail-safe stop). The first datagram heard lets it walk. */
  r->failsafe = 1;
  r->moving = -1; /* unknown: the first update tells the servos */
  update_motion(r);
  if (r->cfg.has_key) new_session_request(r);
}

int rr_authenticated(const rr_robot* r) { return r->cfg.has_key && r->session; }

int rr_moving(const rr_robot* r) { return !r->halted && !r->failsafe; }

static void send_fragment(rr_robot* r, const rr_frame_slot* s, uint16_t index, int resend) {
  rl_message m;
  uint16_t count = (uint16_t)((s->len + RL_FRAGMENT_DATA_MAX - 1) / RL_FRAGMENT_DATA_MAX);
  uint32_t off = (uint32_t)index * RL_FRAGMENT_DATA_MAX;
  uint32_t left = s->len - off;
  header(r, &m, RL_FRAME, s->frame_id, s->t_us);
  m.h.flags = resend ? RL_FLAG_RETRANSMIT : 0;
  m.h.frag_index = index;
  m.h.frag_count = count;
  m.u.frame.meta.total_len = s->len;
  m.u.frame.meta.offset = off;
  m.u.frame.meta.width = s->width;
  m.u.frame.meta.height = s->height;
  m.u.frame.meta.format = s->format;
  m.u.frame.meta.quality = s->quality;
  m.u.frame.data = s->data + off;
  m.u.frame.len = (uint16_t)(left < RL_FRAGMENT_DATA_MAX ? left : RL_FRAGMENT_DATA_MAX);
  send_message(r, &m);
  if (resend) {
    r->stats.fragments_resent++;
  } else {
    r->stats.fragments_sent++;
  }
}

int64_t rr_send_frame(rr_robot* r, const uint8_t* data, size_t len, uint16_t width, uint16_t height,
                      uint8_t format, uint8_t quality, uint64_t t_us) {
  rr_frame_slot* s;
  uint16_t count, i;
  if (len == 0 || len > RR_FRAME_CAP || len > RL_MAX_FRAME_BYTES || width == 0 || height == 0) {
    r->stats.frames_skipped++;
    return -1;
  }
  if (r->cfg.has_key && !r->session) {
    r->stats.frames_no_session++;
    return -1;
  }
  s = &r->slot[r->next_slot];
  r->next_slot = (r->next_slot + 1) % RR_KEEP_FRAMES;
  s->frame_id = r->next_frame_id++;
  s->len = (uint32_t)len;
  s->t_us = t_us;
  s->width = width;
  s->height = height;
  s->format = format;
  s->quality = quality;
  s->used = 1;
  memcpy(s->data, data, len);
  count = (uint16_t)((len + RL_FRAGMENT_DATA_MAX - 1) / RL_FRAGMENT_DATA_MAX);
  for (i = 0; i < count; ++i) send_fragment(r, s, i, 0);
  r->stats.frames_sent++;
  return s->frame_id;
}

static void flush_imu(rr_robot* r) {
  rl_message m;
  if (r->imu_count == 0) return;
  header(r, &m, RL_IMU, r->next_imu_batch++, r->imu[0].t_us);
  m.u.imu.count = r->imu_count;
  memcpy(m.u.imu.sample, r->imu, sizeof(r->imu[0]) * r->imu_count);
  send_message(r, &m);
  r->imu_count = 0;
}

void rr_add_imu(rr_robot* r, const rl_imu_sample* s) {
  r->imu[r->imu_count++] = *s;
  r->stats.imu_samples++;
  if (r->imu_count >= r->cfg.imu_batch) flush_imu(r);
}

static void send_heartbeat(rr_robot* r, uint64_t t) {
  rl_message m;
  header(r, &m, RL_HEARTBEAT, 0, t);
  memset(&m.u.heartbeat, 0, sizeof(m.u.heartbeat));
  m.u.heartbeat.role = RL_ROLE_ROBOT;
  m.u.heartbeat.halted = (uint8_t)!rr_moving(r);
  m.u.heartbeat.failsafe = (uint8_t)r->failsafe;
  m.u.heartbeat.frames_sent = r->stats.frames_sent;
  m.u.heartbeat.frames_skipped = r->stats.frames_skipped;
  m.u.heartbeat.fragments_resent = r->stats.fragments_resent;
  m.u.heartbeat.imu_samples = r->stats.imu_samples;
  m.u.heartbeat.uptime_ms = (uint32_t)((t - r->start_us) / 1000u);
  if (r->hw.rssi_dbm) {
    int rssi = r->hw.rssi_dbm(r->hw.ctx);
    m.u.heartbeat.rssi = (int8_t)(rssi < -128 ? -128 : rssi > 127 ? 127 : rssi);
  }
  send_message(r, &m);
  r->last_heartbeat_us = t;
}

static uint8_t apply_control(rr_robot* r, const rl_control* c) {
  int w, h, q, f;
  switch (c->command) {
    case RL_CMD_HALT:
      r->halted = 1;
      return RL_ACK_OK;
    case RL_CMD_RESUME:
      r->halted = 0;
      return RL_ACK_OK;
    case RL_CMD_GAIT:
      if (c->arg[0] < 0 || c->arg[0] > 255) return RL_ACK_BAD_ARGUMENT;
      r->gait = c->arg[0];
      if (r->moving == 1 && r->hw.set_motion) r->hw.set_motion(r->hw.ctx, 1, r->gait);
      return RL_ACK_OK;
    case RL_CMD_FRAME_SIZE:
    case RL_CMD_QUALITY:
    case RL_CMD_FRAME_RATE:
      if (!r->hw.set_camera) return RL_ACK_UNSUPPORTED;
      w = r->width, h = r->height, q = r->quality, f = r->fps_milli;
      if (c->command == RL_CMD_FRAME_SIZE) {
        if (c->arg[0] <= 0 || c->arg[1] <= 0 || c->arg[0] > 4096 || c->arg[1] > 4096) return RL_ACK_BAD_ARGUMENT;
        w = c->arg[0], h = c->arg[1];
      } else if (c->command == RL_CMD_QUALITY) {
        if (c->arg[0] < 1 || c->arg[0] > 63) return RL_ACK_BAD_ARGUMENT;
        q = c->arg[0];
      } else {
        if (c->arg[0] <= 0 || c->arg[0] > 120000) return RL_ACK_BAD_ARGUMENT;
        f = c->arg[0];
      }
      if (r->hw.set_camera(r->hw.ctx, w, h, q, f) != 0) return RL_ACK_BAD_ARGUMENT;
      r->width = w, r->height = h, r->quality = q, r->fps_milli = f;
      return RL_ACK_OK;
    default:
      return RL_ACK_UNSUPPORTED;
  }
}

/* Halt/resume arrive by control and by heartbeat, and datagrams reorder: a
 * heartbeat sent before a halt must not undo it when it arrives after. The
 * ground station's sequence numbers order them (serial arithmetic); after a
 * fail-safe (a restarted ground station starts a new sequence) anything goes. */
static int state_is_newer(rr_robot* r, const rl_message* in) {
  if (r->state_seq_valid && (int32_t)(in->h.seq - r->state_seq) <= 0) return 0;
  r->state_seq = in->h.seq;
  r->state_seq_valid = 1;
  return 1;
}

static void on_control(rr_robot* r, const rl_message* in) {
  rl_message m;
  uint8_t result = RL_ACK_OK;
  /* Control ids increase; a repeat (our ack was lost) is acked again but not
   * applied twice. Id 0 is never sent, so the first control always applies. */
  if (in->h.msg_id != r->last_control_id) {
    if (state_is_newer(r, in)) result = apply_control(r, &in->u.control);
    r->last_control_id = in->h.msg_id;
    r->stats.controls++;
    update_motion(r);
  }
  header(r, &m, RL_ACK, in->h.msg_id, now(r));
  m.u.ack.command = in->u.control.command;
  m.u.ack.result = result;
  m.u.ack.halted = (uint8_t)!rr_moving(r);
  send_message(r, &m);
}

static void on_nack(rr_robot* r, const rl_message* in) {
  unsigned k;
  for (k = 0; k < RR_KEEP_FRAMES; ++k) {
    const rr_frame_slot* s = &r->slot[k];
    uint16_t count, i;
    if (!s->used || s->frame_id != in->h.msg_id) continue;
    count = (uint16_t)((s->len + RL_FRAGMENT_DATA_MAX - 1) / RL_FRAGMENT_DATA_MAX);
    if (in->u.nack.count == 0) {
      for (i = 0; i < count; ++i) send_fragment(r, s, i, 1);
    } else {
      for (i = 0; i < in->u.nack.count; ++i)
        if (in->u.nack.index[i] < count) send_fragment(r, s, in->u.nack.index[i], 1);
    }
    return;
  }
  r->stats.nacks_too_old++;
}

/* A ground station's answer to our HELLO: the session starts. */
static void on_hello(rr_robot* r, const rl_message* in, const uint8_t* data, size_t len) {
  if (in->u.hello.role != RL_ROLE_GROUND || r->session ||
      memcmp(in->u.hello.nonce_robot, r->nonce, RL_NONCE_SIZE) != 0) {
    r->stats.unauthenticated++; /* not for this attempt (an old answer or a replay) */
    return;
  }
  if (!rl_verify(r->cfg.key, data, len, in)) {
    r->stats.auth_failures++;
    return;
  }
  if (rl_session_key(r->cfg.key, r->nonce, in->u.hello.nonce_ground, r->session_key) != 0) {
    r->stats.auth_failures++;
    return;
  }
  r->session = 1;
  memset(&r->replay, 0, sizeof(r->replay));
  r->state_seq_valid = 0;
  r->last_control_id = 0;
  r->stats.sessions++;
}

/* With a key: whether this datagram comes from the session's ground station
 * and is new (its tag verified before its sequence number moves the window). */
static int authentic(rr_robot* r, const rl_message* in, const uint8_t* data, size_t len) {
  if (!in->tag || !r->session) {
    r->stats.unauthenticated++;
    return 0;
  }
  if (!rl_verify(r->session_key, data, len, in)) {
    r->stats.auth_failures++;
    return 0;
  }
  if (rl_replay_accept(&r->replay, in->h.seq) != RL_REPLAY_OK) {
    r->stats.replays++;
    return 0;
  }
  return 1;
}

void rr_on_datagram(rr_robot* r, const uint8_t* data, size_t len) {
  rl_message in;
  uint64_t t2 = now(r);
  if (rl_parse(data, len, &in) != RL_OK || in.h.robot_id != r->cfg.robot_id) {
    r->stats.bad_datagrams++;
    return;
  }
  if (r->cfg.has_key) {
    if (in.h.type == RL_HELLO) {
      if (!in.tag) {
        r->stats.unauthenticated++;
        return;
      }
      on_hello(r, &in, data, len);
      if (!r->session) return;
      /* A verified answer is the ground station heard: fall through to end
       * the fail-safe, and say our state under the new key at once. */
      r->last_heartbeat_us = 0;
    } else if (!authentic(r, &in, data, len)) {
      return;
    }
  }
  r->last_heard_us = t2;
  r->heard = 1;
  /* Heard: the fail-safe ends, but the servos are told only after this
   * message is applied (a halt heard first must not twitch the legs). */
  const int was_failsafe = r->failsafe;
  r->failsafe = 0;
  switch (in.h.type) {
    case RL_CONTROL:
      on_control(r, &in);
      break;
    case RL_NACK:
      on_nack(r, &in);
      break;
    case RL_TIME_REQ: {
      rl_message m;
      header(r, &m, RL_TIME_RESP, in.h.msg_id, 0);
      m.u.time.t1 = in.u.time.t1;
      m.u.time.t2 = t2;
      m.u.time.t3 = m.h.time_us = now(r);
      send_message(r, &m);
      break;
    }
    case RL_HEARTBEAT:
      /* The ground station's heartbeat carries the state it wants, so a robot
       * converges even when every halt/resume and its retries were lost. */
      if (in.u.heartbeat.role == RL_ROLE_GROUND && state_is_newer(r, &in) &&
          (int)in.u.heartbeat.halted != r->halted) {
        r->halted = in.u.heartbeat.halted ? 1 : 0;
        update_motion(r);
      }
      break;
    default:
      break; /* robot-bound types only */
  }
  if (was_failsafe) update_motion(r);
}

void rr_poll(rr_robot* r) {
  uint64_t t = now(r);
  if (!r->failsafe && t - r->last_heard_us >= (uint64_t)r->cfg.failsafe_ms * 1000u) {
    r->failsafe = 1;
    r->state_seq_valid = 0;
    r->last_control_id = 0;
    if (r->moving == 1) r->stats.failsafe_stops++;
    update_motion(r);
    send_heartbeat(r, t); /* say so now, not at the next period */
    /* The ground station may have restarted: it must prove itself anew. */
    if (r->cfg.has_key) new_session_request(r);
  }
  if (r->cfg.has_key && !r->session) {
    if (!r->last_hello_us || t - r->last_hello_us >= (uint64_t)r->cfg.heartbeat_ms * 1000u) send_hello(r, t);
  } else if (t - r->last_heartbeat_us >= (uint64_t)r->cfg.heartbeat_ms * 1000u) {
    send_heartbeat(r, t);
  }
  if (r->imu_count && t - r->imu[0].t_us >= (uint64_t)r->cfg.imu_batch_ms * 1000u) flush_imu(r);
}
