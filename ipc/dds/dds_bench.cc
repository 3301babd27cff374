#include "ipc/dds/dds_bench.h"

#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "common/process/subprocess.h"
#include "common/recent_samples.h"
#include "ipc/dds/map_client.h"
#include "ipc/dds/map_server.h"

namespace rumi {
namespace {

using Clock = std::chrono::steady_clock;

// The forked child: serves `points` points until it is killed (or its parent dies).
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

// rumi's own client against the served snapshot.
struct RumiTimes {
  std::vector<double> status_us, fetch_ms;
  size_t points = 0;  // in the last fetch
};

bool TimeRumi(const DdsBenchOptions& o, const std::string& instance, RumiTimes* t) {
  std::string why;
  auto client = MapClient::Connect(o.dds, instance, 30, &why);
  if (!client) {
    std::fprintf(stderr, "%s\n", why.c_str());
    return false;
  }
  rumi_dds_Request q{};
  q.submap = const_cast<char*>("");
  MapReply r;
  q.kind = rumi_dds_KIND_POINTS;
  for (int i = 0; i < 50; ++i) {  // wait for the snapshot, warm up
    if (client->Call(q, 10, &r, &why) && r.code == rumi_dds_CODE_OK) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  q.kind = rumi_dds_KIND_STATUS;
  for (int i = 0; i < o.rounds; ++i) {
    const auto t0 = Clock::now();
    if (!client->Call(q, 10, &r, &why)) {
      std::fprintf(stderr, "status: %s\n", why.c_str());
      return false;
    }
    t->status_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  q.kind = rumi_dds_KIND_POINTS;
  for (int i = 0; i < o.fetches; ++i) {
    const auto t0 = Clock::now();
    if (!client->Call(q, 30, &r, &why) || r.code != rumi_dds_CODE_OK) {
      std::fprintf(stderr, "points: %s %s\n", why.c_str(), r.error.c_str());
      return false;
    }
    t->fetch_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    t->points = r.points.size();
  }
  return true;
}

// ddsperf on the same transport, and the ratios to rumi's figures.
void CompareDdsperf(const DdsBenchOptions& o, const RumiTimes& t) {
  const int domain = o.dds.domain_id;
  const size_t bytes = t.points * 12;
  const std::string config = DomainConfigXml(o.dds);
  std::string why;
  double p50 = 0, p99 = 0, big50 = 0, big99 = 0, mbps = 0;
  if (!DdsperfRtt(domain, config, "64", o.ddsperf_s, &p50, &p99, &why) ||
      !DdsperfRtt(domain, config, std::to_string(bytes), o.ddsperf_s, &big50, &big99, &why) ||
      !DdsperfThroughput(domain, config, bytes, o.ddsperf_s, &mbps, &why)) {
    std::printf("ddsperf: %s\n", why.c_str());
    return;
  }
  std::printf("ddsperf ping-pong 64 B        p50 %8.1f us  p99 %8.1f us\n", p50, p99);
  std::printf("ddsperf ping-pong %zu B  p50 %8.2f ms  p99 %8.2f ms  (one way ~ half)\n", bytes, big50 / 1e3,
              big99 / 1e3);
  const double stream_ms = bytes * 8 / (mbps * 1e6) * 1e3;
  std::printf("ddsperf pub/sub %zu B samples  %.0f Mb/s: %.2f ms per %zu B\n", bytes, mbps, stream_ms, bytes);
  std::printf("ratio status p50 / ddsperf 64 B p50: %.2f (goal <= 2)\n", Percentile(t.status_us, 0.5) / p50);
  std::printf("ratio points p50 / ddsperf throughput time for the bytes: %.2f (goal <= 3); / its ping-pong: %.2f, "
              "/ half of it: %.2f\n",
              Percentile(t.fetch_ms, 0.5) / stream_ms, Percentile(t.fetch_ms, 0.5) * 1e3 / big50,
              Percentile(t.fetch_ms, 0.5) * 1e3 / (big50 / 2));
}

}  // namespace

int RunDdsBench(const DdsBenchOptions& o) {
  const std::string instance = "bench" + std::to_string(::getpid());
  const pid_t child = ::fork();
  if (child == 0) Serve(o.dds, instance, o.points);
  dds_set_log_mask(DDS_LC_FATAL | DDS_LC_ERROR);
  RumiTimes t;
  if (!TimeRumi(o, instance, &t)) return 1;
  ::kill(child, SIGTERM);
  ::waitpid(child, nullptr, 0);
  const size_t bytes = t.points * 12;
  std::printf("rumi  status round trip   p50 %8.1f us  p99 %8.1f us  max %8.1f us  (%d calls)\n",
              Percentile(t.status_us, 0.5), Percentile(t.status_us, 0.99), Percentile(t.status_us, 1.0), o.rounds);
  std::printf("rumi  %zu points (%.2f MB, chunks of %lld B)  p50 %7.2f ms  max %7.2f ms  (%d fetches)\n", t.points,
              bytes / 1e6, static_cast<long long>(o.dds.chunk_bytes), Percentile(t.fetch_ms, 0.5),
              Percentile(t.fetch_ms, 1.0), o.fetches);
  CompareDdsperf(o, t);
  return 0;
}

}  // namespace rumi
