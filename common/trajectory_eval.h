#pragma once
// Trajectory evaluation: timestamp association, Umeyama alignment, absolute
// trajectory error (translation) and tracking rate. Numbers agree with evo
// (evo_ape) on the references in ../shared/data/eval-reference.
#include <string>
#include <vector>

#include "common/option_spec.h"
#include "common/geometry.h"
#include "common/trajectory.h"

namespace rumi {

// ---- association ----------------------------------------------------------
struct AssociationOptions {
  double max_diff_s = 0.02;  // |t_est - t_gt| <= max_diff_s to pair
  // evo pairs every pose of the SHORTER trajectory (the estimate on ties) with
  // the nearest-in-time pose of the longer one, within max_diff; it can then
  // use one pose of the longer trajectory twice when the shorter one has two
  // poses closer than 2 * max_diff. That is the default, so rumi's ATE is
  // evo's; one_to_one (strict) keeps only the closer of such pairs (earlier
  // on a tie).
  bool one_to_one = false;
  static const OptionSpec<AssociationOptions>& Spec();
  bool Check(std::string* why = nullptr) const;
};

struct PosePair {
  size_t est = 0;  // index into the estimate
  size_t gt = 0;   // index into the ground truth
};

// Pairs sorted by estimate index. Both trajectories must be strictly
// increasing in time (the readers guarantee it).
std::vector<PosePair> AssociateByTimestamp(const Trajectory& est, const Trajectory& gt,
                                           const AssociationOptions& options);
// KITTI convention: i-th estimate with i-th ground truth, min(sizes) pairs.
std::vector<PosePair> AssociateByIndex(const Trajectory& est, const Trajectory& gt);

// ---- statistics ------------------------------------------------------------
struct ErrorStats {
  size_t count = 0;
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0, sse = 0;
};
// Population std (ddof 0) and the mean of the two middle values for the
// median of an even count, as numpy / evo. All zeros for no errors.
ErrorStats ComputeErrorStats(const std::vector<double>& errors);

// ---- absolute trajectory error --------------------------------------------
enum class Alignment { kNone, kSe3, kSim3 };
bool ParseAlignment(const std::string& name, Alignment* alignment);  // none|se3|sim3
const char* ToString(Alignment alignment);

struct AteOptions {
  AssociationOptions association;
  Alignment alignment = Alignment::kSim3;  // design.md: ATE after Sim(3) Umeyama
  bool match_by_index = false;             // KITTI: ignore timestamps, pair by index
  // Keys: max_diff_s, one_to_one, alignment (none|se3|sim3), match_by_index.
  static const OptionSpec<AteOptions>& Spec();
  bool Check(std::string* why = nullptr) const;
};

struct AteResult {
  size_t num_estimate = 0;
  size_t num_ground_truth = 0;
  std::vector<PosePair> pairs;
  double max_abs_dt_s = 0;  // largest |t_est - t_gt| among the pairs
  Alignment alignment = Alignment::kNone;
  // Maps estimate positions into the ground-truth frame: p_gt ~ S * p_est.
  // Identity for kNone, scale 1 for kSe3.
  Sim3 S_gt_est;
  // The ground truth lies on a straight line (a slider): aligned along it,
  // the angle about it fitted to the orientations (LineAlign in the .cc).
  bool line_alignment = false;
  std::vector<double> translation_errors;  // per pair, |p_gt - S * p_est| (GT units)
  ErrorStats translation;
  ErrorStats rotation_deg;  // per pair angle of R_gt^T * R(S) * R_est, degrees
};

// Associates, aligns (Umeyama on the paired positions) and measures.
// Ground truth on a straight line is aligned along the line (line_alignment).
// Throws std::runtime_error when there are no pairs, fewer than 3 pairs for
// an alignment, or the paired positions are otherwise degenerate (a static
// estimate, collinear estimate positions against non-collinear ground truth).
AteResult ComputeAte(const Trajectory& est, const Trajectory& gt, const AteOptions& options);

// ---- tracking rate ----------------------------------------------------------
// Given the timestamps of all frames of a sequence and those that received a
// pose (tracked), three rates:
//  * covered_rate (RUMI's definition, design.md): duration spanned by the
//    tracked poses, [first, last] clipped to the sequence, divided by the
//    sequence duration (last frame - first frame). Gaps inside do not count.
//  * tracked_rate: the tracked poses are cut into segments wherever two
//    consecutive tracked timestamps are more than max_gap_factor x the median
//    frame interval apart; the tracked duration is the sum of the segments'
//    spans (last - first, clipped to the sequence; an isolated pose counts 0),
//    divided by the sequence duration. Equals covered_rate when nothing is
//    lost for longer than the gap; never exceeds it.
//  * frame_rate: tracked frames / frames, where a frame counts as tracked when
//    the nearest tracked timestamp is within match_tolerance_s of it.
struct TrackingRateOptions {
  double max_gap_factor = 3.0;
  double match_tolerance_s = 0.0;  // 0: half the median frame interval
  static const OptionSpec<TrackingRateOptions>& Spec();  // keys max_gap_factor, match_tolerance_s
  bool Check(std::string* why = nullptr) const;
};

struct TrackingRate {
  size_t num_frames = 0;
  size_t num_tracked_frames = 0;
  double frame_rate = 0;
  double sequence_duration_s = 0;
  double median_frame_interval_s = 0;
  double covered_duration_s = 0;
  double covered_rate = 0;
  double tracked_duration_s = 0;
  double tracked_rate = 0;
  size_t num_segments = 0;
};

// Throws std::runtime_error when frames has fewer than 2 entries or either
// list is not strictly increasing.
TrackingRate ComputeTrackingRate(const std::vector<Timestamp>& frames,
                                 const std::vector<Timestamp>& tracked,
                                 const TrackingRateOptions& options = {});
TrackingRate ComputeTrackingRate(const std::vector<Timestamp>& frames, const Trajectory& tracked,
                                 const TrackingRateOptions& options = {});

}  // namespace rumi
