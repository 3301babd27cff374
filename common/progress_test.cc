#include "common/progress.h"

#include <gtest/gtest.h>

#include <cmath>

#include <sstream>

namespace rumi {
namespace {

int CountLines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

TEST(Progress, FormatDuration) {
  EXPECT_EQ(FormatDuration(0), "0s");
  EXPECT_EQ(FormatDuration(42.4), "42s");
  EXPECT_EQ(FormatDuration(187), "3:07");
  EXPECT_EQ(FormatDuration(3723), "1:02:03");
  EXPECT_EQ(FormatDuration(-1), "?");
}

TEST(Progress, EtaFromElapsedAndFraction) {
  // 25 % after 10 s -> 30 s left.
  const std::string s = FormatProgress("run 1/3", 0.25, 10, "frame 100/400");
  EXPECT_NE(s.find("run 1/3"), std::string::npos) << s;
  EXPECT_NE(s.find("25.0 %"), std::string::npos) << s;
  EXPECT_NE(s.find("elapsed 10s"), std::string::npos) << s;
  EXPECT_NE(s.find("ETA 30s"), std::string::npos) << s;
  EXPECT_NE(s.find("frame 100/400"), std::string::npos) << s;
  EXPECT_NE(FormatProgress("", 0.0, 5, "").find("ETA ?"), std::string::npos);
  EXPECT_NE(FormatProgress("", 1.0, 5, "").find("ETA 0s"), std::string::npos);
  // Unknown share (the back works after the front ended): no "99 % ETA 0s" for minutes.
  const std::string unknown = FormatProgress("", std::nan(""), 300, "back: window 1 of 2, exhaustive_matcher, 280 s");
  EXPECT_NE(unknown.find("? %"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("ETA ?"), std::string::npos) << unknown;
}

TEST(Progress, NonTtyPrintsPlainLinesPerStep) {
  std::ostringstream out;
  ProgressOptions o;
  o.percent_step = 25;
  o.min_interval_s = 1000;
  ProgressLine p(out, /*tty=*/false, "x", o);
  // 100 updates at 1 % each, 0.1 s apart: the first one, then a line at 25,
  // 50, 75, 100 %.
  for (int i = 1; i <= 100; ++i) p.UpdateAt(i / 100.0, 0.1 * i);
  EXPECT_EQ(p.lines_printed(), 5);
  p.FinishAt(10.0, "ok");
  const std::string s = out.str();
  EXPECT_EQ(CountLines(s), 6) << s;
  EXPECT_EQ(s.find('\r'), std::string::npos);
  EXPECT_EQ(s.find('\x1b'), std::string::npos);
  EXPECT_NE(s.find(" 25.0 %"), std::string::npos) << s;
  EXPECT_NE(s.find("100.0 %"), std::string::npos) << s;
  EXPECT_NE(s.find("ended after 10s  ok"), std::string::npos) << s;
  p.FinishAt(11.0);  // once only
  EXPECT_EQ(CountLines(out.str()), 6);
}

TEST(Progress, NonTtyPrintsEveryIntervalWhenSlow) {
  std::ostringstream out;
  ProgressOptions o;
  o.percent_step = 50;
  o.min_interval_s = 5;
  ProgressLine p(out, false, "", o);
  // 1 % per second for 20 s: first update prints, then every 5 s.
  for (int i = 1; i <= 20; ++i) p.UpdateAt(i / 100.0, i);
  EXPECT_EQ(p.lines_printed(), 4);  // t = 1, 6, 11, 16
}

TEST(Progress, TtyRewritesOneLine) {
  std::ostringstream out;
  ProgressOptions o;
  o.tty_interval_s = 0;
  ProgressLine p(out, /*tty=*/true, "long label here", o);
  p.UpdateAt(0.5, 1, "a much longer detail text");
  p.UpdateAt(0.6, 2);
  p.FinishAt(3);
  const std::string s = out.str();
  EXPECT_EQ(CountLines(s), 1) << s;
  EXPECT_EQ(s.back(), '\n');
  EXPECT_EQ(s.find('\x1b'), std::string::npos);
  // Second redraw is padded to the first's width.
  const size_t r1 = s.find('\r'), r2 = s.find('\r', r1 + 1), r3 = s.find('\r', r2 + 1);
  ASSERT_NE(r3, std::string::npos);
  EXPECT_GE(r3 - r2, r2 - r1);
}

}  // namespace
}  // namespace rumi
