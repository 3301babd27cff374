/* rumi robot link: authentication (docs/robot_link.md, "Security").
 *
 * Each robot has a 32-byte key shared with its ground station (`rumi link
 * keygen`). The two ends agree a session key with a HELLO exchange: the robot
 * sends HELLO(its fresh nonce), the ground station answers HELLO(that nonce,
 * its own fresh nonce), both under the robot's key; the session key is
 * HMAC-SHA256(key, label | robot nonce | ground nonce). Every other datagram
 * carries RL_FLAG_AUTH and a 16-byte tag after its payload: HMAC-SHA256 of the
 * whole datagram before it under the session key, truncated to 128 bits. The
 * tag covers the header, so the sequence number, robot id and type are bound
 * to it; a sliding window over each session's sequence numbers refuses
 * replays. A fresh nonce at each end makes an old session's datagrams useless
 * in a new one.
 *
 * The primitives come from mbedTLS (Debian's libmbedtls-dev on the host,
 * ESP-IDF's bundled mbedTLS on the robot); nothing here is hand-written crypto. */
#ifndef RUMI_LINK_AUTH_H_
#define RUMI_LINK_AUTH_H_

#include <stddef.h>
#include <stdint.h>

#include "rumi_link.h"

#ifdef __cplusplus
extern "C" {
#endif

#define RL_KEY_SIZE 32u
/* Sequence numbers may run ahead of the newest one seen by at most this much
 * (a quarter-hour of a robot's datagrams at 70/s); anything further is
 * refused, so no datagram can push the window out of a peer's reach. */
#define RL_REPLAY_MAX_JUMP 65536u
#define RL_REPLAY_WINDOW 64u

/* tag = HMAC-SHA256(key, data[0..len))[0..16). 0 on success. */
int rl_auth_tag(const uint8_t key[RL_KEY_SIZE], const uint8_t* data, size_t len, uint8_t tag[RL_TAG_SIZE]);

/* Appends the tag to a datagram rl_encode wrote with RL_FLAG_AUTH in its
 * flags. Returns the new length, or 0 when it does not fit in cap or the flag
 * is missing. */
size_t rl_seal(const uint8_t key[RL_KEY_SIZE], uint8_t* dgram, size_t len, size_t cap);

/* Whether a datagram rl_parse accepted (m) carries a tag that key made.
 * Compares in constant time. */
int rl_verify(const uint8_t key[RL_KEY_SIZE], const uint8_t* dgram, size_t len, const rl_message* m);

/* The session key for this pair of nonces. 0 on success. */
int rl_session_key(const uint8_t key[RL_KEY_SIZE], const uint8_t nonce_robot[RL_NONCE_SIZE],
                   const uint8_t nonce_ground[RL_NONCE_SIZE], uint8_t out[RL_KEY_SIZE]);

/* Anti-replay: the newest sequence number accepted and a bitmap of the
 * RL_REPLAY_WINDOW before it. Zero it for a new session. */
typedef struct rl_replay {
  uint32_t top;
  uint64_t seen; /* bit k: top - k was accepted */
  uint8_t started;
} rl_replay;

enum rl_replay_result {
  RL_REPLAY_OK = 0,
  RL_REPLAY_SEEN = 1,    /* already accepted, or older than the window */
  RL_REPLAY_JUMP = 2     /* further ahead than RL_REPLAY_MAX_JUMP */
};

/* Checks seq and, when it is new, marks it accepted. Call only after the
 * datagram's tag verified (a forged one must not move the window). */
int rl_replay_accept(rl_replay* w, uint32_t seq);

/* Hex text of a key (2 * RL_KEY_SIZE characters, no terminator written
 * beyond out[64]) and back; rl_key_from_hex skips surrounding whitespace and
 * returns 0 on success, -1 on anything else. */
void rl_key_to_hex(const uint8_t key[RL_KEY_SIZE], char out[2 * RL_KEY_SIZE + 1]);
int rl_key_from_hex(const char* text, size_t len, uint8_t key[RL_KEY_SIZE]);

#ifdef __cplusplus
}
#endif

#endif /* RUMI_LINK_AUTH_H_ */
