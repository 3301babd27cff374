#pragma once
// PNG plots for `rumi eval run` (OpenCV drawing, no plotting library):
//  * top view: estimated trajectories, Sim(3)-aligned to the ground truth,
//    coloured by submap id, over the ground truth, one panel per estimate,
//    on the two axes along which the ground truth spreads most;
//  * timeline (as the paper's Fig. 6): tracking state per frame, submap id,
//    the sampler's S1/S2/S3 samples and the windows shipped to the back.
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "common/submap.h"
#include "common/timestamp.h"
#include "common/trajectory.h"
#include "common/trajectory_eval.h"

namespace rumi {

// Colours (BGR). The ground truth has its own colour, used by nothing else.
extern const cv::Scalar kPlotGroundTruthBgr;
extern const cv::Scalar kPlotNoSubmapBgr;  // poses of no known submap (id < 0)
cv::Scalar SubmapBgr(int64_t submap_id);   // cycles through 10 colours
cv::Scalar TrackingStateBgr(TrackingState state);
cv::Scalar SampleSetBgr(int set);          // 1, 2, 3 for S1, S2, S3

// ---- top view ----------------------------------------------------------------
struct TopViewSeries {
  std::string title;                // e.g. "front (largest submap)"
  Trajectory poses;                 // in the estimate's own frame
  std::vector<int64_t> submap_ids;  // one per pose, or empty (all "no submap")
};

struct TopViewInput {
  std::string title;
  Trajectory ground_truth;  // may be empty: estimates drawn as they are
  std::vector<TopViewSeries> series;  // one panel each (none: ground truth only)
};

struct TopViewOptions {
  int width = 1400;   // whole image, panels side by side
  int height = 800;
  bool align_sim3 = true;  // align each series to the ground truth first
  AteOptions ate;          // association for the alignment
  bool Check(std::string* why = nullptr) const;
};

// Indices (0 x, 1 y, 2 z) of the two axes with the largest extent of the
// ground truth (of the estimates without one), in increasing order.
std::pair<int, int> PickPlotAxes(const std::vector<Eigen::Vector3d>& points);

cv::Mat RenderTopView(const TopViewInput& input, const TopViewOptions& options = {});

// ---- timeline ------------------------------------------------------------------
struct TimelineFrame {
  Timestamp t = 0;
  TrackingState state = TrackingState::kInitializing;
  int64_t submap_id = -1;
  bool skipped = false;  // dropped by the replay before the front saw it (drawn grey)
};
struct TimelineSample {
  Timestamp t = 0;
  int set = 0;  // 1, 2, 3
  int64_t window_id = -1;
};
struct TimelineSpan {
  Timestamp begin = 0, end = 0;
  int64_t id = -1;
};

struct TimelineInput {
  std::string title;
  std::vector<TimelineFrame> frames;    // in time order
  std::vector<TimelineSample> samples;
  std::vector<TimelineSpan> windows;    // back windows (see WindowSpans)
  Timestamp begin = 0, end = 0;         // time range shown; both 0: everything
};

struct TimelineOptions {
  int width = 1600;
  int height = 420;
  bool Check(std::string* why = nullptr) const;
};

// First to last sample of each window id, in order of first sample.
std::vector<TimelineSpan> WindowSpans(const std::vector<TimelineSample>& samples);

cv::Mat RenderTimeline(const TimelineInput& input, const TimelineOptions& options = {});

// Submap id of each pose: that of the frame with the same timestamp (nearest
// within tolerance_ns), -1 when none.
std::vector<int64_t> SubmapIdsByTime(const Trajectory& poses,
                                     const std::vector<TimelineFrame>& frames,
                                     Timestamp tolerance_ns = 1000000);

// The image as a PNG file, written atomically; errors as std::runtime_error
// naming the path.
void WritePng(const std::string& path, const cv::Mat& image);

}  // namespace rumi
