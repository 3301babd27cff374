#pragma once
// The paper's Table IV layout for `rumi eval table`: per sequence, tracking
// rate, RMSE and saved frames for rumi with post-culling (PO), rumi without,
// and the front alone; mean ± std over runs; RMSE shown as "-" when the mean
// rate is below 90 % (a statistic over a small part of a sequence misleads).
#include <optional>
#include <string>
#include <vector>

namespace rumi {

// One run's metrics.json (see docs/eval.md for every key).
struct RunMetrics {
  std::string sequence;
  double front_rate = 0, merged_rate = 0, po_rate = 0;  // by time, in [0, 1]
  std::optional<double> front_rmse, merged_rmse, po_rmse;
  double front_frames = 0, merged_frames = 0, po_frames = 0;  // saved frames
  std::vector<std::string> warnings;  // metrics.json "warnings" (absent in old files)
  // The merge audit: merges accepted, attempts rejected after a Sim(3), and
  // accepted merges that made the map worse (absent without an audit).
  double merges = 0;
  std::optional<int> merges_rejected, merges_harmful;
  // Per loss, seconds from the loss to its merge (null: never merged);
  // absent when the run has no loss-to-merge times.
  std::optional<std::vector<std::optional<double>>> loss_to_merge_s;
};

// Parses metrics.json text; throws std::runtime_error naming `source` and the
// missing or mistyped key. Post-culled figures fall back to the merged ones
// when the run has no separate post-culled entries.
RunMetrics ParseRunMetrics(const std::string& json_text, const std::string& source);

struct TableRow {
  std::string sequence;
  std::vector<RunMetrics> runs;
};

struct EvalTableOptions {
  double min_rate_for_rmse = 0.9;
  bool Check(std::string* why = nullptr) const;
};

// The table (then: merges accepted / rejected / harmful, summed over the
// runs, "-" without an audit; loss to merge p50 / p95 / max in seconds over
// the losses of all runs, with how many of them merged), then one line per
// run that has warnings.
std::string FormatEvalTableMarkdown(const std::vector<TableRow>& rows,
                                    const EvalTableOptions& options = {});
std::string FormatEvalTableCsv(const std::vector<TableRow>& rows,
                               const EvalTableOptions& options = {});

}  // namespace rumi
