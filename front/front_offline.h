#pragma once
// rumi-front offline (`rumi-front --dataset KIND PATH ...`, no --instance):
// the front alone over a dataset read from disk, no channels. Prints the
// tracked share, the largest submap's ATE against the dataset's ground truth
// (if any), per-pass figures with loop > 1 and timings with bench; writes
// the trajectories, per-frame states and timings to out_dir. The pipeline's
// front is RunFront (front/front_run.h).
#include <string>

#include "common/dataset.h"
#include "front/front_options.h"

namespace rumi {

struct FrontOfflineOptions {
  DatasetOptions dataset;   // --dataset KIND PATH (and --config for its camera)
  FrontOptions front;       // --sync: local_mapping_thread = false
  std::string odometry;     // TUM pose source, given to the front whole before the first frame ("": none)
  std::string imu;          // IMU file (EuRoC imu0 columns), fed up to each frame ("": none; not with loop > 1)
  std::string out_dir;      // trajectory.txt, keyframes.txt, submaps_trajectory.txt, frames.txt ("": none)
  bool bench = false;       // print median / p95 / max ms per frame
  bool pace = true;         // frames at their capture rate (false: as fast as they go)
  int max_frames = 0;       // stop after N frames (0: all)
  int loop = 1;             // play the frames N times, forward and backward in turn (memory check)
};

// Returns kExitDone, or kExitBadInput (logged) when the IMU file cannot be
// read or cannot follow loop > 1. Throws std::exception on other errors (a
// dataset that cannot be read, an output that cannot be written).
int RunFrontOffline(const FrontOfflineOptions& o);

}  // namespace rumi
