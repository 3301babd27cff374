#pragma once
// A window stored as a folder, for rumi-back's file mode and its tests: an
// index file (rgb.txt style: "<seconds> <image path> [set]" per line, '#'
// comments, paths relative to the folder; set 1, 2, 3 or S1..S3, S2 when
// absent) plus the camera (common/camera_config.h).
#include <string>

#include "common/camera.h"
#include "common/window.h"

namespace rumi {

struct WindowDirOptions {
  std::string index_file = "rgb.txt";
  int first = 0;      // index of the first listed frame used
  int count = -1;     // frames used (-1 = all)
  int step = 1;       // use every step-th listed frame
  double scale = 1.0; // resize images (and the camera) by this factor
};

// Loads the listed frames as 8-bit grey. Returns false with a message naming
// the file and line on a missing index, malformed line, unreadable image or
// size mismatch with the camera.
bool ReadWindowDir(const std::string& dir, const PinholeCameraOptions& camera,
                   const WindowDirOptions& options, int64_t window_id, ImageWindow* window,
                   std::string* error);

}  // namespace rumi
