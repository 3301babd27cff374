#include "common/timestamp.h"

#include <cctype>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace rumi {

Timestamp SecondsToNs(double seconds) {
  return static_cast<Timestamp>(std::llround(seconds * 1e9));
}

bool ParseSecondsToNs(const std::string& text, Timestamp* ns) {
  size_t i = 0;
  const size_t n = text.size();
  while (i < n && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
  size_t end = n;
  while (end > i && std::isspace(static_cast<unsigned char>(text[end - 1]))) --end;
  if (i >= end) return false;
  const std::string s = text.substr(i, end - i);
  // Exponent notation: fall back to double (rare in trajectory files).
  if (s.find_first_of("eE") != std::string::npos) {
    char* stop = nullptr;
    const double v = std::strtod(s.c_str(), &stop);
    if (stop != s.c_str() + s.size() || !std::isfinite(v)) return false;
    *ns = SecondsToNs(v);
    return true;
  }
  size_t k = 0;
  bool negative = false;
  if (s[k] == '+' || s[k] == '-') negative = s[k++] == '-';
  int64_t whole = 0;
  int64_t frac = 0;
  int frac_digits = 0;
  bool any_digit = false;
  bool round_up = false;
  for (; k < s.size() && std::isdigit(static_cast<unsigned char>(s[k])); ++k) {
    if (whole > (INT64_MAX / 10 - 10) / kNsPerSecond) return false;
    whole = whole * 10 + (s[k] - '0');
    any_digit = true;
  }
  if (k < s.size() && s[k] == '.') {
    ++k;
    for (; k < s.size() && std::isdigit(static_cast<unsigned char>(s[k])); ++k) {
      any_digit = true;
      if (frac_digits < 9) {
        frac = frac * 10 + (s[k] - '0');
        ++frac_digits;
      } else if (frac_digits == 9) {
        round_up = s[k] >= '5';
        ++frac_digits;
      }
    }
  }
  if (!any_digit || k != s.size()) return false;
  for (int d = std::min(frac_digits, 9); d < 9; ++d) frac *= 10;
  int64_t v = whole * kNsPerSecond + frac + (round_up ? 1 : 0);
  *ns = negative ? -v : v;
  return true;
}

std::string FormatSeconds(Timestamp ns) {
  const bool negative = ns < 0;
  const uint64_t a = negative ? static_cast<uint64_t>(-(ns + 1)) + 1 : static_cast<uint64_t>(ns);
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%s%" PRIu64 ".%09" PRIu64, negative ? "-" : "",
                a / kNsPerSecond, a % kNsPerSecond);
  return buf;
}

std::string TimestampFileStem(Timestamp ns) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%020" PRId64, ns);
  return buf;
}

bool ParseTimestampFileStem(const std::string& stem, Timestamp* ns) {
  if (stem.empty() || stem.size() > 20) return false;
  int64_t v = 0;
  for (char c : stem) {
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
    v = v * 10 + (c - '0');
  }
  *ns = v;
  return true;
}

}  // namespace rumi
