#pragma once
// A progress line with ETA for long runs (`rumi eval run`). On a terminal it
// is one line rewritten in place with '\r'; into a file or pipe it prints a
// plain line whenever another `percent_step` % is done or `min_interval_s`
// passed, so logs stay readable (no ANSI codes, no carriage returns).
#include <chrono>
#include <ostream>
#include <string>

namespace rumi {

struct ProgressOptions {
  double percent_step = 10.0;    // non-TTY: a line per this many percent
  double min_interval_s = 5.0;   // non-TTY: and at least every this many seconds
  double tty_interval_s = 0.2;   // TTY: redraw at most this often
  bool Check(std::string* why = nullptr) const;
};

// "42s", "3:07", "1:02:03"; "?" for negative or non-finite input.
std::string FormatDuration(double seconds);
// "label  42.0 %  elapsed 0:12  ETA 0:17  detail"; ETA "?" until fraction > 0;
// a NaN fraction (the share done is not known): "? %" and ETA "?".
std::string FormatProgress(const std::string& label, double fraction, double elapsed_s,
                           const std::string& detail);

class ProgressLine {
 public:
  // `tty`: whether `out` is a terminal (see IsTerminal).
  ProgressLine(std::ostream& out, bool tty, std::string label, ProgressOptions options = {});
  // fraction in [0, 1] (clamped); elapsed time measured from construction.
  void Update(double fraction, const std::string& detail = "");
  // Same with an explicit elapsed time (tests, replays).
  void UpdateAt(double fraction, double elapsed_s, const std::string& detail = "");
  // Prints the final state once (ends the TTY line with '\n').
  void Finish(const std::string& detail = "");
  void FinishAt(double elapsed_s, const std::string& detail = "");
  int lines_printed() const { return lines_printed_; }

  static bool IsTerminal(int fd);

 private:
  void Print(const std::string& text, bool final_line);

  std::ostream& out_;
  bool tty_;
  std::string label_;
  ProgressOptions options_;
  std::chrono::steady_clock::time_point start_;
  double fraction_ = 0;
  double last_print_s_ = -1e300;
  double next_percent_ = 0;
  size_t last_width_ = 0;
  int lines_printed_ = 0;
  bool finished_ = false;
};

}  // namespace rumi
