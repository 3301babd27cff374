#pragma once
// Fairness check of a scenario's hard stretch: inside it ORB (FAST threshold
// 7) should find < 100 keypoints per frame, while COLMAP (SIFT, exhaustive
// matching, CPU) still registers >= 90 % of a window around it in one model.
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/synth/synth_options.h"

namespace rumi {

struct SynthCalibrationOptions {
  std::string work_dir;            // images/, database.db, sparse/, colmap.log
  std::string colmap = "colmap";   // executable
  double around_s = 3.0;           // window reaches this far before/after the stretch
  int step_outside = 5;            // every n-th frame outside the stretch
  int colmap_threads = 1;          // the build machines are shared
  bool run_colmap = true;          // false: ORB counts only
  double sift_peak_threshold = 0;  // > 0: passed to COLMAP (its default is 0.02 / 3)
  bool Check(std::string* why = nullptr) const;
};

struct SynthCalibrationReport {
  std::string scenario;
  int window_frames = 0;         // images handed to COLMAP
  int window_inside = 0;         // of which inside the stretch
  int registered = -1;           // images in the largest model (-1: not run)
  double registered_fraction = 0;
  int orb_inside_min = 0, orb_inside_max = 0;
  double orb_inside_mean = 0;
  int orb_outside_min = 0, orb_outside_max = 0;
  double orb_outside_mean = 0;
  int dropped = 0;               // frames missing from the stream
  bool orb_ok = false;           // ORB < 100 per frame inside the stretch (drop: a gap)
  bool colmap_ok = false;        // >= 90 % registered in one model (kidnap: not required)
  // Both. Without orb_ok the stretch is still fair when rumi's front loses
  // track in it (the "or"), which only a front run can tell.
  bool ok = false;
  std::string Summary() const;
};

// Renders the window into work_dir, counts ORB keypoints and (optionally)
// runs the colmap CLI. Throws std::runtime_error when colmap fails to run.
SynthCalibrationReport CalibrateSynth(const SynthOptions& options, const SynthCalibrationOptions& c);

// Row of `n` thumbnails (tw x th) spanning the sequence with extra samples in
// the hard stretch; hard frames are framed white, dropped frames crossed out.
cv::Mat SynthContactSheet(const SynthOptions& options, int n, int tw, int th);

}  // namespace rumi
