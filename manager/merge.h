#pragma once
// Merging a front and a back submap (paper Section IV-C): pairing on F^search
// -> M_com -> initial Sim(3) -> Formula 8 refinement -> Sim(3)s of the global
// map updated (the smaller component moves) -> fuse M_com duplicates ->
// welding-window BA.
#include <atomic>
#include <string>
#include <vector>

#include "manager/common_points.h"
#include "manager/global_map.h"
#include "manager/manager_options.h"
#include "manager/merge_verify.h"
#include "manager/pairing.h"
#include "manager/welding_ba.h"

namespace rumi {

struct MergeReport {
  bool merged = false;
  std::string kind = "merge";  // "merge" (back <-> front), "place" or "odometry"
  std::string reason;  // why not (empty when merged)
  // What rejected it: a verification check ("inliers", "rmse", "pose_pairs",
  // "kept"; merge_verify.h), or "alignment" when the initial Sim(3) was found
  // but refused before refinement (too few inliers, inlier ratio); empty
  // otherwise.
  std::string rejected_by;
  SubmapKey front, back;
  int keyframe_pairs = 0;
  int frame_pairs = 0;  // back keyframe <-> tracked front frame (not a keyframe)
  int common_points = 0;
  int inliers = 0;
  double inlier_ratio = 0;
  std::string init_method;
  Sim3 S_bf_initial, S_bf;  // front frame -> back frame, before/after refinement
  // S_bf_initial holds the alignment's Sim(3) candidate, also when the
  // alignment then refused it: the merge audit measures what it would do.
  bool aligned = false;
  double refine_initial_rmse_px = 0, refine_final_rmse_px = 0;
  bool refined = false;  // S_bf holds a refined Sim(3) (also when rejected after it)
  int pose_pairs = 0, agreeing_pairs = 0;  // verification: paired poses compared / agreeing
  double pose_angle_deg = 0, pose_offset_ratio = 0;  // their medians
  bool front_moved = true;  // whose component moved (the smaller one)
  int fused_points = 0;
  WeldingReport welding;
  double seconds_align = 0, seconds_refine = 0, seconds_weld = 0;
  bool replayed = false;  // the outcome of an earlier rebuild (MergeMemo)
};

class MergeMemo;

// Merges map submap `front` with map submap `back`. Does nothing (reason set)
// when they are already connected or the alignment is rejected.
MergeReport MergePair(GlobalMap* map, int front, int back, const SearchSet& search, const ManagerOptions& options);

// Tries every (front, back) pair of submaps not yet connected, repeating until
// no merge succeeds (so chains A <-> back <-> B close), with F^search built
// from all submaps. With a memo, attempts it holds are replayed (merge_memo.h)
// and the memo keeps this run's attempts.
// *cancel (optional) is checked before each pair: set, the run ends early
// (the caller throws the map away: a rebuild abandoned on SIGTERM).
std::vector<MergeReport> MergeAll(GlobalMap* map, const ManagerOptions& options, MergeMemo* memo = nullptr,
                                  const std::atomic<bool>* cancel = nullptr);

// Sets the reason and logs "<kind> A <-> B rejected: why".
MergeReport RejectMerge(MergeReport r, const char* kind, const std::string& why);

// Joins the components of `front` and `back` given S_bf (front's frame ->
// back's frame): the one with fewer keyframes moves, so that afterwards
// S_gb * S_bf = S_gf. Returns whether the front side moved.
bool JoinComponents(GlobalMap* map, int front, int back, const Sim3& S_bf);

// The inliers of an alignment that still agree in 3D under S_bf (the
// refined Sim(3)): within `threshold` (back units, the alignment's own
// inlier distance). As (front point index, back point index), in match order.
std::vector<std::pair<int, int>> AgreeingInliers(const Submap& front, const Submap& back,
                                                 const std::vector<PointMatch>& matches,
                                                 const std::vector<char>& inliers, const Sim3& S_bf, double threshold);

// The common tail of every merge, once r.S_bf (front frame -> back frame) is
// refined: moves the smaller component, joins the two, fuses the `agreeing`
// points (AgreeingInliers) and runs the welding BA around the seed
// keyframes of `front`. Fills the report's fused_points, front_moved,
// welding and seconds_weld.
void CommitMerge(GlobalMap* map, int front, int back, const std::vector<std::pair<int, int>>& agreeing,
                 const std::vector<int64_t>& seeds, const ManagerOptions& options, MergeReport* report);

// Re-expresses a submap by S (poses, points, frame records): for export and
// for tests; the global map itself keeps submaps in their own frames.
void TransformSubmap(const Sim3& S, Submap* s);

}  // namespace rumi
