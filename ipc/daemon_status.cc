#include "ipc/daemon_status.h"

#include <algorithm>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "common/process/process_info.h"

namespace rumi {
namespace {

std::string Get(const nlohmann::json& j, const char* key, const std::string& fallback = "-") {
  if (!j.is_object() || !j.contains(key) || j[key].is_null()) return fallback;
  if (j[key].is_string()) return j[key].get<std::string>();
  return j[key].dump();
}

std::string Duration(double s) {
  if (!std::isfinite(s)) return "-";
  char buf[32];
  if (s < 120) std::snprintf(buf, sizeof(buf), "%.0f s", s);
  else if (s < 7200) std::snprintf(buf, sizeof(buf), "%.0f min", s / 60);
  else std::snprintf(buf, sizeof(buf), "%.1f h", s / 3600);
  return buf;
}

}  // namespace

std::string DaemonSummary(const nlohmann::json& st) {
  const nlohmann::json& f = st.value("front", nlohmann::json::object());
  const nlohmann::json& b = st.value("back", nlohmann::json::object());
  const nlohmann::json& m = st.value("manager", nlohmann::json::object());
  // Once the source ended (finishing), the front's last report is stale.
  const bool ended = Get(st, "state") == "finishing";
  std::string s = Get(st, "state") + "; source " + (ended ? std::string("ended") : Get(f, "source")) + "; " +
                  (ended ? std::string("front done") : Get(f, "state", "front starting")) +
                  "; submaps " + Get(m, "submaps_front", "0") + " front + " + Get(m, "submaps_back", "0") +
                  " back; merges " + Get(m, "merges", "0") + "; back queue " + Get(b, "queue", "0");
  if (b.contains("building")) s += " (window " + Get(b["building"], "window") + ": " + Get(b["building"], "stage") + ")";
  return s;
}

std::string FormatDaemonStatus(const nlohmann::json& st, bool alive) {
  std::ostringstream o;
  o << "rumid " << Get(st, "instance") << ": " << (alive ? Get(st, "state") : "not running (last: " + Get(st, "state") + ")")
    << ", pid " << Get(st, "pid") << ", up " << Duration(st.value("uptime_s", NAN)) << ", status of "
    << Get(st, "updated") << "\n";
  o << "  config " << Get(st, "config") << ", state " << Get(st, "state_dir") << "\n\n";
  o << "  child          pid      state        uptime    restarts  ready  heartbeat\n";
  for (const auto& c : st.value("children", nlohmann::json::array())) {
    char buf[200];
    std::snprintf(buf, sizeof(buf), "  %-13s %-8s %-12s %-9s %-9s %-6s %s\n", Get(c, "name").c_str(),
                  Get(c, "pid").c_str(), Get(c, "state").c_str(), Duration(c.value("uptime_s", NAN)).c_str(),
                  Get(c, "restarts").c_str(), c.value("ready", false) ? "yes" : "no",
                  Duration(c.value("heartbeat_age_s", NAN)).c_str());
    o << buf;
  }
  const nlohmann::json& f = st.value("front", nlohmann::json::object());
  const nlohmann::json& b = st.value("back", nlohmann::json::object());
  const nlohmann::json& m = st.value("manager", nlohmann::json::object());
  o << "\n  source     " << (Get(st, "state") == "finishing" ? std::string("ended") : Get(f, "source"))
    << "\n";
  o << "  tracking   " << Get(f, "state") << " in submap " << Get(f, "submap") << "; frames " << Get(f, "frames")
    << ", tracked " << Get(f, "tracked") << ", skipped " << Get(f, "skipped") << "\n";
  o << "  submaps    " << Get(m, "submaps_front", "0") << " front, " << Get(m, "submaps_back", "0") << " back, "
    << Get(m, "components", "0") << " component(s); merges " << Get(m, "merges", "0") << ", loops closed "
    << Get(m, "loops", "0") << "; manager "
    << Get(m, "state") << ", " << Get(m, "rebuilds", "0") << " rebuilds (last " << Get(m, "last_rebuild_s")
    << " s)\n";
  o << "  back       queue " << Get(b, "queue", "0") << ", built " << Get(b, "built", "0") << ", failed "
    << Get(b, "failed", "0") << ", dropped " << Get(b, "dropped", "0") << ", joined " << Get(b, "joined", "0");
  if (b.contains("building")) {
    const nlohmann::json& w = b["building"];
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.0f s", w.value("elapsed_s", 0.0));
    o << "; building window " << Get(w, "window") << " (" << Get(w, "frames") << " frames): " << Get(w, "stage")
      << ", " << buf;
  }
  o << "\n";
  o << "  windows    sent " << Get(f, "windows_sent", "0") << ", dropped by the front " << Get(f, "windows_dropped", "0")
    << "\n";
  for (const auto& r : st.value("rings", nlohmann::json::array())) {
    o << "  ring       " << Get(r, "name") << ": pushed " << Get(r, "pushed") << ", read " << Get(r, "popped")
      << ", dropped " << Get(r, "dropped") << "\n";
  }
  o << "  last save  " << Get(m, "last_save") << "\n";
  const nlohmann::json& self = st.value("rumid", nlohmann::json::object());
  auto mib = [](const nlohmann::json& j, const char* key) {  // whole MiB
    if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return std::string("-");
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.0f", j[key].get<double>());
    return std::string(buf);
  };
  o << "  memory     rumid " << mib(self, "rss_mib") << " MiB";
  for (const auto& c : st.value("children", nlohmann::json::array()))
    o << ", " << Get(c, "name") << " " << mib(c, "rss_mib") << " MiB (" << mib(c, "private_mib") << " private, "
      << Get(c, "fds") << " fds)";
  o << "\n";
  return o.str();
}

std::string DaemonStatusCsv(const nlohmann::json& st, bool header) {
  std::ostringstream h, v;
  auto col = [&](const std::string& name, const std::string& value) {
    h << (h.tellp() > 0 ? "," : "") << name;
    v << (v.tellp() > 0 ? "," : "") << value;
  };
  col("uptime_s", Get(st, "uptime_s", ""));
  const nlohmann::json& r = st.value("rumid", nlohmann::json::object());
  col("rumid_rss_mib", Get(r, "rss_mib", ""));
  col("rumid_fds", Get(r, "fds", ""));
  auto child = [&](const std::string& name) {
    for (const auto& x : st.value("children", nlohmann::json::array()))
      if (x.value("name", std::string()) == name) return x;
    return nlohmann::json(nlohmann::json::object());
  };
  const char* const kChildren[] = {"front", "back", "manager"};
  for (const std::string p : kChildren) {
    const nlohmann::json c = child("rumi-" + p);
    col(p + "_rss_mib", Get(c, "rss_mib", ""));
    col(p + "_fds", Get(c, "fds", ""));
    col(p + "_restarts", Get(c, "restarts", ""));
  }
  const nlohmann::json& f = st.value("front", nlohmann::json::object());
  const nlohmann::json& b = st.value("back", nlohmann::json::object());
  const nlohmann::json& m = st.value("manager", nlohmann::json::object());
  col("frames", Get(f, "frames", ""));
  col("tracked", Get(f, "tracked", ""));
  col("submaps_front", Get(m, "submaps_front", ""));
  col("submaps_back", Get(m, "submaps_back", ""));
  col("components", Get(m, "components", ""));
  col("merges", Get(m, "merges", ""));
  col("loops", Get(m, "loops", ""));
  col("rebuilds", Get(m, "rebuilds", ""));
  col("last_rebuild_s", Get(m, "last_rebuild_s", ""));
  col("windows_built", Get(b, "built", ""));
  col("windows_failed", Get(b, "failed", ""));
  col("windows_dropped", Get(b, "dropped", ""));
  col("windows_joined", Get(b, "joined", ""));
  // Appended, so older columns keep their places: the private part of each
  // process's RSS and its touched shared-segment pages (the rings).
  for (const std::string p : kChildren) {
    const nlohmann::json c = child("rumi-" + p);
    col(p + "_private_mib", Get(c, "private_mib", ""));
    col(p + "_shared_mib", Get(c, "shared_mib", ""));
  }
  return (header ? h.str() + "\n" : std::string()) + v.str() + "\n";
}

bool ReadDaemonStatus(const std::string& state_dir, nlohmann::json* status, std::string* why) {
  const std::string path = state_dir + "/status.json";
  std::ifstream in(path);
  if (!in) {
    if (why) *why = "no " + path + ": has a rumid ever run with this state folder?";
    return false;
  }
  try {
    *status = nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    if (why) *why = path + ": " + e.what();
    return false;
  }
  return true;
}

DaemonLiveness CheckDaemonLiveness(const nlohmann::json& st, double now_unix_s) {
  DaemonLiveness l;
  const pid_t pid = st.value("pid", 0);
  const std::string state = st.value("state", std::string());
  const uint64_t ticks = pid > 0 ? ProcessStartTicks(pid) : 0;
  // The pid may be long gone, or reused by another process since.
  const bool same = ticks != 0 && (!st.contains("pid_start_ticks") || st["pid_start_ticks"].get<uint64_t>() == ticks);
  l.alive = same && state != "stopped" && state != "failed";
  if (st.contains("updated_unix_s") && st["updated_unix_s"].is_number()) {
    l.age_s = now_unix_s - st["updated_unix_s"].get<double>();
    const double interval = st.value("status_interval_s", 1.0);
    l.stale = l.alive && l.age_s > std::max(10.0, 5 * interval);
  }
  return l;
}

}  // namespace rumi
