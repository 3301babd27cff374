#include "manager/dds_serving_bench.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <thread>
#include <vector>

#include "common/process/subprocess.h"
#include "common/recent_samples.h"
#include "ipc/dds/map_server.h"
#include "manager/manager_service.h"
#include "manager/map_file.h"
#include "manager/map_snapshot_of.h"

namespace rumi {
namespace {

using Clock = std::chrono::steady_clock;

// The server of a "follow" or "stopped" pass, with the front's 30 Hz pose
// stream and a `rumi query pose --follow` client reading it (stopped: the
// client stopped by SIGSTOP).
class Serving {
 public:
  bool Start(const DdsOptions& o, const std::string& instance, bool stop_client, std::string* why) {
    server_ = MapServer::Start(o, instance, why);
    if (!server_) return false;
    poses_ = std::thread([this] {  // the front's 30 Hz pose stream
      for (int64_t i = 0; !stop_; ++i) {
        LivePose p;
        p.timestamp = i * 33333333;
        p.state = 1;
        p.submap = "front#0";
        server_->PublishPose(p);
        std::this_thread::sleep_for(std::chrono::microseconds(33333));
      }
    });
    SpawnOptions c;
    c.argv = {ExecutableDir() + "/rumi", "query", "--instance", instance, "--domain", std::to_string(o.domain_id),
              "--timeout", "3600", "pose", "--follow"};
    c.log_path = "/dev/null";
    client_ = SpawnChild(c, why);
    // Without its client the pass measures nothing (and kill(-1, ...) would
    // signal every process the user may signal).
    if (client_ <= 0) return false;
    std::this_thread::sleep_for(std::chrono::seconds(2));  // attached and reading
    if (stop_client) ::kill(client_, SIGSTOP);
    return true;
  }
  ~Serving() {
    stop_ = true;
    if (poses_.joinable()) poses_.join();
    if (client_ > 0) {
      ::kill(client_, SIGKILL);
      ::waitpid(client_, nullptr, 0);
    }
  }
  MapServer* server() { return server_.get(); }

 private:
  std::unique_ptr<MapServer> server_;
  std::atomic<bool> stop_{false};
  std::thread poses_;
  pid_t client_ = -1;
};

// One pass; mode: off | follow | stopped.
int Pass(const std::vector<Submap>& submaps, const std::string& mode, const DdsOptions& o, const std::string& out) {
  ManagerServiceOptions so;
  so.out_dir = out + "/" + mode;
  std::filesystem::remove_all(so.out_dir);
  ManagerService service(so);
  std::string why;
  if (!service.Start(&why)) {
    std::fprintf(stderr, "%s\n", why.c_str());
    return 1;
  }
  const std::string instance = "benchmgr" + std::to_string(::getpid());
  Serving serving;
  if (mode != "off" && !serving.Start(o, instance, mode == "stopped", &why)) {
    std::fprintf(stderr, "%s\n", why.c_str());
    return 1;
  }
  MapServer* server = serving.server();
  SnapshotMaker maker(instance);
  std::vector<double> rebuild_s, snapshot_ms;
  for (const Submap& s : submaps) {
    service.AddSubmap(s);
    const auto t0 = Clock::now();
    if (!service.Rebuild(&why)) {
      std::fprintf(stderr, "rebuild: %s\n", why.c_str());
      return 1;
    }
    rebuild_s.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    if (server) {
      const auto t1 = Clock::now();
      server->Publish(maker.Make(service, "running", "{}"));
      snapshot_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t1).count());
    }
  }
  double total = 0;
  for (double x : rebuild_s) total += x;
  std::printf("%-8s rebuild+save: total %7.2f s, median %6.3f s, max %6.3f s; snapshot median %6.2f ms, max %6.2f ms",
              mode.c_str(), total, Percentile(rebuild_s, 0.5), Percentile(rebuild_s, 1.0),
              Percentile(snapshot_ms, 0.5), Percentile(snapshot_ms, 1.0));
  if (server) std::printf("; %lld snapshots published", static_cast<long long>(server->counters().snapshots));
  std::printf("\n");
  return 0;
}

}  // namespace

int RunDdsServingBench(const DdsServingBenchOptions& o) {
  GlobalMap map;
  std::string why;
  if (!LoadGlobalMap(o.raw, &map, &why)) {
    std::fprintf(stderr, "%s\n", why.c_str());
    return 1;
  }
  std::vector<Submap> submaps;
  for (size_t i = 0; i < map.size(); ++i) submaps.push_back(map.submap(static_cast<int>(i)));
  // In the order they were made (their first frame), as a session sends them.
  std::sort(submaps.begin(), submaps.end(), [](const Submap& a, const Submap& b) {
    const Timestamp ta = a.keyframes.empty() ? 0 : a.keyframes.front().timestamp;
    const Timestamp tb = b.keyframes.empty() ? 0 : b.keyframes.front().timestamp;
    return ta < tb;
  });
  if (o.submaps > 0 && submaps.size() > static_cast<size_t>(o.submaps)) submaps.resize(o.submaps);
  std::printf("%zu submaps of %s, one rebuild (merge, culling, save) after each\n", submaps.size(), o.raw.c_str());
  const std::string out = "/tmp/rumi_dds_bench_" + std::to_string(::getpid());
  for (int k = 0; k < o.repeat; ++k)  // interleaved: drift of the machine hits every mode alike
    for (const char* mode : {"off", "follow", "stopped"})
      if (Pass(submaps, mode, o.dds, out) != 0) return 1;
  std::filesystem::remove_all(out);
  return 0;
}

}  // namespace rumi
