#pragma once
// rumi-back's file mode (`rumi-back --window-dir DIR --out DIR`): one window
// stored as a folder (window_dir.h) built, its result written to out_dir
// (back_result_io.h, and each submap in the shared binary format as
// submap_<id>.bin); on request the time per COLMAP step (bench) and the ATE
// of each submap against a ground truth printed, or only what the window
// costs on the wire to a remote worker (bench_wire: nothing is built).
#include <string>

#include "back/back_options.h"
#include "back/window_dir.h"
#include "common/camera.h"

namespace rumi {

struct WindowDirRunOptions {
  std::string window_dir;
  WindowDirOptions window;      // which frames, at what scale
  PinholeCameraOptions camera;  // of the folder's images
  BackOptions back;
  std::string out_dir;          // not needed with bench_wire
  bool bench = false;
  bool bench_wire = false;
  std::string groundtruth;      // TUM trajectory; "" = no ATE
};

// Exit code (common/process/exit_codes.h): done (a window built), window
// failed, bad input (the folder does not load), error (writing).
int RunWindowDir(const WindowDirRunOptions& o);

}  // namespace rumi
