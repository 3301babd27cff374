#pragma once
// Reading the plain-text files of datasets and trajectories (TUM, EuRoC,
// KITTI, index and calibration files): one notion of a data line and of a
// field, so every reader skips, splits and rejects alike.
#include <cstdint>
#include <functional>
#include <istream>
#include <string>
#include <utility>
#include <vector>

namespace rumi {

// Without leading and trailing whitespace.
std::string Trim(const std::string& s);

// Calls fn(line number, trimmed text) for every line that is neither blank nor
// a '#' comment, until fn returns false.
void ForEachDataLine(std::istream& in, const std::function<bool(int line, const std::string& text)>& fn);

// The data lines of a text file as (line number, trimmed text); throws when
// it cannot be opened.
std::vector<std::pair<int, std::string>> ReadDataLines(const std::string& file);

// Fields separated by whitespace (and commas with `commas`); empty fields
// are dropped.
std::vector<std::string> SplitFields(const std::string& line, bool commas);

// The whole token as a number: no trailing characters, no overflow, finite.
bool ParseInt64(const std::string& token, int64_t* v);
bool ParseFiniteDouble(const std::string& token, double* v);

}  // namespace rumi
