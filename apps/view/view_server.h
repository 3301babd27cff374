#pragma once
// The web view's HTTP server (cpp-httplib, docs/view.md): the page's files,
// the JSON of what it shows and a server-sent-event stream of what changes,
// all from one ViewHub. Read-only: nothing it serves changes the map or the
// robot. Every request is checked before it is routed: its path (short,
// plain characters, no "..") and, when a token is set, the token
// (?token=... or "Authorization: Bearer ..."; 401 without one, 403 wrong).
#include <memory>
#include <string>
#include <thread>

#include "apps/view/view_hub.h"
#include "apps/view/view_options.h"

namespace httplib {
class Server;
}

namespace rumi {

class ViewServer {
 public:
  // Listens on o.bind:o.port (0: a free port) with the page's files from
  // web_dir; nullptr with *why when the files or the address are not there.
  static std::unique_ptr<ViewServer> Start(const ViewOptions& o, const std::string& token,
                                           std::shared_ptr<ViewHub> hub, const std::string& web_dir,
                                           std::string* why);
  ~ViewServer();  // closes the streams and stops
  int port() const { return port_; }
  // "http://127.0.0.1:8765/" (with "?token=..." left out: the user has it).
  std::string Address() const;

 private:
  ViewServer() = default;

  std::unique_ptr<httplib::Server> server_;
  std::shared_ptr<ViewHub> hub_;
  std::string bind_;
  int port_ = 0;
  std::thread thread_;
};

// The page's files: view.web_dir, else installed (<bin>/../share/rumi/view),
// else the source tree's apps/view/web. "" when none holds index.html.
std::string FindWebDir(const std::string& configured);

// The token to require: view.token, else view.token_file's first line
// (relative: to the state folder), else "". False with *why when the file
// cannot be read or is empty.
bool ResolveViewToken(const ViewOptions& o, const std::string& state_dir, std::string* token, std::string* why);

// Equal without a timing that says how much of the guess was right.
bool TokenMatches(const std::string& expected, const std::string& given);

}  // namespace rumi
