// rumi-dds-bench: the map service's speed against Cyclone's own ddsperf, on
// this machine, in one run (docs/dds.md, docs/results/). A child process
// serves a synthetic snapshot (--points points); this process queries it:
// the status round trip (p50/p99 over --rounds calls) and the fetch of all
// points in one page (the reply in chunks). Then ddsperf ping/pong on the
// same transport: 64 B round trips, and round trips of the points' byte
// count. Prints the figures and the ratios the DDS issue asks for.
//   rumi-dds-bench [--points 100000] [--rounds 2000] [--fetches 30] [--domain 77]
// With --manager RAW (a saved map.rumi.raw): does serving cost the manager?
// Feeds the first --submaps submaps of RAW one at a time into a manager
// service, rebuilding and saving after each, three times: without DDS; with
// the server, a 30 Hz pose stream and a `rumi query pose --follow` client
// reading; and with that client stopped (SIGSTOP) so it reads nothing.
// Prints the rebuild (+ save) and snapshot times of each.
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <thread>

#include "common/process/subprocess.h"
#include "common/recent_samples.h"
#include "manager/manager_service.h"
#include "manager/map_file.h"
#include "manager/map_snapshot_of.h"
#include "ipc/dds/map_client.h"
#include "ipc/dds/map_server.h"
#include "ipc/dds/request_handler.h"

namespace rumi {
namespace {

using Clock = std::chrono::steady_clock;

[[noreturn]] void Serve(const DdsOptions& o, const std::string& instance, int points) {
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  std::string why;
  auto server = MapServer::Start(o, instance, &why);
  if (!server) {
    std::fprintf(stderr, "server: %s\n", why.c_str());
    ::_exit(1);
  }
  auto s = std::make_shared<MapSnapshot>();
  s->seq = 1;
  s->status.instance = instance;
  s->status.state = "running";
  for (int i = 0; i < points; ++i) s->points.emplace_back(0.01f * (i % 1000), 0.01f * (i / 1000), 1.f);
  server->Publish(s);
  for (;;) ::pause();
}

// ddsperf's per-second lines "size S mean .. 50% Xus 90% .. 99% Yus ..":
// the medians over the seconds of the 50% and 99% columns, in microseconds.
bool DdsperfRtt(int domain, const std::string& config, const std::string& size, double seconds, double* p50,
                double* p99, std::string* why) {
  const std::string log = "/tmp/rumi_dds_bench_ddsperf_" + std::to_string(::getpid()) + ".log";
  std::remove(log.c_str());
  SpawnOptions pong;
  pong.argv = {"ddsperf", "-i", std::to_string(domain), "-D", std::to_string(int(seconds) + 5), "pong", "waitset"};
  pong.env = {"CYCLONEDDS_URI=" + config};
  pong.log_path = "/dev/null";
  const pid_t pp = SpawnChild(pong, why);
  if (pp <= 0) return false;
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  RunRequest ping;
  ping.argv = {"ddsperf", "-i", std::to_string(domain), "-D", std::to_string(int(seconds)), "ping", "size", size,
               "waitset"};
  ping.env = {"CYCLONEDDS_URI=" + config};
  ping.log_path = log;
  ping.timeout_s = seconds + 30;
  ping.low_priority = false;
  const RunResult r = RunProcess(ping);
  ::kill(pp, SIGTERM);
  ::waitpid(pp, nullptr, 0);
  std::vector<double> a, b;
  std::ifstream in(log);
  for (std::string line; std::getline(in, line);) {
    const size_t m = line.find(" 50% "), n = line.find(" 99% ");
    if (m == std::string::npos || n == std::string::npos) continue;
    a.push_back(std::stod(line.substr(m + 5)));
    b.push_back(std::stod(line.substr(n + 5)));
  }
  std::remove(log.c_str());
  if (a.empty()) {
    *why = "ddsperf gave no round trips (" + r.message + ")";
    return false;
  }
  *p50 = Percentile(a, 0.5);
  *p99 = Percentile(b, 0.5);
  return true;
}

// One pass of the --manager mode; mode: off | follow | stopped.
int ManagerPass(const std::vector<Submap>& submaps, const std::string& mode, const DdsOptions& o,
                const std::string& out) {
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
  std::unique_ptr<MapServer> server;
  pid_t client = -1;
  std::atomic<bool> stop{false};
  std::thread poses;
  if (mode != "off") {
    server = MapServer::Start(o, instance, &why);
    if (!server) {
      std::fprintf(stderr, "%s\n", why.c_str());
      return 1;
    }
    poses = std::thread([&] {  // the front's 30 Hz pose stream
      for (int64_t i = 0; !stop; ++i) {
        LivePose p;
        p.timestamp = i * 33333333;
        p.state = 1;
        p.submap = "front#0";
        server->PublishPose(p);
        std::this_thread::sleep_for(std::chrono::microseconds(33333));
      }
    });
    SpawnOptions c;
    c.argv = {ExecutableDir() + "/rumi", "query", "--instance", instance, "--domain", std::to_string(o.domain_id),
              "--timeout", "3600", "pose", "--follow"};
    c.log_path = "/dev/null";
    client = SpawnChild(c, &why);
    std::this_thread::sleep_for(std::chrono::seconds(2));  // attached and reading
    if (mode == "stopped") ::kill(client, SIGSTOP);
  }
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
  if (server) {
    const MapServerCounters c = server->counters();
    std::printf("; %lld snapshots published", static_cast<long long>(c.snapshots));
  }
  std::printf("\n");
  stop = true;
  if (poses.joinable()) poses.join();
  if (client > 0) {
    ::kill(client, SIGKILL);
    ::waitpid(client, nullptr, 0);
  }
  return 0;
}

int ManagerBench(const std::string& raw, int count, int repeat, const DdsOptions& o) {
  GlobalMap map;
  std::string why;
  if (!LoadGlobalMap(raw, &map, &why)) {
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
  if (count > 0 && submaps.size() > static_cast<size_t>(count)) submaps.resize(count);
  std::printf("%zu submaps of %s, one rebuild (merge, culling, save) after each\n", submaps.size(), raw.c_str());
  const std::string out = "/tmp/rumi_dds_bench_" + std::to_string(::getpid());
  for (int k = 0; k < repeat; ++k)  // interleaved: drift of the machine hits every mode alike
    for (const char* mode : {"off", "follow", "stopped"})
      if (ManagerPass(submaps, mode, o, out) != 0) return 1;
  std::filesystem::remove_all(out);
  return 0;
}

// ddsperf pub/sub of `bytes`-byte samples: the median of its per-second
// rates, in Mb/s (the "rate ... kS/s X Mb/s" lines of sub).
bool DdsperfThroughput(int domain, const std::string& config, size_t bytes, double seconds, double* mbps,
                       std::string* why) {
  const std::string log = "/tmp/rumi_dds_bench_sub_" + std::to_string(::getpid()) + ".log";
  std::remove(log.c_str());
  SpawnOptions sub;
  sub.argv = {"ddsperf", "-i", std::to_string(domain), "-D", std::to_string(int(seconds) + 3), "sub", "waitset"};
  sub.env = {"CYCLONEDDS_URI=" + config};
  sub.log_path = log;
  const pid_t sp = SpawnChild(sub, why);
  if (sp <= 0) return false;
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  RunRequest pub;
  pub.argv = {"ddsperf", "-i", std::to_string(domain), "-D", std::to_string(int(seconds)), "pub", "size",
              std::to_string(bytes)};
  pub.env = {"CYCLONEDDS_URI=" + config};
  pub.log_path = "/dev/null";
  pub.timeout_s = seconds + 30;
  pub.low_priority = false;
  RunProcess(pub);
  ::kill(sp, SIGTERM);
  ::waitpid(sp, nullptr, 0);
  std::vector<double> rates;
  std::ifstream in(log);
  for (std::string line; std::getline(in, line);) {
    const size_t k = line.find(" kS/s ");
    if (line.find(" rate ") == std::string::npos || k == std::string::npos) continue;
    const double r = std::stod(line.substr(k + 6));
    if (r > 0) rates.push_back(r);
  }
  std::remove(log.c_str());
  if (rates.empty()) {
    *why = "ddsperf sub saw no data";
    return false;
  }
  *mbps = Percentile(rates, 0.5);
  return true;
}

int Main(int argc, char** argv) {
  CLI::App app{"rumi-dds-bench: the DDS map service against ddsperf on this machine"};
  int points = 100000, rounds = 2000, fetches = 30, domain = 77, submaps = 40, repeat = 2;
  double ddsperf_s = 10;
  std::string manager_raw;
  int64_t chunk_bytes = DdsOptions().chunk_bytes;
  app.add_option("--chunk-bytes", chunk_bytes, "dds.chunk_bytes of the server")->capture_default_str();
  app.add_option("--manager", manager_raw, "a map.rumi.raw: time the manager with and without serving");
  app.add_option("--submaps", submaps, "with --manager: how many submaps to feed")->capture_default_str();
  app.add_option("--repeat", repeat, "with --manager: passes of the three modes")->capture_default_str();
  app.add_option("--points", points, "points in the served map (one page)")->capture_default_str();
  app.add_option("--rounds", rounds, "status round trips")->capture_default_str();
  app.add_option("--fetches", fetches, "fetches of all points")->capture_default_str();
  app.add_option("--domain", domain, "DDS domain (keep it apart from live ones)")->capture_default_str();
  app.add_option("--ddsperf-seconds", ddsperf_s, "seconds per ddsperf run")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  std::string why;
  DdsOptions o;
  o.domain_id = domain;
  o.max_page_points = std::max(points, 1);
  o.chunk_bytes = chunk_bytes;
  if (!o.Check(&why)) {
    std::fprintf(stderr, "%s\n", why.c_str());
    return 2;
  }
  if (!manager_raw.empty()) {
    spdlog::set_level(spdlog::level::warn);
    return ManagerBench(manager_raw, submaps, repeat, o);
  }
  const std::string instance = "bench" + std::to_string(::getpid());
  const pid_t child = ::fork();
  if (child == 0) Serve(o, instance, points);
  dds_set_log_mask(DDS_LC_FATAL | DDS_LC_ERROR);
  auto client = MapClient::Connect(o, instance, 30, &why);
  if (!client) {
    std::fprintf(stderr, "%s\n", why.c_str());
    return 1;
  }
  rumi_dds_Request q{};
  q.submap = const_cast<char*>("");
  MapReply r;
  q.kind = rumi_dds_KIND_POINTS;
  for (int i = 0; i < 50; ++i) {  // wait for the snapshot, warm up
    if (client->Call(q, 10, &r, &why) && r.code == rumi_dds_CODE_OK) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  std::vector<double> status_us, fetch_ms;
  q.kind = rumi_dds_KIND_STATUS;
  for (int i = 0; i < rounds; ++i) {
    const auto t0 = Clock::now();
    if (!client->Call(q, 10, &r, &why)) {
      std::fprintf(stderr, "status: %s\n", why.c_str());
      return 1;
    }
    status_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  q.kind = rumi_dds_KIND_POINTS;
  size_t got = 0;
  for (int i = 0; i < fetches; ++i) {
    const auto t0 = Clock::now();
    if (!client->Call(q, 30, &r, &why) || r.code != rumi_dds_CODE_OK) {
      std::fprintf(stderr, "points: %s %s\n", why.c_str(), r.error.c_str());
      return 1;
    }
    fetch_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    got = r.points.size();
  }
  client.reset();
  ::kill(child, SIGTERM);
  ::waitpid(child, nullptr, 0);

  const size_t bytes = got * 12;
  std::printf("rumi  status round trip   p50 %8.1f us  p99 %8.1f us  max %8.1f us  (%d calls)\n",
              Percentile(status_us, 0.5), Percentile(status_us, 0.99), Percentile(status_us, 1.0), rounds);
  std::printf("rumi  %zu points (%.2f MB, chunks of %lld B)  p50 %7.2f ms  max %7.2f ms  (%d fetches)\n", got,
              bytes / 1e6, static_cast<long long>(o.chunk_bytes), Percentile(fetch_ms, 0.5), Percentile(fetch_ms, 1.0),
              fetches);
  const std::string config = DomainConfigXml(o);
  double p50 = 0, p99 = 0, big50 = 0, big99 = 0, mbps = 0;
  if (!DdsperfRtt(domain, config, "64", ddsperf_s, &p50, &p99, &why) ||
      !DdsperfRtt(domain, config, std::to_string(bytes), ddsperf_s, &big50, &big99, &why) ||
      !DdsperfThroughput(domain, config, bytes, ddsperf_s, &mbps, &why)) {
    std::printf("ddsperf: %s\n", why.c_str());
    return 0;
  }
  std::printf("ddsperf ping-pong 64 B        p50 %8.1f us  p99 %8.1f us\n", p50, p99);
  std::printf("ddsperf ping-pong %zu B  p50 %8.2f ms  p99 %8.2f ms  (one way ~ half)\n", bytes, big50 / 1e3,
              big99 / 1e3);
  const double stream_ms = bytes * 8 / (mbps * 1e6) * 1e3;
  std::printf("ddsperf pub/sub %zu B samples  %.0f Mb/s: %.2f ms per %zu B\n", bytes, mbps, stream_ms, bytes);
  std::printf("ratio status p50 / ddsperf 64 B p50: %.2f (goal <= 2)\n", Percentile(status_us, 0.5) / p50);
  std::printf("ratio points p50 / ddsperf throughput time for the bytes: %.2f (goal <= 3); / its ping-pong: %.2f, "
              "/ half of it: %.2f\n",
              Percentile(fetch_ms, 0.5) / stream_ms, Percentile(fetch_ms, 0.5) * 1e3 / big50,
              Percentile(fetch_ms, 0.5) * 1e3 / (big50 / 2));
  return 0;
}

}  // namespace
}  // namespace rumi

int main(int argc, char** argv) { return rumi::Main(argc, argv); }
