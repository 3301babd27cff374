#pragma once
// What building one window gave: the status, the back submaps and their
// statistics, the time per COLMAP step. BackSubmapBuilder fills it, the
// result codec carries it to a remote dispatcher, back_result_io writes it.
#include <cstdint>
#include <string>
#include <vector>

#include "back/model_to_submap.h"
#include "common/submap.h"

namespace rumi {

enum class BackStatus {
  kOk,             // at least one submap
  kInvalidWindow,  // bad input (too few frames, wrong image size, bad timestamps)
  kNoModel,        // COLMAP ran but registered no model big enough
  kColmapFailed,   // a step exited non-zero or could not be started
  kTimeout,        // a step ran past step_timeout_s (its process group was killed)
  kCancelled,
  kIoError,        // workspace or image writing
  kModelError,     // a model could not be read or converted
};
const char* ToString(BackStatus s);

struct BackStepTimes {
  double undistort_write_s = 0;
  double feature_extraction_s = 0;
  double matching_s = 0;
  double mapping_s = 0;
  double read_convert_s = 0;
  double total_s = 0;
  // CPU seconds (user + system) of the COLMAP steps: comparable across loads.
  double feature_extraction_cpu_s = 0;
  double matching_cpu_s = 0;
  double mapping_cpu_s = 0;
};

struct BackResult {
  int64_t window_id = -1;
  BackStatus status = BackStatus::kInvalidWindow;
  std::string message;                 // empty or the reason for a non-ok status
  std::vector<std::string> warnings;   // e.g. models dropped as too small
  std::vector<Submap> submaps;         // one per COLMAP model kept, largest first
  std::vector<BackSubmapStats> stats;  // parallel to submaps
  int num_frames = 0;
  int num_registered = 0;              // over all kept submaps
  int matched_pairs = 0;               // image pairs matched per attempt (sequential: 0, COLMAP picks)
  BackStepTimes times;
  std::string workspace;               // path when kept, else ""
  bool retried = false;                // a second attempt with retry_peak_threshold ran
  bool retry_kept = false;             // ... and its model was larger
  bool filled = false;                 // matcher pairs fell short: the other pairs matched too
  bool fill_kept = false;              // ... and that model was larger
  // Filled by the remote dispatcher (back/remote/), not encoded: who built
  // it ("" = here), the bytes on the wire, the wait for a worker to claim
  // it, and how many times it was offered.
  struct Remote {
    std::string worker;
    uint64_t bytes_out = 0, bytes_in = 0;
    double claim_wait_s = 0;
    int offers = 0;
  } remote;
  bool ok() const { return status == BackStatus::kOk; }
};

}  // namespace rumi
