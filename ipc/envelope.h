#pragma once
// The envelope shared by every rumi binary format (submaps on the channels and
// in the map file, image windows): a fixed header followed by tagged,
// length-prefixed sections.
//
//   header (40 bytes): "RUMI" | kind (4 chars) | u16 version | u16 header bytes |
//                      u32 section count | u64 total bytes | u64 checksum | u64 reserved
//   section:           u32 tag | u32 flags | u64 payload length | payload, padded to 8
//
// The checksum covers the header fields after the magic (checksum field zero)
// and every section payload except those flagged kSectionUnchecked (raw image
// pixels, so a window is touched once on its way). Readers check the magic,
// kind, version, total size, every section length and the checksum before
// parsing a single field, and every field read is bounds-checked again.
#include <cstdint>
#include <string>
#include <vector>

#include "ipc/byte_io.h"

namespace rumi {

constexpr uint32_t FourCc(const char (&s)[5]) {
  return static_cast<uint32_t>(static_cast<uint8_t>(s[0])) |
         static_cast<uint32_t>(static_cast<uint8_t>(s[1])) << 8 |
         static_cast<uint32_t>(static_cast<uint8_t>(s[2])) << 16 |
         static_cast<uint32_t>(static_cast<uint8_t>(s[3])) << 24;
}

constexpr uint32_t kEnvelopeMagic = FourCc("RUMI");
constexpr size_t kEnvelopeHeaderBytes = 40;
constexpr uint32_t kSectionUnchecked = 1u;

std::string FourCcString(uint32_t v);

struct Section {
  uint32_t tag = 0;
  uint32_t flags = 0;
  const uint8_t* data = nullptr;
  size_t size = 0;
};

// Writes the header with zero sizes/checksum; FinishEnvelope patches them.
template <typename W>
void BeginEnvelope(W& w, uint32_t kind, uint16_t version) {
  w.template Put<uint32_t>(kEnvelopeMagic);
  w.template Put<uint32_t>(kind);
  w.template Put<uint16_t>(version);
  w.template Put<uint16_t>(static_cast<uint16_t>(kEnvelopeHeaderBytes));
  w.template Put<uint32_t>(0);  // section count
  w.template Put<uint64_t>(0);  // total bytes
  w.template Put<uint64_t>(0);  // checksum
  w.template Put<uint64_t>(0);  // reserved
}

// Returns the offset of the length field to pass to EndSection.
template <typename W>
size_t BeginSection(W& w, uint32_t tag, uint32_t flags = 0) {
  w.template Put<uint32_t>(tag);
  w.template Put<uint32_t>(flags);
  return w.Reserve(sizeof(uint64_t));
}

template <typename W>
void EndSection(W& w, size_t length_at) {
  const uint64_t len = w.size() - (length_at + sizeof(uint64_t));
  w.PatchAt(length_at, len);
  w.Align(8);
}

// Fills section count, total size and checksum of an envelope written into
// data[0, n).
void FinishEnvelope(uint8_t* data, size_t n);

// Encoding runs the same body twice (byte_io.h): `body(writer)` writes a
// whole envelope through a SizeCounter, then through a BufferWriter.
template <typename Body>
size_t EnvelopeSize(const Body& body) {
  SizeCounter c;
  body(c);
  return c.size();
}

// Writes the envelope of `body` into out[0, n), n its EnvelopeSize, and
// finishes it.
template <typename Body>
void WriteEnvelope(const Body& body, uint8_t* out, size_t n) {
  BufferWriter w(out, n);
  body(w);
  FinishEnvelope(out, n);
}

// The envelope in a buffer of its own.
template <typename Body>
std::vector<uint8_t> EncodeEnvelope(const Body& body) {
  std::vector<uint8_t> out(EnvelopeSize(body));
  WriteEnvelope(body, out.data(), out.size());
  return out;
}

// The envelope written into out[0, capacity); its size, or 0 when it does not fit.
template <typename Body>
size_t EncodeEnvelopeInto(const Body& body, uint8_t* out, size_t capacity) {
  const size_t n = EnvelopeSize(body);
  if (n > capacity) return 0;
  WriteEnvelope(body, out, n);
  return n;
}

// Validates the envelope and lists its sections. Throws CodecError naming
// `what` and the problem (foreign data, other kind, newer version, truncation,
// checksum mismatch).
std::vector<Section> ParseEnvelope(const uint8_t* data, size_t n, uint32_t kind,
                                   uint16_t max_version, const std::string& what,
                                   uint16_t* version = nullptr);

// The first section with this tag; throws when missing.
const Section& FindSection(const std::vector<Section>& sections, uint32_t tag,
                           const std::string& what);
// nullptr when absent (sections added to a format after version 1).
const Section* FindOptionalSection(const std::vector<Section>& sections, uint32_t tag);

}  // namespace rumi
