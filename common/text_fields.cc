#include "common/text_fields.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

namespace rumi {

std::string Trim(const std::string& s) {
  size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

void ForEachDataLine(std::istream& in, const std::function<bool(int line, const std::string& text)>& fn) {
  std::string raw;
  for (int line = 1; std::getline(in, raw); ++line) {
    const std::string s = Trim(raw);
    if (s.empty() || s[0] == '#') continue;
    if (!fn(line, s)) return;
  }
}

std::vector<std::pair<int, std::string>> ReadDataLines(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error("cannot open " + file);
  std::vector<std::pair<int, std::string>> out;
  ForEachDataLine(in, [&](int line, const std::string& text) {
    out.emplace_back(line, text);
    return true;
  });
  return out;
}

std::vector<std::string> SplitFields(const std::string& line, bool commas) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : line) {
    if (std::isspace(static_cast<unsigned char>(c)) || (commas && c == ',')) {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

bool ParseInt64(const std::string& token, int64_t* v) {
  if (token.empty()) return false;
  char* stop = nullptr;
  errno = 0;
  const long long x = std::strtoll(token.c_str(), &stop, 10);
  if (stop != token.c_str() + token.size() || errno == ERANGE) return false;
  *v = static_cast<int64_t>(x);
  return true;
}

bool ParseFiniteDouble(const std::string& token, double* v) {
  if (token.empty()) return false;
  char* stop = nullptr;
  errno = 0;
  *v = std::strtod(token.c_str(), &stop);
  return stop == token.c_str() + token.size() && errno != ERANGE && std::isfinite(*v);
}

}  // namespace rumi
