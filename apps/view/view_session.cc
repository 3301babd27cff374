#include "apps/view/view_session.h"

namespace rumi {

std::unique_ptr<ViewSession> ViewSession::Start(const ViewSessionOptions& o, std::string* why) {
  std::string token;
  if (!ResolveViewToken(o.view, o.state_dir, &token, why)) return nullptr;
  const std::string web = FindWebDir(o.view.web_dir);
  if (web.empty()) {
    *why = "view: the page's files (index.html) are neither in view.web_dir, installed share/rumi/view nor the "
           "source tree";
    return nullptr;
  }
  std::unique_ptr<ViewSession> s(new ViewSession());
  s->hub_ = std::make_shared<ViewHub>(o.view);
  s->folder_ = std::make_unique<FolderFeed>(o.state_dir, s->hub_, !o.live_dds);
  s->folder_->Poll(nullptr);  // a finished session is there at the first request
  s->server_ = ViewServer::Start(o.view, token, s->hub_, web, why);
  if (!s->server_) return nullptr;
  s->folder_->Start(o.folder_interval_s);
  if (o.live_dds) {
    s->dds_ = std::make_unique<DdsFeed>(o.dds, o.instance, s->hub_);
    s->dds_->Start();
  }
  return s;
}

ViewSession::~ViewSession() {
  server_.reset();
  dds_.reset();
  folder_.reset();
}

}  // namespace rumi
