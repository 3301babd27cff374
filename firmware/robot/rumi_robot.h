/* The robot's side of the link, without hardware: fragmenting frames and
 * keeping the last few for retransmission on NACK, batching IMU samples,
 * obeying halt/resume and the camera settings with acknowledgements,
 * answering clock-sync requests, heartbeats, and the fail-safe (a robot stands
 * until it first hears the ground station, and stops walking when it hears
 * nothing for failsafe_ms).
 *
 * With a key (rr_config.has_key) the robot speaks only authenticated: it
 * sends HELLOs until the ground station answers one, then tags every datagram
 * with the session key and accepts only datagrams tagged with it, each
 * sequence number once (rumi_link_auth.h). A fail-safe ends the session; the
 * next ground station must say HELLO again. Without a key it is the insecure
 * lab link: anything that parses is obeyed.
 *
 * The hardware is behind rr_hw (a datagram sender, a clock, the servos, the
 * camera settings), so the same code runs in the ESP32-CAM firmware
 * (firmware/esp32cam), in the host tests, and in `rumi robot-sim`.
 * No allocation: an rr_robot holds everything (RR_KEEP_FRAMES x RR_FRAME_CAP
 * bytes; the firmware puts it in PSRAM once at boot).
 * Not thread-safe: call it from one task. */
#ifndef RUMI_ROBOT_H_
#define RUMI_ROBOT_H_

#include <stddef.h>
#include <stdint.h>

#include "rumi_link.h"
#include "rumi_link_auth.h"

#ifdef __cplusplus
extern "C" {
#endif

#ifndef RR_KEEP_FRAMES
#define RR_KEEP_FRAMES 16 /* frames kept for NACKs: 530 ms at 30 fps (the firmware: 6 at 10 fps) */
#endif
#ifndef RR_FRAME_CAP
#define RR_FRAME_CAP RL_MAX_FRAME_BYTES /* the firmware sets 64 KiB (QVGA/VGA JPEG) */
#endif

typedef struct rr_hw {
  void* ctx;
  /* One datagram to the ground station; 0 on success (a failure is counted). */
  int (*send)(void* ctx, const uint8_t* data, size_t len);
  /* The robot's clock, microseconds, monotonic. */
  uint64_t (*now_us)(void* ctx);
  /* Walk (moving = 1, with this gait) or stand still (moving = 0). */
  void (*set_motion)(void* ctx, int moving, int gait);
  /* Camera settings; 0 if applied. NULL: camera commands are unsupported. */
  int (*set_camera)(void* ctx, int width, int height, int quality, int fps_milli);
  /* Wi-Fi signal strength, dBm (0: unknown); sent in every heartbeat. NULL: unknown. */
  int (*rssi_dbm)(void* ctx);
  /* n unpredictable bytes (the HELLO nonce); 0 on success. Needed with a key. */
  int (*random)(void* ctx, uint8_t* out, size_t n);
} rr_hw;

typedef struct rr_config {
  uint16_t robot_id;
  uint32_t heartbeat_ms;   /* robot heartbeat period */
  uint32_t failsafe_ms;    /* stop walking after this long without a datagram */
  uint16_t imu_batch;      /* samples per IMU datagram (<= RL_IMU_MAX_SAMPLES) */
  uint32_t imu_batch_ms;   /* or send once the oldest sample is this old */
  int gait;                /* gait at start */
  int start_halted;        /* stand still until the ground station says resume */
  int has_key;             /* 1: authenticated link with key; 0: insecure */
  uint8_t key[RL_KEY_SIZE];
} rr_config;

void rr_config_default(rr_config* c);

typedef struct rr_stats {
  uint32_t frames_sent;
  uint32_t frames_skipped;      /* too large for the protocol */
  uint32_t fragments_sent;
  uint32_t fragments_resent;    /* on NACK */
  uint32_t nacks_too_old;       /* asked for a frame no longer kept */
  uint32_t send_failures;
  uint32_t imu_samples;
  uint32_t controls;            /* applied (duplicates only acked) */
  uint32_t bad_datagrams;       /* failed rl_parse */
  uint32_t failsafe_stops;
  uint32_t unauthenticated;     /* no tag, or no session yet: ignored */
  uint32_t auth_failures;       /* a tag that the key did not make */
  uint32_t replays;             /* a sequence number seen before, or a jump */
  uint32_t sessions;            /* HELLOs answered: sessions started */
  uint32_t frames_no_session;   /* frames not sent: no session yet */
} rr_stats;

typedef struct rr_frame_slot {
  uint32_t frame_id;
  uint32_t len;
  uint64_t t_us;
  uint16_t width, height;
  uint8_t format, quality;
  uint8_t used;
  uint8_t data[RR_FRAME_CAP];
} rr_frame_slot;

typedef struct rr_robot {
  rr_hw hw;
  rr_config cfg;
  rr_stats stats;
  uint32_t seq;
  uint32_t next_frame_id;
  uint32_t next_imu_batch;
  rr_frame_slot slot[RR_KEEP_FRAMES];
  unsigned next_slot;
  rl_imu_sample imu[RL_IMU_MAX_SAMPLES];
  uint16_t imu_count;
  int halted;           /* commanded by the ground station */
  int failsafe;         /* stopped: nothing heard yet, or nothing for failsafe_ms */
  int moving;           /* what the servos were last told */
  int gait;
  int width, height, quality, fps_milli;  /* camera settings (0: unset) */
  uint32_t last_control_id;
  uint32_t state_seq;   /* ground sequence number of the last halt/resume state */
  int state_seq_valid;
  uint64_t start_us, last_heard_us, last_heartbeat_us;
  int heard;            /* anything heard since start */
  int session;          /* with a key: a session key is agreed */
  uint8_t nonce[RL_NONCE_SIZE];
  uint8_t session_key[RL_KEY_SIZE];
  rl_replay replay;     /* the ground station's sequence numbers in this session */
  uint64_t last_hello_us;
  uint8_t buf[RL_MAX_DATAGRAM];
} rr_robot;

void rr_init(rr_robot* r, const rr_hw* hw, const rr_config* cfg);

/* Sends one image (JPEG or grey bytes) captured at t_us (robot clock) as
 * fragments, and keeps it for retransmission. Returns the frame id, or -1 if
 * it is too large (counted in frames_skipped). */
int64_t rr_send_frame(rr_robot* r, const uint8_t* data, size_t len, uint16_t width, uint16_t height,
                      uint8_t format, uint8_t quality, uint64_t t_us);

/* Queues one IMU sample; sends a batch when full. */
void rr_add_imu(rr_robot* r, const rl_imu_sample* s);

/* One datagram from the ground station (anything: garbage is counted). */
void rr_on_datagram(rr_robot* r, const uint8_t* data, size_t len);

/* Timers: heartbeat, IMU batch age, fail-safe. Call every few milliseconds. */
void rr_poll(rr_robot* r);

/* Whether the robot walks: not halted and not in fail-safe. */
/* With a key: whether a session with the ground station is established. */
int rr_authenticated(const rr_robot* r);

int rr_moving(const rr_robot* r);

#ifdef __cplusplus
}
#endif

#endif /* RUMI_ROBOT_H_ */
