#include "common/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace rumi {

bool ProgressOptions::Check(std::string* why) const {
  auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!(percent_step > 0 && percent_step <= 100)) return fail("percent_step must be in (0, 100]");
  if (!(min_interval_s > 0)) return fail("min_interval_s must be > 0");
  if (!(tty_interval_s >= 0)) return fail("tty_interval_s must be >= 0");
  return true;
}

std::string FormatDuration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  const long s = std::lround(seconds);
  char buf[48];
  if (s < 60) {
    std::snprintf(buf, sizeof(buf), "%lds", s);
  } else if (s < 3600) {
    std::snprintf(buf, sizeof(buf), "%ld:%02ld", s / 60, s % 60);
  } else {
    std::snprintf(buf, sizeof(buf), "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  }
  return buf;
}

std::string FormatProgress(const std::string& label, double fraction, double elapsed_s,
                           const std::string& detail) {
  // NaN: the share done is not known (the back working after the front):
  // no percentage, no ETA.
  const bool known = !std::isnan(fraction);
  fraction = std::clamp(std::isfinite(fraction) ? fraction : 0.0, 0.0, 1.0);
  const double eta = known && fraction > 0 ? elapsed_s * (1 - fraction) / fraction : -1;
  char pct[32];
  if (known) std::snprintf(pct, sizeof(pct), "%5.1f %%", 100.0 * fraction);
  else std::snprintf(pct, sizeof(pct), "    ? %%");
  std::string s = label.empty() ? "" : label + "  ";
  s += std::string(pct) + "  elapsed " + FormatDuration(elapsed_s) + "  ETA " + FormatDuration(eta);
  if (!detail.empty()) s += "  " + detail;
  return s;
}

ProgressLine::ProgressLine(std::ostream& out, bool tty, std::string label, ProgressOptions options)
    : out_(out), tty_(tty), label_(std::move(label)), options_(options),
      start_(std::chrono::steady_clock::now()) {
  if (!options_.Check()) options_ = ProgressOptions{};
  next_percent_ = options_.percent_step;
}

bool ProgressLine::IsTerminal(int fd) { return isatty(fd) == 1; }

void ProgressLine::Update(double fraction, const std::string& detail) {
  const double t =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  UpdateAt(fraction, t, detail);
}

void ProgressLine::UpdateAt(double fraction, double elapsed_s, const std::string& detail) {
  if (finished_) return;
  const bool known = !std::isnan(fraction);
  if (known) fraction_ = std::clamp(std::isfinite(fraction) ? fraction : 0.0, 0.0, 1.0);
  const double pct = 100.0 * fraction_;
  bool due;
  if (tty_) {
    due = elapsed_s - last_print_s_ >= options_.tty_interval_s;
  } else {
    due = pct >= next_percent_ || elapsed_s - last_print_s_ >= options_.min_interval_s;
  }
  if (!due) return;
  if (!tty_) {
    // Next line at the next multiple of the step above what is done now.
    while (next_percent_ <= pct) next_percent_ += options_.percent_step;
  }
  last_print_s_ = elapsed_s;
  Print(FormatProgress(label_, known ? fraction_ : fraction, elapsed_s, detail), false);
}

void ProgressLine::Finish(const std::string& detail) {
  FinishAt(std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(),
           detail);
}

void ProgressLine::FinishAt(double elapsed_s, const std::string& detail) {
  if (finished_) return;
  std::string s = (label_.empty() ? "" : label_ + "  ") + "ended after " + FormatDuration(elapsed_s);
  if (!detail.empty()) s += "  " + detail;
  Print(s, true);
  finished_ = true;
}

void ProgressLine::Print(const std::string& text, bool final_line) {
  if (tty_) {
    // Pad with blanks so a shorter line fully covers the previous one.
    std::string line = text;
    if (line.size() < last_width_) line.append(last_width_ - line.size(), ' ');
    last_width_ = text.size();
    out_ << '\r' << line;
    if (final_line) out_ << '\n';
  } else {
    out_ << text << '\n';
  }
  out_.flush();
  ++lines_printed_;
}

}  // namespace rumi
