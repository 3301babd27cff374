#pragma once
// The whole web view of one state folder, as rumid and `rumi view` run it:
// the hub, its feeds and the server. Live (rumid with dds.enabled): the map
// and the pose from the manager over DDS, the daemon's status from the
// folder. Otherwise everything from the folder, read again when it changes.
#include <memory>
#include <string>

#include "apps/view/dds_feed.h"
#include "apps/view/folder_feed.h"
#include "apps/view/view_hub.h"
#include "apps/view/view_options.h"
#include "apps/view/view_server.h"
#include "ipc/dds/dds_options.h"

namespace rumi {

struct ViewSessionOptions {
  ViewOptions view;
  std::string state_dir;
  // Live from rumi-manager over DDS (dds.enabled under rumid); else the folder.
  bool live_dds = false;
  DdsOptions dds;
  std::string instance;
  double folder_interval_s = 1.0;
};

class ViewSession {
 public:
  // nullptr with *why (the page's files, the token file, the address).
  static std::unique_ptr<ViewSession> Start(const ViewSessionOptions& o, std::string* why);
  ~ViewSession();  // the server first (no stream left), then the feeds
  std::string Address() const { return server_->Address(); }
  int port() const { return server_->port(); }
  ViewHub& hub() { return *hub_; }

 private:
  ViewSession() = default;
  std::shared_ptr<ViewHub> hub_;
  std::unique_ptr<FolderFeed> folder_;
  std::unique_ptr<DdsFeed> dds_;
  std::unique_ptr<ViewServer> server_;
};

}  // namespace rumi
