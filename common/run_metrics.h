#pragma once
// One run's metrics.json for `rumi eval run` (keys in docs/eval.md), computed
// from the files the three processes leave in the run dir. Parsed back by
// common/eval_table (ParseRunMetrics) for `rumi eval table`.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/submap.h"
#include "common/timestamp.h"
#include "common/trajectory.h"
#include "common/trajectory_eval.h"
#include "common/stats.h"  // Median, PercentileNearestRank (for the callers of these metrics)

namespace rumi {

// Figures the processes report about themselves (back_stats.json,
// manager_stats.json, front_stats.json).
struct RunCounts {
  int64_t back_windows = 0;
  double back_seconds = 0;
  int64_t merges = 0;
  int64_t saved_frames = 0;             // frames (keyframes) in the merged map
  int64_t saved_frames_postculled = 0;  // after post-culling
  int64_t submaps_front = 0;
  int64_t submaps_back = 0;
  int64_t front_saved_frames = 0;       // keyframes the front alone kept
  int64_t back_windows_failed = 0;      // built without a usable model (back_stats.json)
};

struct RunMetricsInput {
  std::string sequence;
  std::vector<Timestamp> frames;  // every frame of the sequence, increasing
  Trajectory ground_truth;        // empty: no ground truth
  Trajectory front;               // front's largest submap
  Trajectory merged;              // manager's largest merged map
  std::vector<Trajectory> components;  // every component (merged_<k>.txt); may be empty
  std::vector<double> front_ms;   // per-frame front time; may be empty
  RunCounts counts;
  AteOptions ate;                 // Sim(3), max_diff 0.02 s by default
  TrackingRateOptions rate;
};

struct TrajectoryMetrics {
  double rate_time = 0;    // covered duration / sequence duration
  double rate_frames = 0;  // frames with a pose / all frames
  std::optional<double> ate_rmse;  // null without GT or when ATE is impossible
  size_t ate_pairs = 0;
  std::optional<Sim3> S_gt_est;    // alignment used (for plots)
  std::string ate_note;            // why the RMSE is null, or an unusual alignment
};

// One merge attempt of the manager that reached a Sim(3), judged against the
// ground truth (manager/merge_audit.h computes it): side `a` (the front
// submap; the first one of a place or odometry merge) and side `b` (the back
// submap; the second one), each Sim(3)-aligned to the ground truth on its own,
// then both together under the merge's Sim(3).
struct MergeAuditRow {
  std::string kind;  // merge, place, odometry
  std::string a, b;  // "front#3", "back#1"
  bool accepted = false;
  std::string reason;       // why it was rejected (empty when accepted)
  std::string rejected_by;  // the verification check or "alignment", when one rejected it
  size_t a_frames = 0, b_frames = 0;  // frames with ground truth
  std::optional<double> ate_a, ate_b;  // each side on its own (before)
  std::optional<double> ate_joint;     // both sides, one alignment (after)
  std::optional<double> ate_a_joint;   // side a's frames under that alignment
  bool harmful = false;  // accepting it makes the map worse (merge_audit.h)
  std::string note;      // why the figures are missing, if they are
};

// One loop the manager found (manager/loop_audit.h judges it): its measured
// relation of the two cameras against the ground truth's.
struct LoopAuditRow {
  std::string query, match;  // "front#3"
  int64_t query_keyframe = -1, match_keyframe = -1;
  double query_time_s = 0, match_time_s = 0;
  bool closed = false;
  std::optional<double> rotation_error_deg;   // measured vs true relative rotation
  std::optional<double> direction_error_deg;  // of the translation between the cameras (>= 1/5 of the depth apart)
  bool right = false;    // rotation within 5 deg and direction (when measured) within 20 deg
  bool harmful = false;  // closed and not right
  std::string note;      // why the figures are missing, if they are
};

// One tracking loss and how long its frames took to be part of the map
// (common/loss_to_merge.h computes it).
struct LossToMerge {
  Timestamp first = 0, last = 0;  // the lost stretch: first and last frame the front did not track
  int frames = 0;                 // frames in it (skipped ones included)
  Timestamp lost_wall = 0;        // when the front was done with its first frame (system clock)
  std::optional<double> seconds;  // loss to merge; null: never merged
  int64_t back_submap = -1;       // the back submap whose join merged it
};
// Over the merged losses: median, nearest-rank p95, max.
struct LossToMergeSummary {
  int losses = 0, merged = 0;
  std::optional<double> p50_s, p95_s, max_s;
};

struct RunMetricsReport {
  std::string sequence;
  size_t frames = 0;
  double duration_s = 0;
  TrajectoryMetrics front, merged;
  std::optional<double> front_ms_mean, front_ms_median, front_ms_p95;
  RunCounts counts;
  // The merged trajectory's ATE over the frames of front.txt only (the
  // frames the front tracked): a merge must not make these worse.
  std::optional<double> merged_ate_front_frames;
  // Share of the sequence's frames that some component of the map poses
  // (any merged_<k>.txt, matched like merged_tracking_rate_frames): a
  // rejected merge leaves its submap as a component of its own.
  std::optional<double> components_rate_frames;
  // Every merge attempt that reached a Sim(3) (with ground truth and the
  // raw map; empty otherwise), and the counts of merges rejected (all
  // attempts that got a Sim(3)) and of harmful accepted merges.
  std::vector<MergeAuditRow> merge_audit;
  bool merge_audit_done = false;
  // Every loop of the manager's last rebuild, judged the same way.
  std::vector<LoopAuditRow> loop_audit;
  bool loop_audit_done = false;
  // Every loss after the first tracked frame, with its loss-to-merge time;
  // not computed (null in metrics.json) without the back or the wall times.
  std::optional<std::vector<LossToMerge>> loss_to_merge;
  // What makes the figures suspect (nothing tracked, failed back windows):
  // metrics.json "warnings", printed by `rumi eval run` and `rumi eval table`.
  std::vector<std::string> warnings;
};

// Throws std::runtime_error when frames has fewer than 2 entries or a list is
// not strictly increasing. An ATE that cannot be computed (no pairs, fewer
// than 3, degenerate) gives a null RMSE with the reason in ate_note.
RunMetricsReport ComputeRunMetrics(const RunMetricsInput& input);
TrajectoryMetrics ComputeTrajectoryMetrics(const std::vector<Timestamp>& frames,
                                           const Trajectory& est, const Trajectory& gt,
                                           const AteOptions& ate,
                                           const TrackingRateOptions& rate);

// metrics.json text (pretty, 2 spaces).
std::string FormatRunMetricsJson(const RunMetricsReport& report);
void WriteRunMetricsJson(const std::string& path, const RunMetricsReport& report);


// ---- run-dir files written by rumi-front (contract in docs/eval.md) --------
struct FrontFrameLine {
  Timestamp t = 0;
  TrackingState state = TrackingState::kInitializing;
  int64_t submap_id = -1;
  std::optional<double> ms;  // per-frame time, when the 4th column is given
  bool skipped = false;      // 6th column 1: the replay dropped it (front too slow), never tracked
  std::optional<Timestamp> wall;  // 7th column: when the front was done with it (system clock)
};
struct FrontSampleLine {
  Timestamp t = 0;
  int set = 0;  // 1, 2, 3 for S1, S2, S3
  int64_t window_id = -1;
};
// front_frames.txt: "t_seconds state submap_id [ms [cpu_ms skipped [wall_s [more...]]]]", state
// as a name (tracking, lost, initializing, coarse) or its number 0..3.
// front_samples.txt: "t_seconds set window_id", set as 1..3 or S1..S3.
// '#' lines and blank lines are skipped; throws naming file:line otherwise.
std::vector<FrontFrameLine> ParseFrontFrames(std::istream& in, const std::string& name);
std::vector<FrontFrameLine> ReadFrontFrames(const std::string& path);
std::vector<FrontSampleLine> ParseFrontSamples(std::istream& in, const std::string& name);
std::vector<FrontSampleLine> ReadFrontSamples(const std::string& path);
bool ParseTrackingState(const std::string& text, TrackingState* state);

// {"windows": N, "seconds": S} from back_stats.json; {"merges", "saved_frames",
// "saved_frames_postculled", "submaps_front", "submaps_back"} from
// manager_stats.json; {"saved_frames", "submaps"} from front_stats.json.
// Each throws naming the file and key when one is missing or not a number.
void ReadBackStats(const std::string& path, RunCounts* counts);
void ReadManagerStats(const std::string& path, RunCounts* counts);
void ReadFrontStats(const std::string& path, RunCounts* counts);

}  // namespace rumi
