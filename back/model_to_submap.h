#pragma once
// COLMAP model -> rumi back submap: timestamps from image names, T_cw from
// qvec/tvec, keypoints and intrinsics moved from COLMAP's pixel convention
// (top-left pixel centre at (0.5, 0.5)) to rumi's/OpenCV's (centre at (0, 0)).
#include <string>

#include "back/colmap_model.h"
#include "common/submap.h"

namespace rumi {

// COLMAP pixel x/y = rumi pixel x/y + kColmapPixelOffset.
constexpr double kColmapPixelOffset = 0.5;

// File name handed to COLMAP for a frame (zero-padded ns + ".png").
std::string ColmapImageName(Timestamp t);
// Inverse of ColmapImageName; false for any other name (extension included).
bool ParseColmapImageName(const std::string& name, Timestamp* t);

struct BackSubmapStats {
  int registered_images = 0;
  int num_points = 0;
  int num_observations = 0;
  double mean_reprojection_error_px = 0.0;  // mean of COLMAP's per-point errors
  double mean_track_length = 0.0;
};

// Converts one model. The model must hold exactly one PINHOLE (or
// SIMPLE_PINHOLE) camera; every image name must parse as a timestamp.
// Keyframes are sorted by timestamp and numbered 0..n-1; points 0..m-1 in
// COLMAP id order. Returns false with a message on anything unexpected.
bool ColmapModelToSubmap(const ColmapModel& model, int64_t submap_id, Submap* submap,
                         BackSubmapStats* stats, std::string* error);

}  // namespace rumi
