// `rumi query`: the reference DDS client of a running rumi-manager
// (docs/dds.md). Human-readable by default, --json for scripts; a server
// that does not answer is a time out naming the domain and instance
// (exit 3), a refused request exits 1 with the server's reason.
#include <fmt/format.h>

#include <cmath>
#include <cstring>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/atomic_file.h"
#include "common/process/exit_codes.h"
#include "common/trajectory.h"
#include "manager/sim3_json.h"
#include "apps/config/rumi_config.h"
#include "apps/cli/commands.h"
#include "ipc/daemon_status.h"
#include "ipc/dds/map_client.h"
#include "ipc/dds/request_handler.h"

namespace rumi::cli {
namespace {

struct QueryArgs {
  std::string instance = "default", config, interface;
  int domain = -1;
  double timeout = 5.0;
  bool json = false;
  // per subcommand
  bool follow = false;
  int count = 0;
  double from_s = 0, to_s = 0;
  std::string out, submap;
  std::vector<double> box;
  int64_t page_size = 0;
};

[[noreturn]] void Fail(const std::string& why, int code) {
  std::cerr << "rumi query: " << why << "\n";
  throw CLI::RuntimeError(code);
}

DdsOptions Options(const QueryArgs& a) {
  DdsOptions o;
  try {
    o = LoadRumiConfig(a.config).dds;
  } catch (const ConfigError& e) {
    Fail(e.what(), kExitBadInput);
  }
  if (a.domain >= 0) o.domain_id = a.domain;
  if (!a.interface.empty()) o.interface = a.interface;
  std::string why;
  if (!o.Check(&why)) Fail("dds: " + why, kExitBadInput);
  return o;
}

std::unique_ptr<MapClient> Connect(const QueryArgs& a, const DdsOptions& o) {
  // Cyclone's warnings ("lo is not multicast-capable") are not the user's
  // business here; errors still show.
  dds_set_log_mask(DDS_LC_FATAL | DDS_LC_ERROR);
  std::string why;
  auto c = MapClient::Connect(o, a.instance, a.timeout, &why);
  if (!c) Fail(why, kExitNoProducer);
  return c;
}

MapReply Call(MapClient* c, const QueryArgs& a, rumi_dds_Request q) {
  q.submap = const_cast<char*>(a.submap.c_str());
  MapReply r;
  std::string why;
  if (!c->Call(q, a.timeout, &r, &why)) Fail(why, kExitNoProducer);
  if (r.code != rumi_dds_CODE_OK) Fail("the server refused: " + r.error, kExitError);
  return r;
}

// Connects, asks once, returns the answer (exits on a time out or a refusal).
MapReply Ask(const QueryArgs& a, int32_t kind, rumi_dds_Request q = {}) {
  const DdsOptions o = Options(a);
  auto c = Connect(a, o);
  q.kind = kind;
  return Call(c.get(), a, q);
}

nlohmann::json PoseJson(Timestamp t, const Se3& T) {
  const auto& q = T.rotation();
  const auto& p = T.translation();
  return {{"t_ns", t}, {"t", {p.x(), p.y(), p.z()}}, {"q_xyzw", {q.x(), q.y(), q.z(), q.w()}}};
}

nlohmann::json StatusJson(const SnapshotStatus& s) {
  nlohmann::json j = {{"instance", s.instance},   {"state", s.state},
                      {"stamp_ns", s.stamp_ns},   {"rebuilds", s.rebuilds},
                      {"submaps_front", s.submaps_front}, {"submaps_back", s.submaps_back},
                      {"components", s.components}, {"keyframes", s.keyframes},
                      {"points", s.points},       {"trajectory_frames", s.trajectory_frames},
                      {"last_save", s.last_save}, {"grid", s.grid}};
  // {"manager": ..., "daemon": rumid's status.json under rumid}
  const nlohmann::json detail = nlohmann::json::parse(s.json, nullptr, false);
  if (detail.is_object())
    for (const auto& [k, v] : detail.items()) j[k] = v;
  const SnapshotLink& l = s.link;
  if (l.present)  // the typed fields, as a program reads them off the topic
    j["link"] = {{"robot_heard", l.robot_heard},       {"robot_halted", l.robot_halted},
                 {"robot_failsafe", l.robot_failsafe}, {"rssi_dbm", l.rssi_dbm},
                 {"frames_delivered", l.frames_delivered}, {"frames_dropped", l.frames_dropped},
                 {"fragments_recovered", l.fragments_recovered},
                 {"latency_ms", {l.latency_p50_ms, l.latency_p95_ms, l.latency_max_ms}},
                 {"clock_synced", l.clock_synced},     {"clock_offset_ms", l.clock_offset_ms},
                 {"asked_fps", l.asked_fps},           {"imu_samples", l.imu_samples},
                 {"imu_gaps", l.imu_gaps},             {"gyro_predicted", l.gyro_predicted},
                 {"gyro_bridged", l.gyro_bridged},     {"authenticated", l.authenticated},
                 {"insecure", l.insecure},             {"auth_failures", l.auth_failures},
                 {"halt_alarm", l.halt_alarm}};
  return j;
}

const char* StateName(int s) {
  static const char* names[] = {"initialising", "fine", "coarse", "lost"};
  return s >= 0 && s < 4 ? names[s] : "unknown";
}

void Status(const QueryArgs& a) {
  const MapReply r = Ask(a, rumi_dds_KIND_STATUS);
  const SnapshotStatus& s = r.status;
  if (a.json) {
    std::cout << StatusJson(s).dump(2) << "\n";
    return;
  }
  std::cout << fmt::format(
      "instance {}: {}, map version {}\n  submaps {} front + {} back in {} component(s), {} keyframes, {} points\n"
      "  trajectory {} frames, last save {}\n  grid: {}\n",
      s.instance, s.state, r.map_seq, s.submaps_front, s.submaps_back, s.components, s.keyframes, s.points,
      s.trajectory_frames, s.last_save.empty() ? "none yet" : s.last_save, s.grid.empty() ? "none yet" : s.grid);
  if (const SnapshotLink& l = s.link; l.present)
    std::cout << fmt::format(
        "  link: robot {}{}, {} frames delivered, {} dropped, latency p50/p95/max {:.0f}/{:.0f}/{:.0f} ms, clock {}, "
        "RSSI {} dBm, asked {:.1f} fps, gyro {} predicted, {} bridged, {}{}{}\n",
        l.robot_heard ? (l.robot_halted ? "halted" : "walking") : "not heard", l.robot_failsafe ? " (fail-safe)" : "",
        l.frames_delivered, l.frames_dropped, l.latency_p50_ms, l.latency_p95_ms, l.latency_max_ms,
        l.clock_synced ? fmt::format("{:+.1f} ms", l.clock_offset_ms) : std::string("not synced"), l.rssi_dbm,
        l.asked_fps, l.gyro_predicted, l.gyro_bridged,
        l.insecure ? "INSECURE" : (l.authenticated ? "authenticated" : "not authenticated"),
        l.auth_failures ? fmt::format(", {} refused", l.auth_failures) : std::string(),
        l.halt_alarm ? ", HALT ALARM (the robot does not do as asked)" : "");
  const nlohmann::json detail = nlohmann::json::parse(s.json, nullptr, false);
  if (detail.is_object() && detail.contains("daemon"))  // the table `rumi status` prints on the ground station
    std::cout << FormatDaemonStatus(detail["daemon"], true);
}

void Pose(const QueryArgs& a) {
  const DdsOptions o = Options(a);
  auto c = Connect(a, o);
  int seen = 0;
  const bool ended = c->FollowPose(a.timeout, [&](const LivePose& p) {
    if (a.json) {
      nlohmann::json j = PoseJson(p.timestamp, p.T_wc);
      j["state"] = StateName(p.state);
      j["submap"] = p.submap;
      j["in_global"] = p.in_global;
      std::cout << j.dump() << std::endl;
    } else {
      const auto& t = p.T_wc.translation();
      const auto& q = p.T_wc.rotation();
      std::cout << fmt::format("{:.6f} {:.4f} {:.4f} {:.4f} {:.4f} {:.4f} {:.4f} {:.4f}  {} {}{}\n", p.timestamp * 1e-9,
                               t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w(), StateName(p.state), p.submap,
                               p.in_global ? "" : " (submap frame)")
                << std::flush;
    }
    ++seen;
    return a.follow && (a.count == 0 || seen < a.count);
  });
  if (!ended)
    Fail(fmt::format("no pose for {} s ({} received; is a source streaming?)", a.timeout, seen), kExitNoProducer);
}

void TrajectoryCmd(const QueryArgs& a) {
  rumi_dds_Request q{};
  q.from_ns = static_cast<int64_t>(std::llround(a.from_s * 1e9));
  q.to_ns = static_cast<int64_t>(std::llround(a.to_s * 1e9));
  const MapReply r = Ask(a, rumi_dds_KIND_TRAJECTORY, q);
  Trajectory traj;
  for (const SnapshotPose& p : r.poses) traj.push_back({p.timestamp, p.T_wc});
  if (!a.out.empty()) {
    try {
      WriteTumTrajectory(a.out, traj);
    } catch (const std::exception& e) {
      Fail(e.what(), kExitError);
    }
    std::cerr << fmt::format("rumi query: {} poses -> {}\n", traj.size(), a.out);
    return;
  }
  if (a.json) {
    nlohmann::json j = nlohmann::json::array();
    for (const SnapshotPose& p : r.poses) {
      j.push_back(PoseJson(p.timestamp, p.T_wc));
      j.back()["from_back"] = p.from_back;
    }
    std::cout << j.dump() << "\n";
    return;
  }
  for (const StampedPose& p : traj) {
    const auto& t = p.T_wc.translation();
    const auto& q = p.T_wc.rotation();
    std::cout << fmt::format("{:.6f} {:.6f} {:.6f} {:.6f} {:.6f} {:.6f} {:.6f} {:.6f}\n", p.t * 1e-9, t.x(), t.y(),
                             t.z(), q.x(), q.y(), q.z(), q.w());
  }
}

bool WritePly(const std::string& path, const std::vector<Eigen::Vector3f>& points, std::string* why) {
  std::string s = fmt::format(
      "ply\nformat binary_little_endian 1.0\ncomment rumi map points (global frame)\nelement vertex {}\n"
      "property float x\nproperty float y\nproperty float z\nend_header\n",
      points.size());
  const size_t head = s.size();
  s.resize(head + points.size() * 12);
  for (size_t i = 0; i < points.size(); ++i) std::memcpy(&s[head + i * 12], points[i].data(), 12);
  return WriteFileAtomically(path, s, why);
}

void Points(const QueryArgs& a) {
  const DdsOptions o = Options(a);
  if (!a.box.empty() && a.box.size() != 6) Fail("--box takes 6 numbers: xmin,ymin,zmin,xmax,ymax,zmax", kExitBadInput);
  auto c = Connect(a, o);
  rumi_dds_Request q{};
  q.kind = rumi_dds_KIND_POINTS;
  for (size_t i = 0; i < a.box.size(); ++i) (i < 3 ? q.box_min[i] : q.box_max[i - 3]) = a.box[i];
  q.page_size = a.page_size;
  std::vector<Eigen::Vector3f> all;
  int64_t pages = 1, total = 0;
  for (int64_t page = 0; page < pages; ++page) {  // every page of one map version
    q.page = page;
    MapReply r = Call(c.get(), a, q);
    pages = r.pages;
    total = r.total;
    all.insert(all.end(), r.points.begin(), r.points.end());
  }
  if (!a.out.empty()) {
    std::string why;
    if (!WritePly(a.out, all, &why)) Fail(why, kExitError);
    std::cerr << fmt::format("rumi query: {} points -> {}\n", all.size(), a.out);
    return;
  }
  if (a.json) {
    nlohmann::json j = {{"total", total}, {"points", nlohmann::json::array()}};
    for (const auto& p : all) j["points"].push_back({p.x(), p.y(), p.z()});
    std::cout << j.dump() << "\n";
    return;
  }
  std::cout << fmt::format("{} points", all.size());
  if (!all.empty()) {
    Eigen::Vector3f lo = all[0], hi = all[0];
    for (const auto& p : all) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    std::cout << fmt::format(" in [{:.2f}, {:.2f}] x [{:.2f}, {:.2f}] x [{:.2f}, {:.2f}]", lo.x(), hi.x(), lo.y(),
                             hi.y(), lo.z(), hi.z());
  }
  std::cout << " (write them with -o FILE.ply)\n";
}

void Keyframes(const QueryArgs& a) {
  const MapReply r = Ask(a, rumi_dds_KIND_KEYFRAMES);
  if (a.json) {
    nlohmann::json j = nlohmann::json::array();
    for (const SnapshotKeyframe& k : r.keyframes) {
      j.push_back(PoseJson(k.timestamp, k.T_wc));
      j.back()["id"] = k.id;
      j.back()["submap"] = k.submap;
      j.back()["component"] = k.component;
    }
    std::cout << j.dump() << "\n";
    return;
  }
  for (const SnapshotKeyframe& k : r.keyframes) {
    const auto& t = k.T_wc.translation();
    std::cout << fmt::format("{:>9} {:.6f} {:>8} c{} {:.4f} {:.4f} {:.4f}\n", k.submap, k.timestamp * 1e-9, k.id,
                             k.component, t.x(), t.y(), t.z());
  }
}

void Submaps(const QueryArgs& a) {
  const MapReply r = Ask(a, rumi_dds_KIND_SUBMAP);
  if (a.json) {
    nlohmann::json j = nlohmann::json::array();
    for (const SnapshotSubmap& s : r.submaps) {
      j.push_back({{"key", s.key}, {"component", s.component}, {"keyframes", s.keyframes}, {"points", s.points},
                   {"first_ns", s.first}, {"last_ns", s.last}, {"sim3", Sim3ToJson(s.S_gl)}});
    }
    std::cout << j.dump(2) << "\n";
    return;
  }
  for (const SnapshotSubmap& s : r.submaps)
    std::cout << fmt::format("{:>9}  component {}  {} keyframes  {} points  {:.3f}-{:.3f} s  scale {:.4f}\n", s.key,
                             s.component, s.keyframes, s.points, s.first * 1e-9, s.last * 1e-9, s.S_gl.scale());
}

void Grid(const QueryArgs& a) {
  const MapReply r = Ask(a, rumi_dds_KIND_GRID);
  const MapServerGrid& g = r.grid.cells;
  if (!a.out.empty()) {
    // The served YAML's rumi keys (scale, up, map-to-grid) go along.
    std::vector<std::string> extra;
    std::istringstream in(r.grid.yaml);
    for (std::string line; std::getline(in, line);)
      if (line.rfind("rumi_", 0) == 0 || line.rfind("# rumi", 0) == 0) extra.push_back(line);
    std::string pgm = a.out;
    const size_t dot = pgm.rfind('.');
    pgm = (dot == std::string::npos ? pgm : pgm.substr(0, dot)) + ".pgm";
    std::string why;
    if (!WriteMapServerGrid(g, pgm, a.out, extra, &why)) Fail(why, kExitError);
    std::cerr << fmt::format("rumi query: {}x{} grid -> {} + {}\n", g.width, g.height, a.out, pgm);
    return;
  }
  int counts[3] = {0, 0, 0};
  for (uint8_t v : g.pixels) ++counts[v == kPgmFree ? 0 : v == kPgmOccupied ? 1 : 2];
  const double cell2 = g.resolution * g.resolution;
  if (a.json) {
    std::cout << nlohmann::json{{"width", g.width},     {"height", g.height},
                                {"resolution", g.resolution}, {"origin", {g.origin.x(), g.origin.y(), g.origin.z()}},
                                {"free_m2", counts[0] * cell2}, {"occupied_m2", counts[1] * cell2},
                                {"yaml", r.grid.yaml}}
                     .dump(2)
              << "\n";
    return;
  }
  std::cout << fmt::format("grid {}x{} at {:.3f} m, origin ({:.2f}, {:.2f}), free {:.1f} m2, occupied {:.1f} m2 "
                           "(write it with -o map.yaml)\n",
                           g.width, g.height, g.resolution, g.origin.x(), g.origin.y(), counts[0] * cell2,
                           counts[1] * cell2);
}

}  // namespace

void RegisterQueryCommand(CLI::App* app) {
  auto a = std::make_shared<QueryArgs>();
  CLI::App* cmd = app->add_subcommand("query", "ask a running rumi-manager for its map over DDS (docs/dds.md)");
  cmd->require_subcommand(1);
  cmd->add_option("--instance", a->instance, "rumi instance (topics rumi/<instance>/*)")->capture_default_str();
  cmd->add_option("--config", a->config, "rumi config: its dds: section (domain, interface, topic_prefix)");
  cmd->add_option("--domain", a->domain, "DDS domain (overrides the config)")->check(CLI::Range(0, 232));
  cmd->add_option("--interface", a->interface, "network interface (overrides the config; default lo)");
  cmd->add_option("--timeout", a->timeout, "seconds to wait for the server")->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_flag("--json", a->json, "machine-readable output");
  cmd->fallthrough();  // inherited: `rumi query status --json` works as well

  cmd->add_subcommand("status", "the manager's state and counts")->callback([a] { Status(*a); });
  CLI::App* pose = cmd->add_subcommand("pose", "the live camera pose");
  pose->add_flag("--follow", a->follow, "keep printing poses (ends when none comes for --timeout s)");
  pose->add_option("--count", a->count, "with --follow: stop after this many");
  pose->callback([a] { Pose(*a); });
  CLI::App* traj = cmd->add_subcommand("trajectory", "the global trajectory (TUM)");
  traj->add_option("--from", a->from_s, "first timestamp, seconds");
  traj->add_option("--to", a->to_s, "last timestamp, seconds");
  traj->add_option("-o,--out", a->out, "write a TUM file");
  traj->callback([a] { TrajectoryCmd(*a); });
  CLI::App* pts = cmd->add_subcommand("points", "the map points of the main component");
  pts->add_option("--box", a->box, "xmin,ymin,zmin,xmax,ymax,zmax")->delimiter(',');
  pts->add_option("--page-size", a->page_size, "points per request (0: the server's cap)");
  pts->add_option("-o,--out", a->out, "write a binary PLY file");
  pts->callback([a] { Points(*a); });
  cmd->add_subcommand("keyframes", "every keyframe: submap, timestamp, id, component, position")
      ->callback([a] { Keyframes(*a); });
  CLI::App* sub = cmd->add_subcommand("submaps", "submap summaries (or one: submaps KEY)");
  sub->add_option("key", a->submap, "front#3, back#0, ...");
  sub->callback([a] { Submaps(*a); });
  CLI::App* grid = cmd->add_subcommand("grid", "the occupancy grid");
  grid->add_option("-o,--out", a->out, "write map_server files: FILE.yaml + FILE.pgm");
  grid->callback([a] { Grid(*a); });
}

}  // namespace rumi::cli
