#include "rumi_link_auth.h"

#include <string.h>

#include <mbedtls/md.h>

static const char kSessionLabel[] = "rumi link v2 session";

static int hmac(const uint8_t key[RL_KEY_SIZE], const uint8_t* a, size_t alen, const uint8_t* b, size_t blen,
                const uint8_t* c, size_t clen, uint8_t out[32]) {
  const mbedtls_md_info_t* info = mbedtls_md_info_from_type(MBEDTLS_MD_SHA256);
  mbedtls_md_context_t ctx;
  int rc;
  if (!info) return -1;
  mbedtls_md_init(&ctx);
  rc = mbedtls_md_setup(&ctx, info, 1);
  if (rc == 0) rc = mbedtls_md_hmac_starts(&ctx, key, RL_KEY_SIZE);
  if (rc == 0 && alen) rc = mbedtls_md_hmac_update(&ctx, a, alen);
  if (rc == 0 && blen) rc = mbedtls_md_hmac_update(&ctx, b, blen);
  if (rc == 0 && clen) rc = mbedtls_md_hmac_update(&ctx, c, clen);
  if (rc == 0) rc = mbedtls_md_hmac_finish(&ctx, out);
  mbedtls_md_free(&ctx);
  return rc == 0 ? 0 : -1;
}

int rl_auth_tag(const uint8_t key[RL_KEY_SIZE], const uint8_t* data, size_t len, uint8_t tag[RL_TAG_SIZE]) {
  uint8_t full[32];
  if (hmac(key, data, len, NULL, 0, NULL, 0, full) != 0) return -1;
  memcpy(tag, full, RL_TAG_SIZE);
  return 0;
}

size_t rl_seal(const uint8_t key[RL_KEY_SIZE], uint8_t* dgram, size_t len, size_t cap) {
  if (len < RL_HEADER_SIZE || len + RL_TAG_SIZE > cap || len + RL_TAG_SIZE > RL_MAX_DATAGRAM) return 0;
  if (!(dgram[4] & RL_FLAG_AUTH)) return 0;
  if (rl_auth_tag(key, dgram, len, dgram + len) != 0) return 0;
  return len + RL_TAG_SIZE;
}

int rl_verify(const uint8_t key[RL_KEY_SIZE], const uint8_t* dgram, size_t len, const rl_message* m) {
  uint8_t want[RL_TAG_SIZE];
  uint8_t diff = 0;
  size_t i;
  if (!m || !m->tag || len < RL_HEADER_SIZE + RL_TAG_SIZE || m->tag != dgram + len - RL_TAG_SIZE) return 0;
  if (rl_auth_tag(key, dgram, len - RL_TAG_SIZE, want) != 0) return 0;
  for (i = 0; i < RL_TAG_SIZE; ++i) diff |= (uint8_t)(want[i] ^ m->tag[i]);
  return diff == 0;
}

int rl_session_key(const uint8_t key[RL_KEY_SIZE], const uint8_t nonce_robot[RL_NONCE_SIZE],
                   const uint8_t nonce_ground[RL_NONCE_SIZE], uint8_t out[RL_KEY_SIZE]) {
  return hmac(key, (const uint8_t*)kSessionLabel, sizeof(kSessionLabel) - 1, nonce_robot, RL_NONCE_SIZE,
              nonce_ground, RL_NONCE_SIZE, out);
}

int rl_replay_accept(rl_replay* w, uint32_t seq) {
  uint32_t ahead;
  if (!w->started) {
    w->started = 1;
    w->top = seq;
    w->seen = 1;
    return RL_REPLAY_OK;
  }
  ahead = seq - w->top; /* serial arithmetic: wraps at 2^32 */
  if (ahead != 0 && ahead <= RL_REPLAY_MAX_JUMP) {
    w->seen = ahead >= RL_REPLAY_WINDOW ? 1u : (w->seen << ahead) | 1u;
    w->top = seq;
    return RL_REPLAY_OK;
  }
  {
    const uint32_t behind = w->top - seq;
    if (behind < RL_REPLAY_WINDOW) {
      const uint64_t bit = (uint64_t)1 << behind;
      if (w->seen & bit) return RL_REPLAY_SEEN;
      w->seen |= bit;
      return RL_REPLAY_OK;
    }
    /* Far behind is old (or a replay); far ahead is a jump. Which of the two
     * a 2^31 distance is does not matter: both are refused. */
    return behind <= 0x80000000u ? RL_REPLAY_SEEN : RL_REPLAY_JUMP;
  }
}

void rl_key_to_hex(const uint8_t key[RL_KEY_SIZE], char out[2 * RL_KEY_SIZE + 1]) {
  static const char digits[] = "0123456789abcdef";
  size_t i;
  for (i = 0; i < RL_KEY_SIZE; ++i) {
    out[2 * i] = digits[key[i] >> 4];
    out[2 * i + 1] = digits[key[i] & 15];
  }
  out[2 * RL_KEY_SIZE] = 0;
}

static int nibble(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

static int space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

int rl_key_from_hex(const char* text, size_t len, uint8_t key[RL_KEY_SIZE]) {
  size_t b = 0, e = len, i;
  while (b < e && space(text[b])) ++b;
  while (e > b && space(text[e - 1])) --e;
  if (e - b != 2 * RL_KEY_SIZE) return -1;
  for (i = 0; i < RL_KEY_SIZE; ++i) {
    const int hi = nibble(text[b + 2 * i]), lo = nibble(text[b + 2 * i + 1]);
    if (hi < 0 || lo < 0) return -1;
    key[i] = (uint8_t)(hi << 4 | lo);
  }
  return 0;
}
