#include "ipc/envelope.h"

namespace rumi {
namespace {

constexpr size_t kCountAt = 12, kTotalAt = 16, kChecksumAt = 24;

// Walks sections; returns false with *why on a bad layout.
bool WalkSections(const uint8_t* data, size_t n, std::vector<Section>* out, std::string* why) {
  size_t pos = kEnvelopeHeaderBytes;
  while (pos < n) {
    if (n - pos < 16) {
      *why = "truncated section header at offset " + std::to_string(pos);
      return false;
    }
    Section s;
    std::memcpy(&s.tag, data + pos, 4);
    std::memcpy(&s.flags, data + pos + 4, 4);
    uint64_t len;
    std::memcpy(&len, data + pos + 8, 8);
    pos += 16;
    if (len > n - pos) {
      *why = "section '" + FourCcString(s.tag) + "' claims " + std::to_string(len) +
             " bytes, only " + std::to_string(n - pos) + " left";
      return false;
    }
    s.data = data + pos;
    s.size = len;
    out->push_back(s);
    pos += (len + 7) / 8 * 8;
  }
  return true;
}

uint64_t EnvelopeChecksum(const uint8_t* data, const std::vector<Section>& sections) {
  uint8_t head[kEnvelopeHeaderBytes];
  std::memcpy(head, data, kEnvelopeHeaderBytes);
  std::memset(head + kChecksumAt, 0, 8);
  uint64_t h = Checksum64(head + 4, kEnvelopeHeaderBytes - 4);
  for (const Section& s : sections) {
    uint8_t sh[8];
    std::memcpy(sh, &s.tag, 4);
    std::memcpy(sh + 4, &s.flags, 4);
    h = Checksum64(sh, 8, h);
    if (!(s.flags & kSectionUnchecked)) h = Checksum64(s.data, s.size, h);
    h = Checksum64(reinterpret_cast<const uint8_t*>(&s.size), 8, h);
  }
  return h;
}

}  // namespace

std::string FourCcString(uint32_t v) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((v >> (8 * i)) & 0xff);
    if (c >= 32 && c < 127) {
      s += c;
    } else {
      static const char* kHex = "0123456789abcdef";
      s += "\\x";
      s += kHex[(c >> 4) & 0xf];
      s += kHex[c & 0xf];
    }
  }
  return s;
}

void FinishEnvelope(uint8_t* data, size_t n) {
  std::vector<Section> sections;
  std::string why;
  if (!WalkSections(data, n, &sections, &why)) throw CodecError("FinishEnvelope: " + why);
  const uint32_t count = static_cast<uint32_t>(sections.size());
  const uint64_t total = n;
  std::memcpy(data + kCountAt, &count, 4);
  std::memcpy(data + kTotalAt, &total, 8);
  const uint64_t sum = EnvelopeChecksum(data, sections);
  std::memcpy(data + kChecksumAt, &sum, 8);
}

std::vector<Section> ParseEnvelope(const uint8_t* data, size_t n, uint32_t kind,
                                   uint16_t max_version, const std::string& what,
                                   uint16_t* version_out) {
  if (data == nullptr || n < kEnvelopeHeaderBytes) {
    throw CodecError(what + ": truncated (" + std::to_string(n) + " bytes, header needs " +
                     std::to_string(kEnvelopeHeaderBytes) + ")");
  }
  uint32_t magic, got_kind, count;
  uint16_t version, header_bytes;
  uint64_t total, sum;
  std::memcpy(&magic, data, 4);
  std::memcpy(&got_kind, data + 4, 4);
  std::memcpy(&version, data + 8, 2);
  std::memcpy(&header_bytes, data + 10, 2);
  std::memcpy(&count, data + kCountAt, 4);
  std::memcpy(&total, data + kTotalAt, 8);
  std::memcpy(&sum, data + kChecksumAt, 8);
  if (magic != kEnvelopeMagic) {
    throw CodecError(what + ": not rumi data (magic '" + FourCcString(magic) + "', expected 'RUMI')");
  }
  if (got_kind != kind) {
    throw CodecError(what + ": holds a '" + FourCcString(got_kind) + "' record, expected '" +
                     FourCcString(kind) + "'");
  }
  if (version == 0 || version > max_version) {
    throw CodecError(what + ": format version " + std::to_string(version) +
                     ", this build reads versions 1.." + std::to_string(max_version));
  }
  if (header_bytes != kEnvelopeHeaderBytes) {
    throw CodecError(what + ": header of " + std::to_string(header_bytes) + " bytes, expected " +
                     std::to_string(kEnvelopeHeaderBytes));
  }
  if (total != n) {
    throw CodecError(what + ": " + (total > n ? "truncated" : "trailing bytes") + " (header says " +
                     std::to_string(total) + " bytes, got " + std::to_string(n) + ")");
  }
  std::vector<Section> sections;
  std::string why;
  if (!WalkSections(data, n, &sections, &why)) throw CodecError(what + ": " + why);
  if (sections.size() != count) {
    throw CodecError(what + ": " + std::to_string(sections.size()) + " sections, header says " +
                     std::to_string(count));
  }
  if (EnvelopeChecksum(data, sections) != sum) throw CodecError(what + ": checksum mismatch (corrupt data)");
  if (version_out) *version_out = version;
  return sections;
}

const Section& FindSection(const std::vector<Section>& sections, uint32_t tag, const std::string& what) {
  for (const Section& s : sections) {
    if (s.tag == tag) return s;
  }
  throw CodecError(what + ": section '" + FourCcString(tag) + "' missing");
}

const Section* FindOptionalSection(const std::vector<Section>& sections, uint32_t tag) {
  for (const Section& s : sections) {
    if (s.tag == tag) return &s;
  }
  return nullptr;
}

}  // namespace rumi
