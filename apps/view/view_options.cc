#include "apps/view/view_options.h"

#include <cctype>

namespace rumi {

bool IsLoopbackAddress(const std::string& a) {
  return a == "localhost" || a == "::1" || a.rfind("127.", 0) == 0;
}

const OptionSpec<ViewOptions>& ViewOptions::Spec() {
  using O = ViewOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("view");
    s->Flag("enabled", &O::enabled, "rumid serves the read-only web view of the live map");
    s->Text("bind", &O::bind, "address to listen on; not loopback: needs token or token_file", "[A-Za-z0-9.:-]+",
            [](const std::string& v) {
              for (char c : v)
                if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != ':' && c != '-')
                  return std::string("'") + c + "' cannot be in an address";
              return v.empty() ? std::string("empty") : std::string();
            });
    s->Number("port", &O::port, AtLeast(0), AtMost(65535), "TCP port; 0: any free one");
    s->Text("token", &O::token, "every request must carry it (?token= or Authorization: Bearer)");
    s->Text("token_file", &O::token_file, "the token read from this file (relative: to the state folder)");
    s->Number("max_clients", &O::max_clients, AtLeast(1), AtMost(64), "live streams open at once");
    s->Number("client_queue", &O::client_queue, AtLeast(2), AtMost(4096),
              "messages waiting per stream; a slow browser loses its oldest");
    s->Number("pose_hz", &O::pose_hz, Above(0.0), AtMost(100.0), "the live pose goes out at most this often");
    s->Number("cells_across", &O::cells_across, AtLeast(16), AtMost(4096),
              "the top view's point cells across the map's extent");
    s->Number("move_tolerance_cells", &O::move_tolerance_cells, AtLeast(0), AtMost(16),
              "a point cell or keyframe that moved by at most this many cells stays where the page shows it");
    s->Text("web_dir", &O::web_dir, "the page's files; '': installed share/rumi/view, else the source tree's");
    s->Rule("a bind address other than loopback needs view.token or view.token_file",
            [](const O& o) { return IsLoopbackAddress(o.bind) || !o.token.empty() || !o.token_file.empty(); });
    return s;
  }();
  return *spec;
}

}  // namespace rumi
