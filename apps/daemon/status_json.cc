#include "apps/daemon/status_json.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "common/process/process_info.h"
#include "common/process/subprocess.h"
#include "common/timestamp.h"
#include "ipc/daemon_status.h"
#include "ipc/segments.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;

// Resident memory (MiB: all, private, shared segments) and open file
// descriptors of a process; -1 unknown.
void AddResources(pid_t pid, nlohmann::json* j) {
  const ResidentMemory mem = ResidentMemoryOf(pid);
  int fds = 0;
  std::error_code ec;
  for (auto it = fs::directory_iterator("/proc/" + std::to_string(pid) + "/fd", ec); !ec && it != fs::directory_iterator();
       it.increment(ec))
    ++fds;
  (*j)["rss_mib"] = mem.total_mib;
  (*j)["private_mib"] = mem.private_mib;
  (*j)["shared_mib"] = mem.shared_mib;
  (*j)["fds"] = ec ? -1 : fds;
}

nlohmann::json RingsJson(const std::string& instance) {
  nlohmann::json rings = nlohmann::json::array();
  for (const std::string& name : InstanceSegmentNames(instance)) {
    RingStats s;
    if (!ReadRingStats(name, &s)) continue;
    rings.push_back({{"name", name},
                     {"pushed", s.pushed},
                     {"popped", s.popped},
                     {"dropped", s.dropped_full + s.dropped_oldest + s.dropped_too_large},
                     {"producer_alive", s.producer_alive},
                     {"consumer_alive", s.consumer_alive}});
  }
  return rings;
}

nlohmann::json ChildJson(const ChildInfo& in) {
  nlohmann::json ch = {{"name", in.name},
                       {"pid", in.pid},
                       {"state", ToString(in.state)},
                       {"uptime_s", in.uptime_s()},
                       {"restarts", in.restarts()},
                       {"ready", in.ready}};
  const double hb = in.heartbeat_age_s();
  ch["heartbeat_age_s"] = std::isfinite(hb) ? nlohmann::json(hb) : nlohmann::json();
  if (in.exited_once) ch["last_exit"] = DescribeWaitStatus(in.last_status);
  if (in.state == ChildState::kRunning) AddResources(in.pid, &ch);
  return ch;
}

// A child's own status line (its heartbeat's JSON), {} before it sent one.
nlohmann::json OwnStatus(const Supervisor& sup, int child) {
  return sup.info(child).status.is_null() ? nlohmann::json::object() : sup.info(child).status;
}

}  // namespace

nlohmann::json DaemonStatusJson(const DaemonStatusFacts& f, const Supervisor& sup) {
  nlohmann::json st;
  st["instance"] = f.instance;
  st["pid"] = ::getpid();
  st["pid_start_ticks"] = SelfProcessId().start_ticks;
  st["state"] = f.state;
  st["started"] = f.started;
  st["updated"] = LocalWallClockText();
  st["updated_unix_s"] = NsToSeconds(WallNowNs());
  st["status_interval_s"] = f.status_interval_s;
  st["uptime_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - f.started_at).count();
  st["config"] = f.config_path;
  st["state_dir"] = f.state_dir;
  if (!f.failure.empty()) st["failure"] = f.failure;
  if (!f.view.empty()) st["view"] = f.view;
  nlohmann::json children = nlohmann::json::array();
  for (int i = 0; i < static_cast<int>(sup.size()); ++i) children.push_back(ChildJson(sup.info(i)));
  st["children"] = children;
  nlohmann::json self;
  AddResources(::getpid(), &self);
  st["rumid"] = self;
  st["front"] = OwnStatus(sup, f.front);
  st["back"] = OwnStatus(sup, f.back);
  st["manager"] = OwnStatus(sup, f.manager);
  if (!st["front"].contains("source")) st["front"]["source"] = f.source;
  st["rings"] = RingsJson(f.instance);
  st["summary"] = DaemonSummary(st);
  return st;
}

}  // namespace rumi
