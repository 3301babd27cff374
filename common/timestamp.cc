#include "common/timestamp.h"

#include <algorithm>
#include <cctype>
#include <climits>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>

namespace rumi {

std::string LocalWallClockText() {
  const std::time_t t = std::time(nullptr);
  std::tm local{};
  localtime_r(&t, &local);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%S%z", &local);
  return buf;
}

Timestamp SecondsToNs(double seconds) {
  return static_cast<Timestamp>(std::llround(seconds * 1e9));
}

namespace {

// Parses "[+-]digits[.digits]" (no exponent) to ns, rounding half away from
// zero beyond 9 decimals; false on malformed input or int64 overflow.
bool ParseDecimalSeconds(const std::string& s, Timestamp* ns) {
  if (s.empty()) return false;
  size_t k = 0;
  bool negative = false;
  if (s[k] == '+' || s[k] == '-') negative = s[k++] == '-';
  constexpr int64_t kMaxWhole = INT64_MAX / kNsPerSecond;
  int64_t whole = 0;
  int64_t frac = 0;
  int frac_digits = 0;
  bool any_digit = false;
  bool round_up = false;
  for (; k < s.size() && std::isdigit(static_cast<unsigned char>(s[k])); ++k) {
    whole = whole * 10 + (s[k] - '0');
    if (whole > kMaxWhole) return false;
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
  const int64_t below = frac + (round_up ? 1 : 0);
  if (whole * kNsPerSecond > INT64_MAX - below) return false;
  const int64_t v = whole * kNsPerSecond + below;
  *ns = negative ? -v : v;
  return true;
}

}  // namespace

bool ParseSecondsToNs(const std::string& text, Timestamp* ns) {
  size_t i = 0;
  const size_t n = text.size();
  while (i < n && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
  size_t end = n;
  while (end > i && std::isspace(static_cast<unsigned char>(text[end - 1]))) --end;
  if (i >= end) return false;
  const std::string s = text.substr(i, end - i);
  const size_t e = s.find_first_of("eE");
  if (e == std::string::npos) return ParseDecimalSeconds(s, ns);
  // Exponent notation (numpy savetxt writes it): shift the decimal point in
  // the text so that the result stays exact, then parse as plain decimal.
  const std::string mantissa = s.substr(0, e), exponent = s.substr(e + 1);
  size_t k = 0;
  if (!exponent.empty() && (exponent[0] == '+' || exponent[0] == '-')) ++k;
  if (k == exponent.size()) return false;
  long exp10 = 0;
  for (; k < exponent.size(); ++k) {
    if (!std::isdigit(static_cast<unsigned char>(exponent[k]))) return false;
    exp10 = std::min(exp10 * 10 + (exponent[k] - '0'), 100000L);
  }
  if (exponent[0] == '-') exp10 = -exp10;
  std::string sign, digits;
  long point = -1;  // digits before the decimal point
  for (size_t m = 0; m < mantissa.size(); ++m) {
    const char c = mantissa[m];
    if (m == 0 && (c == '+' || c == '-')) {
      sign = c == '-' ? "-" : "";
    } else if (std::isdigit(static_cast<unsigned char>(c))) {
      digits += c;
    } else if (c == '.' && point < 0) {
      point = static_cast<long>(digits.size());
    } else {
      return false;
    }
  }
  if (digits.empty()) return false;
  if (point < 0) point = static_cast<long>(digits.size());
  point += exp10;
  // Leading zeros never overflow; more than 30 significant digits before the
  // point always does.
  const size_t first_nonzero = digits.find_first_not_of('0');
  if (first_nonzero == std::string::npos) {
    *ns = 0;
    return true;
  }
  if (point - static_cast<long>(first_nonzero) > 30) return false;
  if (point < -30) {  // far below 1 ns
    *ns = 0;
    return true;
  }
  if (point <= 0) {
    digits.insert(0, static_cast<size_t>(-point), '0');
    point = 0;
  } else if (point > static_cast<long>(digits.size())) {
    digits.append(static_cast<size_t>(point) - digits.size(), '0');
  }
  return ParseDecimalSeconds(sign + digits.substr(0, point) + "." + digits.substr(point), ns);
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
    if (v > (INT64_MAX - (c - '0')) / 10) return false;  // 20 digits can overflow
    v = v * 10 + (c - '0');
  }
  *ns = v;
  return true;
}

}  // namespace rumi
