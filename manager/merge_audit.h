#pragma once
// The merge audit of `rumi eval run`: for every merge attempt of a run that
// reached a Sim(3) (accepted; rejected by the verification, with its refined
// Sim(3); or refused by the alignment, with the candidate it refused: too few
// inliers, a low inlier ratio), what accepting it does to the map, measured
// against the ground truth.
//
// The two sides are taken from the raw map (every submap as received, in its
// own frame, before any merge): side b = all posed frames of the back submap
// (its keyframes) or of the second front submap; side a = the first submap's
// tracked frames within near_s of side b's time span (all of them when fewer
// than 3 are that near). Each side is Sim(3)-aligned to the ground truth on
// its own (ate_a, ate_b: "before"), then side b is moved into side a's frame
// by the merge's Sim(3) and both are aligned together (ate_joint, and
// ate_a_joint over side a's frames: "after"; welding not included).
//
// Harmful: ate_joint > joint_ratio x max(ate_a, ate_b) + floor_ratio x the
// ground-truth extent of both sides' frames. The bound for a whole
// run (merged ATE <= 1.5 x the front's) applied to one merge: joined, the
// two sides may be as bad as the worse of them alone, and a little more,
// but a wrong Sim(3) puts side b metres away. Not ate_a_joint: under one
// alignment a front that drifts far from the junction shows its own drift
// next to an accurate back, which is not the merge's doing (what merging
// does to the front's frames is metrics.json merged_ate_front_frames).
// Also harmful: ate_joint > front_ratio x ate_a + floor, whatever ate_b:
// a back submap that is itself broken (COLMAP joined two places through a
// repeated pattern: `kidnap` seed 3, its own ATE 0.27 m against 0.006 m for
// the front) is as bad alone as joined, so the first rule excuses it, yet
// merging it puts that error into the map. Right merges of the November
// 2026 runs stayed within 3.5 x (a blurred back at 4 x the front's ATE).
// The floor keeps noise on millimetre errors from counting as harm.
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/run_metrics.h"
#include "common/trajectory.h"
#include "common/trajectory_eval.h"
#include "manager/global_map.h"
#include "manager/merge.h"

namespace rumi {

struct MergeAuditOptions {
  double near_s = 3.0;
  double joint_ratio = 1.5;
  double front_ratio = 5.0;
  double floor_ratio = 0.001;
  AssociationOptions association;
};

// One attempt as manager_stats.json "merge_reports" gives it.
struct MergeAttempt {
  std::string kind = "merge";
  std::string a, b;  // ToString(SubmapKey): "front#0", "back#2"
  bool merged = false;
  std::string reason, rejected_by;
  bool has_transform = false;
  Sim3 S_ba;  // a's frame -> b's frame (the report's S_bf)
};

// Throws std::runtime_error naming the file when it is not manager_stats.json
// with a "merge_reports" array. Attempts without a Sim(3) are skipped.
std::vector<MergeAttempt> ReadMergeAttempts(const std::string& manager_stats_path);

// The attempts of a manager's reports that got a Sim(3) (merged, refined, or
// the alignment's candidate).
std::vector<MergeAttempt> AttemptsOf(const std::vector<MergeReport>& reports);

// Submaps named in an attempt but absent from `raw` give a row with a note.
std::vector<MergeAuditRow> AuditMerges(const GlobalMap& raw, const std::vector<MergeAttempt>& attempts,
                                       const Trajectory& ground_truth, const MergeAuditOptions& options = {});

}  // namespace rumi
