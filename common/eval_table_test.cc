#include "common/eval_table.h"

#include <gtest/gtest.h>

#include <sstream>

namespace rumi {
namespace {

std::string Metrics(double front_rate, const char* front_rmse, double merged_rate, const char* merged_rmse,
                    int saved, int saved_po) {
  return std::string("{\"sequence\":\"seq\",\"front_tracking_rate_time\":") + std::to_string(front_rate) +
         ",\"front_ate_rmse\":" + front_rmse + ",\"merged_tracking_rate_time\":" + std::to_string(merged_rate) +
         ",\"merged_ate_rmse\":" + merged_rmse + ",\"front_saved_frames\":40,\"saved_frames\":" +
         std::to_string(saved) + ",\"saved_frames_postculled\":" + std::to_string(saved_po) + "}";
}

TEST(EvalTable, ParsesKeysAndNullRmse) {
  const RunMetrics m = ParseRunMetrics(Metrics(0.31, "null", 0.97, "0.012", 300, 100), "m.json");
  EXPECT_EQ(m.sequence, "seq");
  EXPECT_DOUBLE_EQ(m.front_rate, 0.31);
  EXPECT_FALSE(m.front_rmse.has_value());
  ASSERT_TRUE(m.merged_rmse.has_value());
  EXPECT_DOUBLE_EQ(*m.merged_rmse, 0.012);
  EXPECT_DOUBLE_EQ(m.merged_frames, 300);
  EXPECT_DOUBLE_EQ(m.po_frames, 100);
  EXPECT_DOUBLE_EQ(m.po_rate, 0.97);  // falls back to merged
}

TEST(EvalTable, ErrorsNameTheKey) {
  try {
    ParseRunMetrics("{\"front_tracking_rate_time\": 1}", "run1/metrics.json");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("run1/metrics.json"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("merged_tracking_rate_time"), std::string::npos);
  }
  EXPECT_THROW(ParseRunMetrics("not json", "x"), std::runtime_error);
  EXPECT_THROW(ParseRunMetrics("{\"front_tracking_rate_time\":\"a\"}", "x"), std::runtime_error);
}

TEST(EvalTable, RmseInParenthesesBelowNinetyPercentAndMeanStd) {
  TableRow row{"drop", {ParseRunMetrics(Metrics(0.30, "0.5", 0.96, "0.010", 300, 100), "a"),
                        ParseRunMetrics(Metrics(0.32, "0.5", 0.98, "0.014", 310, 110), "b")}};
  const std::string md = FormatEvalTableMarkdown({row});
  // Merged: 97.0 ± 1.4 rate, RMSE 0.012 ± 0.003; front rate 31 % -> its RMSE
  // in parentheses, and a note says why.
  EXPECT_NE(md.find("| drop | 97.0 ± 1.4 | 0.012 ± 0.003 | 105 ± 7 | 97.0 ± 1.4 | 0.012 ± 0.003 | 305 ± 7 |"
                    " 31.0 ± 1.4 | (0.500 ± 0.000) | 40 ± 0 |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("RMSE in parentheses: over less than 90 % of the sequence's time"), std::string::npos) << md;
  TableRow full{"full", {ParseRunMetrics(Metrics(0.95, "0.5", 0.96, "0.010", 300, 100), "c")}};
  EXPECT_EQ(FormatEvalTableMarkdown({full}).find("parentheses"), std::string::npos);
  const std::string csv = FormatEvalTableCsv({row});
  EXPECT_NE(csv.find("drop,2,"), std::string::npos) << csv;
}

TEST(EvalTable, MissingRmseInAnyRunHidesIt) {
  TableRow row{"s", {ParseRunMetrics(Metrics(0.95, "null", 0.99, "null", 1, 1), "a")}};
  const std::string md = FormatEvalTableMarkdown({row});
  EXPECT_NE(md.find("| s | 99.0 | - | 1 | 99.0 | - | 1 | 95.0 | - | 40 |"), std::string::npos) << md;
}

TEST(EvalTable, MergeAuditColumnSumsRunsAndShowsDashWithoutAudit) {
  auto with_audit = [](int merges, int rejected, int harmful) {
    std::string m = Metrics(0.5, "0.01", 1.0, "0.01", 10, 5);
    m.pop_back();
    return m + ",\"merges\":" + std::to_string(merges) + ",\"merges_rejected\":" + std::to_string(rejected) +
           ",\"merges_harmful\":" + std::to_string(harmful) + "}";
  };
  const RunMetrics a = ParseRunMetrics(with_audit(2, 1, 0), "a");
  ASSERT_TRUE(a.merges_harmful.has_value());
  EXPECT_EQ(*a.merges_rejected, 1);
  TableRow row{"blur", {a, ParseRunMetrics(with_audit(3, 0, 1), "b")}};
  EXPECT_NE(FormatEvalTableMarkdown({row}).find("| 5 / 1 / 1 | - |\n"), std::string::npos) << FormatEvalTableMarkdown({row});
  EXPECT_NE(FormatEvalTableCsv({row}).find(",\"5 / 1 / 1\",\"-\"\n"), std::string::npos);
  // One run without an audit (an older metrics.json): no sum that hides it.
  row.runs.push_back(ParseRunMetrics(Metrics(0.5, "0.01", 1.0, "0.01", 10, 5), "c"));
  EXPECT_NE(FormatEvalTableMarkdown({row}).find("| - | - |\n"), std::string::npos);
}

TEST(EvalTable, LossToMergeColumnPoolsTheLossesOfAllRuns) {
  auto with_losses = [](const std::string& seconds) {
    std::string m = Metrics(0.5, "0.01", 1.0, "0.01", 10, 5);
    m.pop_back();
    std::string a = "[";
    std::stringstream in(seconds);
    for (std::string s; in >> s;) a += (a.size() > 1 ? "," : "") + std::string("{\"seconds\":") + s + "}";
    return m + ",\"loss_to_merge\":" + a + "]}";
  };
  // 1, 2, 3, 4, 100 merged, one never: median 3, nearest-rank p95 100, max 100.
  TableRow row{"drop", {ParseRunMetrics(with_losses("4 null 1"), "a"), ParseRunMetrics(with_losses("2 100 3"), "b")}};
  ASSERT_TRUE(row.runs[0].loss_to_merge_s.has_value());
  EXPECT_FALSE((*row.runs[0].loss_to_merge_s)[1].has_value());
  EXPECT_NE(FormatEvalTableMarkdown({row}).find("| 3 / 100 / 100 (5 of 6) |\n"), std::string::npos)
      << FormatEvalTableMarkdown({row});
  EXPECT_NE(FormatEvalTableMarkdown({{"s", {ParseRunMetrics(with_losses(""), "c")}}}).find("| no loss |\n"),
            std::string::npos);
  EXPECT_NE(FormatEvalTableMarkdown({{"s", {ParseRunMetrics(with_losses("null"), "d")}}}).find("| - (0 of 1) |\n"),
            std::string::npos);
  EXPECT_THROW(ParseRunMetrics(with_losses("\"x\""), "e"), std::runtime_error);
}

}  // namespace
}  // namespace rumi
