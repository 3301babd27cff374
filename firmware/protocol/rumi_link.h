/* rumi robot link: the wire protocol between the robot (ESP32-CAM firmware)
 * and the ground station, one definition compiled into both (docs/robot_link.md).
 *
 * Every UDP datagram is a 36-byte header plus a typed payload, all fields
 * little-endian, written byte by byte (no packed structs, so the layout does
 * not depend on the compiler or the CPU):
 *
 *   off size field
 *    0   2   magic 0x4C52 ("RL")
 *    2   1   version (RL_VERSION)
 *    3   1   type (enum rl_type)
 *    4   1   flags (RL_FLAG_*)
 *    5   1   reserved, 0
 *    6   2   robot id
 *    8   4   sequence number of the sender's datagrams
 *   12   4   message id: frame number (FRAME, NACK), control id (CONTROL,
 *            ACK), request id (TIME_*), batch number (IMU)
 *   16   2   fragment index (FRAME), else 0
 *   18   2   fragment count (FRAME), else 1
 *   20   8   sender timestamp, microseconds of the sender's clock (FRAME:
 *            the capture time, the same in every fragment)
 *   28   2   payload length
 *   30   2   reserved, 0
 *   32   4   CRC-32 (IEEE) of bytes 0..31 and the payload
 *
 * With RL_FLAG_AUTH, a 16-byte tag follows the payload (rumi_link_auth.h):
 * the datagram is header + payload + tag. Version 2 added the tag and HELLO;
 * a version 1 datagram is refused (RL_ERR_VERSION).
 *
 * Portable C99, no allocation: the parser only reads the bytes it was given
 * and fills a caller's struct, so garbage of any length is rejected with a
 * code (it is fuzzed: rumi_link_fuzz.c). */
#ifndef RUMI_LINK_H_
#define RUMI_LINK_H_

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define RL_MAGIC 0x4C52u
#define RL_VERSION 2u
#define RL_HEADER_SIZE 36u
/* 1500-byte MTU minus IPv4 (20) and UDP (8) headers: never IP-fragmented. */
#define RL_MAX_DATAGRAM 1472u
#define RL_TAG_SIZE 16u
#define RL_NONCE_SIZE 16u
/* Room for the tag is kept whether or not a datagram carries one, so a frame
 * is cut the same way on an authenticated and an insecure link. */
#define RL_MAX_PAYLOAD (RL_MAX_DATAGRAM - RL_HEADER_SIZE - RL_TAG_SIZE)
#define RL_FRAME_META_SIZE 16u
#define RL_FRAGMENT_DATA_MAX (RL_MAX_PAYLOAD - RL_FRAME_META_SIZE)
#define RL_MAX_FRAGMENTS 96u
#define RL_MAX_FRAME_BYTES (RL_MAX_FRAGMENTS * RL_FRAGMENT_DATA_MAX)
#define RL_IMU_SAMPLE_SIZE 32u
#define RL_IMU_MAX_SAMPLES 40u
#define RL_NACK_MAX 64u

enum rl_type {
  RL_FRAME = 1,      /* robot -> ground: one fragment of an image */
  RL_IMU = 2,        /* robot -> ground: a batch of IMU samples */
  RL_CONTROL = 3,    /* ground -> robot: a command, acknowledged */
  RL_ACK = 4,        /* robot -> ground: a command was received (and applied?) */
  RL_HEARTBEAT = 5,  /* both ways: I am alive, and my state */
  RL_TIME_REQ = 6,   /* ground -> robot: clock sync request (t1) */
  RL_TIME_RESP = 7,  /* robot -> ground: t1 echoed, t2 receive, t3 send */
  RL_NACK = 8,       /* ground -> robot: fragments of a frame that never came */
  RL_HELLO = 9       /* both ways: agree a session key (rumi_link_auth.h) */
};

enum rl_flag {
  RL_FLAG_RETRANSMIT = 1,
  RL_FLAG_AUTH = 2  /* a tag follows the payload */
};

enum rl_format { RL_FORMAT_JPEG = 1, RL_FORMAT_GREY = 2 };

enum rl_command {
  RL_CMD_HALT = 1,        /* stop walking (the map is being merged) */
  RL_CMD_RESUME = 2,      /* walk again */
  RL_CMD_FRAME_SIZE = 3,  /* arg0 width, arg1 height */
  RL_CMD_QUALITY = 4,     /* arg0 JPEG quality 1..63 (OV2640: lower is better) */
  RL_CMD_FRAME_RATE = 5,  /* arg0 frames per 1000 s (10 fps = 10000) */
  RL_CMD_GAIT = 6         /* arg0 gait number */
};

enum rl_ack_result { RL_ACK_OK = 0, RL_ACK_UNSUPPORTED = 1, RL_ACK_BAD_ARGUMENT = 2 };

enum rl_role { RL_ROLE_ROBOT = 1, RL_ROLE_GROUND = 2 };

enum rl_error {
  RL_OK = 0,
  RL_ERR_SHORT = -1,     /* fewer bytes than a header */
  RL_ERR_MAGIC = -2,
  RL_ERR_VERSION = -3,
  RL_ERR_TYPE = -4,
  RL_ERR_LENGTH = -5,    /* payload length disagrees with the datagram */
  RL_ERR_CRC = -6,
  RL_ERR_FRAGMENT = -7,  /* fragment index/count impossible */
  RL_ERR_PAYLOAD = -8,   /* the typed payload is malformed */
  RL_ERR_SPACE = -9      /* encode: the output buffer is too small */
};

typedef struct rl_header {
  uint8_t type;
  uint8_t flags;
  uint16_t robot_id;
  uint32_t seq;
  uint32_t msg_id;
  uint16_t frag_index;
  uint16_t frag_count;
  uint64_t time_us;
  uint16_t payload_len;
} rl_header;

typedef struct rl_frame_meta {
  uint32_t total_len;  /* bytes of the whole image */
  uint32_t offset;     /* of this fragment's data in the image */
  uint16_t width, height;
  uint8_t format;      /* rl_format */
  uint8_t quality;
} rl_frame_meta;

typedef struct rl_imu_sample {
  uint64_t t_us;       /* sender clock */
  float accel[3];      /* m/s^2, sensor frame */
  float gyro[3];       /* rad/s */
} rl_imu_sample;

typedef struct rl_control {
  uint8_t command;     /* rl_command */
  int32_t arg[3];
} rl_control;

typedef struct rl_ack {
  uint8_t command;
  uint8_t result;      /* rl_ack_result */
  uint8_t halted;      /* the robot's state after the command */
} rl_ack;

typedef struct rl_heartbeat {
  uint8_t role;        /* rl_role */
  uint8_t halted;      /* robot: halted; ground: wants the robot halted */
  uint8_t failsafe;    /* robot: halted because it heard nothing */
  int8_t rssi;         /* robot: Wi-Fi RSSI dBm, 0 unknown */
  uint32_t frames_sent;
  uint32_t frames_skipped;     /* robot: too large or camera failures */
  uint32_t fragments_resent;
  uint32_t imu_samples;
  uint32_t uptime_ms;
} rl_heartbeat;

typedef struct rl_time {
  uint64_t t1;         /* ground clock: request sent */
  uint64_t t2;         /* robot clock: request received (RESP only) */
  uint64_t t3;         /* robot clock: response sent (RESP only) */
} rl_time;

typedef struct rl_hello {
  uint8_t role;        /* rl_role of the sender */
  uint8_t nonce_robot[RL_NONCE_SIZE];
  uint8_t nonce_ground[RL_NONCE_SIZE];  /* zero in the robot's HELLO */
} rl_hello;

typedef struct rl_nack {
  uint16_t count;      /* 0: the whole frame (none of it arrived) */
  uint16_t index[RL_NACK_MAX];
} rl_nack;

/* One datagram, parsed. FRAME's data and the tag point into the datagram. */
typedef struct rl_message {
  rl_header h;
  const uint8_t* tag;  /* RL_TAG_SIZE bytes after the payload; NULL without RL_FLAG_AUTH */
  union {
    struct {
      rl_frame_meta meta;
      const uint8_t* data;
      uint16_t len;
    } frame;
    struct {
      uint16_t count;
      rl_imu_sample sample[RL_IMU_MAX_SAMPLES];
    } imu;
    rl_control control;
    rl_ack ack;
    rl_heartbeat heartbeat;
    rl_time time;
    rl_nack nack;
    rl_hello hello;
  } u;
} rl_message;

/* Parses one datagram; RL_OK or an rl_error. Never reads past buf[len-1]. */
int rl_parse(const uint8_t* buf, size_t len, rl_message* out);

/* Writes m (its h.payload_len is ignored and computed) into out; returns the
 * datagram's length, or 0 when cap is too small or m is not encodable. With
 * RL_FLAG_AUTH in m's flags the tag is not written: rl_seal appends it. */
size_t rl_encode(const rl_message* m, uint8_t* out, size_t cap);

const char* rl_error_string(int code);
const char* rl_type_name(int type);

/* CRC-32 (IEEE 802.3, reflected 0xEDB88320), continued from crc (0 to start). */
uint32_t rl_crc32(uint32_t crc, const uint8_t* data, size_t len);

#ifdef __cplusplus
}
#endif

#endif /* RUMI_LINK_H_ */
