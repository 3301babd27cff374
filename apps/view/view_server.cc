#include "apps/view/view_server.h"

#include <httplib.h>
#include <openssl/crypto.h>

#include <filesystem>
#include <map>

#include "common/atomic_file.h"
#include "common/process/subprocess.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;

constexpr size_t kMaxPath = 256;
// The page's files, served from memory: nothing else of the folder is reachable.
const std::map<std::string, std::pair<std::string, std::string>> kFiles = {
    {"/", {"index.html", "text/html; charset=utf-8"}},
    {"/view.js", {"view.js", "text/javascript; charset=utf-8"}},
    {"/view.css", {"view.css", "text/css; charset=utf-8"}}};

void Refuse(httplib::Response& res, int status, const std::string& reason) {
  res.status = status;
  res.set_content(reason + "\n", "text/plain; charset=utf-8");
}

// "" when the path may be routed, else why not (and the status to answer).
std::string PathProblem(const std::string& path, int* status) {
  *status = 400;
  if (path.size() > kMaxPath) {
    *status = 414;
    return "the path is longer than " + std::to_string(kMaxPath) + " characters";
  }
  if (path.empty() || path[0] != '/') return "the path must start with '/'";
  for (char c : path)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '/' && c != '.' && c != '_' && c != '-')
      return "the path holds a character other than [A-Za-z0-9/._-]";
  if (path.find("..") != std::string::npos) return "the path holds '..'";
  return "";
}

std::string GivenToken(const httplib::Request& req) {
  if (req.has_param("token")) return req.get_param_value("token");
  const std::string auth = req.get_header_value("Authorization");
  const std::string bearer = "Bearer ";
  return auth.rfind(bearer, 0) == 0 ? auth.substr(bearer.size()) : "";
}

}  // namespace

bool TokenMatches(const std::string& expected, const std::string& given) {
  // The length is not secret (it is in the config's size); the bytes are.
  return !expected.empty() && expected.size() == given.size() &&
         CRYPTO_memcmp(expected.data(), given.data(), expected.size()) == 0;
}

std::string FindWebDir(const std::string& configured) {
  std::vector<fs::path> candidates;
  if (!configured.empty()) {
    candidates.push_back(configured);
  } else {
    candidates.push_back(fs::path(ExecutableDir()) / ".." / "share" / "rumi" / "view");
    candidates.push_back(RUMI_VIEW_SOURCE_WEB_DIR);
  }
  for (const fs::path& c : candidates)
    if (fs::is_regular_file(c / "index.html")) return fs::weakly_canonical(c).string();
  return "";
}

bool ResolveViewToken(const ViewOptions& o, const std::string& state_dir, std::string* token, std::string* why) {
  *token = o.token;
  if (!o.token.empty() || o.token_file.empty()) return true;
  fs::path p = o.token_file;
  if (p.is_relative()) p = fs::path(state_dir) / p;
  std::string text, problem;
  if (!ReadFileText(p.string(), &text, &problem)) {
    *why = "view.token_file: " + problem;
    return false;
  }
  *token = text.substr(0, text.find_first_of("\r\n"));
  if (token->empty()) {
    *why = "view.token_file " + p.string() + " holds no token on its first line";
    return false;
  }
  return true;
}

std::unique_ptr<ViewServer> ViewServer::Start(const ViewOptions& o, const std::string& token,
                                              std::shared_ptr<ViewHub> hub, const std::string& web_dir,
                                              std::string* why) {
  std::string problem;
  if (!o.Check(&problem)) {
    *why = "view: " + problem;
    return nullptr;
  }
  if (!IsLoopbackAddress(o.bind) && token.empty()) {
    *why = "view: binding " + o.bind + " (not loopback) needs a token (view.token or view.token_file)";
    return nullptr;
  }
  std::map<std::string, std::string> files;
  for (const auto& [route, file] : kFiles)
    if (!ReadFileText((fs::path(web_dir) / file.first).string(), &files[route], &problem)) {
      *why = "view: the page's file: " + problem + " (view.web_dir)";
      return nullptr;
    }
  std::unique_ptr<ViewServer> s(new ViewServer());
  s->hub_ = hub;
  s->bind_ = o.bind;
  s->server_ = std::make_unique<httplib::Server>();
  httplib::Server& svr = *s->server_;
  // Each stream holds a thread while it is open: room for all of them and
  // for the page's other requests.
  const size_t threads = static_cast<size_t>(o.max_clients) + 4;
  svr.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  svr.set_write_timeout(5, 0);  // a browser that stopped reading loses its stream
  svr.set_read_timeout(5, 0);
  svr.set_payload_max_length(4096);  // read-only: a request has no business carrying a body
  svr.set_pre_routing_handler([token](const httplib::Request& req, httplib::Response& res) {
    int status = 400;
    const std::string problem = PathProblem(req.path, &status);
    if (!problem.empty()) {
      Refuse(res, status, problem);
      return httplib::Server::HandlerResponse::Handled;
    }
    if (!token.empty()) {
      const std::string given = GivenToken(req);
      if (given.empty()) {
        Refuse(res, 401, "this view needs its token: add ?token=... to the address");
        return httplib::Server::HandlerResponse::Handled;
      }
      if (!TokenMatches(token, given)) {
        Refuse(res, 403, "wrong token");
        return httplib::Server::HandlerResponse::Handled;
      }
    }
    res.set_header("Cache-Control", "no-store");
    res.set_header("X-Content-Type-Options", "nosniff");
    // The page loads nothing from anywhere but here (it works offline).
    res.set_header("Content-Security-Policy", "default-src 'self'; img-src 'self' data: blob:");
    return httplib::Server::HandlerResponse::Unhandled;
  });
  for (const auto& [route, body] : files) {
    const std::string type = kFiles.at(route).second;
    svr.Get(route, [body = body, type](const httplib::Request&, httplib::Response& res) { res.set_content(body, type); });
  }
  const std::string json = "application/json";
  svr.Get("/api/map", [hub, json](const httplib::Request&, httplib::Response& res) { res.set_content(hub->MapJson(), json); });
  svr.Get("/api/state",
          [hub, json](const httplib::Request&, httplib::Response& res) { res.set_content(hub->StateJson(), json); });
  svr.Get("/api/timeline",
          [hub, json](const httplib::Request&, httplib::Response& res) { res.set_content(hub->TimelineJson(), json); });
  svr.Get("/api/manager_stats", [hub, json](const httplib::Request&, httplib::Response& res) {
    res.set_content(hub->ManagerStatsJson(), json);
  });
  svr.Get("/api/grid", [hub, json](const httplib::Request&, httplib::Response& res) { res.set_content(hub->GridJson(), json); });
  svr.Get("/api/grid.pgm", [hub](const httplib::Request&, httplib::Response& res) {
    const std::string pgm = hub->GridPgm();
    if (pgm.empty()) return Refuse(res, 404, "no occupancy grid yet (the map has no metric frame, or no save yet)");
    res.set_content(pgm, "image/x-portable-graymap");
  });
  svr.Get("/api/events", [hub](const httplib::Request&, httplib::Response& res) {
    std::string why;
    std::shared_ptr<ClientQueue> q = hub->Subscribe(&why);
    if (!q) return Refuse(res, 503, why);
    res.set_header("X-Accel-Buffering", "no");
    res.set_chunked_content_provider(
        "text/event-stream",
        [q](size_t, httplib::DataSink& sink) {
          std::string m;
          // A comment every second while nothing comes: a vanished browser
          // shows as a failed write and its stream ends.
          if (!q->Pop(std::chrono::milliseconds(1000), &m)) {
            if (q->closed()) {  // the server stops: the stream ends whole
              sink.done();
              return true;
            }
            m = ": idle\n\n";
          }
          return sink.write(m.data(), m.size());
        },
        [hub, q](bool) { hub->Unsubscribe(q); });
  });
  const auto read_only = [](const httplib::Request&, httplib::Response& res) {
    Refuse(res, 405, "the view is read-only: it changes nothing");
  };
  svr.Post(".*", read_only);
  svr.Put(".*", read_only);
  svr.Patch(".*", read_only);
  svr.Delete(".*", read_only);
  svr.set_error_handler([](const httplib::Request& req, httplib::Response& res) {
    if (res.body.empty())
      res.set_content(std::to_string(res.status) + (res.status == 404 ? ": no such page: " + req.path : "") + "\n",
                      "text/plain; charset=utf-8");
  });
  s->port_ = o.port == 0 ? svr.bind_to_any_port(o.bind) : (svr.bind_to_port(o.bind, o.port) ? o.port : -1);
  if (s->port_ <= 0) {
    *why = "view: cannot listen on " + o.bind + ":" + std::to_string(o.port) + " (in use, or not this host's address)";
    return nullptr;
  }
  s->thread_ = std::thread([&svr] { svr.listen_after_bind(); });
  return s;
}

ViewServer::~ViewServer() {
  if (hub_) hub_->CloseAll();
  if (server_) server_->stop();
  if (thread_.joinable()) thread_.join();
}

std::string ViewServer::Address() const {
  const std::string host = bind_.find(':') != std::string::npos ? "[" + bind_ + "]" : bind_;
  return "http://" + host + ":" + std::to_string(port_) + "/";
}

}  // namespace rumi
