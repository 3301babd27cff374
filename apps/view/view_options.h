#pragma once
// Options of the web view (config section `view:`, docs/view.md): rumid's
// read-only page of the live map, and `rumi view STATE_DIR`'s.
#include <string>

#include "common/option_spec.h"

namespace rumi {

struct ViewOptions {
  // rumid serves the page. Loopback by default: nothing leaves the machine.
  bool enabled = true;
  // Address to listen on. Anything but a loopback address needs a token.
  std::string bind = "127.0.0.1";
  // 0: any free port (tests); the address is in rumid's log and status.json.
  int port = 8765;
  // Every request must carry it (?token=... or "Authorization: Bearer ...")
  // when set. token_file: read from that file (relative: to the state folder).
  std::string token;
  std::string token_file;
  // Open live streams at once; one more is refused (503).
  int max_clients = 8;
  // Messages waiting per stream: a slow browser loses its oldest, never
  // holds up the others (or the daemon).
  int client_queue = 64;
  // The live pose goes out at most this often.
  double pose_hz = 15.0;
  // The top view's point cells: about this many across the map's extent.
  int cells_across = 512;
  // A point cell or keyframe that moved by at most this many cells (a
  // rebuild's few centimetres) stays where the page shows it: map updates
  // stay small on a map that moves (0: every move is sent).
  int move_tolerance_cells = 2;
  // The page's files; '': installed share/rumi/view, else the source tree's.
  std::string web_dir;

  static const OptionSpec<ViewOptions>& Spec();
  bool Check(std::string* why = nullptr) const { return Spec().Check(*this, why); }
};

// 127.0.0.0/8, ::1 and "localhost".
bool IsLoopbackAddress(const std::string& address);

}  // namespace rumi
