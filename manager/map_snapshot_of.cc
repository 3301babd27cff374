#include "manager/map_snapshot_of.h"

#include <algorithm>
#include <chrono>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "ipc/daemon_status.h"
#include "manager/global_trajectory.h"

namespace rumi {

std::string StatusDetailJson(const ManagerService& service, const std::string& manager_status_json) {
  nlohmann::json j = {{"manager", nlohmann::json::parse(manager_status_json, nullptr, false)}};
  if (service.options().journal) {  // under rumid: its status file is in the same folder
    nlohmann::json d;
    if (ReadDaemonStatus(service.options().out_dir, &d, nullptr)) j["daemon"] = d;
  }
  return j.dump();
}

SnapshotLink LinkFromStatusJson(const std::string& status_detail_json) {
  SnapshotLink l;
  const nlohmann::json j = nlohmann::json::parse(status_detail_json, nullptr, false);
  if (!j.is_object() || !j.contains("daemon")) return l;
  const nlohmann::json& d = j["daemon"];
  if (!d.is_object() || !d.contains("front") || !d["front"].is_object()) return l;
  const nlohmann::json& k = d["front"].value("link", nlohmann::json());
  if (!k.is_object()) return l;
  // A value of the wrong type reads as its default rather than failing the status.
  auto num = [](const nlohmann::json& o, const char* key) {
    return o.is_object() && o.contains(key) && o[key].is_number() ? o[key].get<double>() : 0.0;
  };
  auto flag = [](const nlohmann::json& o, const char* key) {
    return o.is_object() && o.contains(key) && o[key].is_boolean() && o[key].get<bool>();
  };
  const nlohmann::json none;
  const nlohmann::json& lat = k.contains("latency_ms") ? k["latency_ms"] : none;
  const nlohmann::json& clock = k.contains("clock") ? k["clock"] : none;
  const nlohmann::json& rate = k.contains("rate_control") ? k["rate_control"] : none;
  const nlohmann::json& gyro = k.contains("gyro") ? k["gyro"] : none;
  const nlohmann::json& auth = k.contains("auth") ? k["auth"] : none;
  l.present = true;
  l.robot_heard = flag(k, "robot_heard");
  l.robot_halted = flag(k, "robot_halted");
  l.robot_failsafe = flag(k, "robot_failsafe");
  l.rssi_dbm = static_cast<int>(num(k, "robot_rssi_dbm"));
  l.frames_delivered = static_cast<int64_t>(num(k, "frames_delivered"));
  l.frames_dropped = static_cast<int64_t>(num(k, "frames_dropped") + num(k, "frames_overflow"));
  l.fragments_recovered = static_cast<int64_t>(num(k, "fragments_recovered"));
  l.latency_p50_ms = num(lat, "p50");
  l.latency_p95_ms = num(lat, "p95");
  l.latency_max_ms = num(lat, "max");
  l.clock_synced = flag(clock, "synced");
  l.clock_offset_ms = num(clock, "offset_ms");
  l.asked_fps = num(rate, "asked_fps");
  l.imu_samples = static_cast<int64_t>(num(k, "imu_samples"));
  l.imu_gaps = static_cast<int64_t>(num(k, "imu_gaps"));
  l.gyro_predicted = static_cast<int64_t>(num(gyro, "predicted"));
  l.gyro_bridged = static_cast<int64_t>(num(gyro, "bridged"));
  l.authenticated = flag(auth, "authenticated");
  l.insecure = flag(auth, "insecure");
  l.auth_failures = static_cast<int64_t>(num(auth, "unauthenticated") + num(auth, "failures") +
                                         num(auth, "replays") + num(auth, "wrong_source"));
  l.halt_alarm = flag(k, "halt_alarm");
  return l;
}

void FillMapSnapshot(const GlobalMap& map, MapSnapshot* out) {
  MapSnapshot& s = *out;
  const std::vector<int> roots = map.ComponentsBySize();
  auto component_rank = [&](int i) {
    const int c = map.Component(i);
    for (size_t k = 0; k < roots.size(); ++k)
      if (roots[k] == c) return static_cast<int>(k);
    return -1;
  };
  // Fused duplicates are served once (the kept point).
  std::set<std::pair<int, int64_t>> dups;
  for (const FusedPoint& f : map.fused()) dups.insert({f.dup, f.dup_point});
  for (size_t i = 0; i < map.size(); ++i) {
    const int idx = static_cast<int>(i);
    const Submap& sm = map.submap(idx);
    const Sim3& S = map.ToGlobal(idx);
    const int rank = component_rank(idx);
    SnapshotSubmap sum;
    sum.key = ToString(map.Key(idx));
    sum.component = rank;
    sum.keyframes = static_cast<int>(sm.keyframes.size());
    sum.points = static_cast<int64_t>(sm.points.size());
    if (!sm.keyframes.empty()) {
      sum.first = sm.keyframes.front().timestamp;
      sum.last = sm.keyframes.back().timestamp;
    }
    sum.S_gl = S;
    s.submaps.push_back(sum);
    s.status.keyframes += sum.keyframes;
    for (const Keyframe& k : sm.keyframes) s.keyframes.push_back({k.id, k.timestamp, sum.key, rank, S.TransformPose(k.T_wc())});
    if (rank != 0) continue;
    for (const MapPoint& p : sm.points) {
      if (dups.count({idx, p.id})) continue;
      s.points.push_back((S * p.position).cast<float>());
    }
  }
  std::stable_sort(s.keyframes.begin(), s.keyframes.end(),
                   [](const SnapshotKeyframe& a, const SnapshotKeyframe& b) { return a.component < b.component; });
  s.status.points = static_cast<int64_t>(s.points.size());
  if (map.size() > 0)
    for (const GlobalPose& p : ComputeGlobalTrajectory(map)) s.trajectory.push_back({p.timestamp, p.from_back, p.T_wc});
  s.status.trajectory_frames = static_cast<int>(s.trajectory.size());  // also of a reloaded, unrebuilt map
}

SnapshotStatus SnapshotMaker::MakeStatus(const ManagerService& service, const std::string& state,
                                         const std::string& status_json) const {
  SnapshotStatus s = last_;
  const ManagerStats& st = service.stats();
  s.instance = instance_;
  s.state = state;
  s.stamp_ns = WallNowNs();
  s.rebuilds = st.rebuilds;
  s.last_save = st.last_save;
  s.grid = st.grid;
  s.json = status_json;
  s.link = LinkFromStatusJson(status_json);
  return s;
}

std::shared_ptr<const MapSnapshot> SnapshotMaker::Make(const ManagerService& service, const std::string& state,
                                                       const std::string& status_json) {
  auto snap = std::make_shared<MapSnapshot>();
  MapSnapshot& s = *snap;
  const GlobalMap& map = service.map();
  const ManagerStats& st = service.stats();
  s.seq = ++seq_;
  s.status.instance = instance_;
  s.status.state = state;
  s.status.stamp_ns = WallNowNs();
  s.status.rebuilds = st.rebuilds;
  s.status.submaps_front = st.submaps_front;
  s.status.submaps_back = st.submaps_back;
  s.status.components = st.components;
  s.status.last_save = st.last_save;
  s.status.grid = st.grid;
  s.status.json = status_json;
  s.status.link = LinkFromStatusJson(status_json);

  FillMapSnapshot(map, &s);
  for (const SnapshotSubmap& sum : s.submaps)
    if (submaps_.insert(sum.key).second) s.events.push_back({"received", sum.key, "", Sim3(), ""});

  for (const MergeReport& r : st.reports) {
    const std::pair<std::string, std::string> key{ToString(r.back), ToString(r.front)};
    if (r.merged && merges_.insert(key).second) {
      s.events.push_back({"merged", key.first, key.second, r.S_bf.Inverse(),
                          "inliers " + std::to_string(r.inliers) + ", ratio " + std::to_string(r.inlier_ratio)});
    } else if (!r.merged && r.keyframe_pairs > 0 && rejections_.insert(key).second) {
      s.events.push_back({"rejected", key.first, key.second, Sim3(), r.reason});
    }
  }
  for (const LoopReport& l : st.loops.loops) {
    if (!l.closed) continue;
    const std::string q = ToString(l.edge.query_submap), m = ToString(l.edge.match_submap);
    if (!loops_.insert(q + ":" + std::to_string(l.edge.query_keyframe) + ">" + m + ":" +
                       std::to_string(l.edge.match_keyframe))
             .second)
      continue;
    char detail[160];
    std::snprintf(detail, sizeof(detail), "keyframe %lld -> %lld, %d inliers, %d agree, moved %.3f (%.1f %% of depth), %.2f deg",
                  static_cast<long long>(l.edge.query_keyframe), static_cast<long long>(l.edge.match_keyframe),
                  l.edge.inliers, l.support, l.shift, 100 * l.shift_ratio, l.rotation_deg);
    s.events.push_back({"loop", q, m, l.edge.S_mq, detail});
  }
  const int culled = st.culling.keyframes_before - st.culling.keyframes_after;
  if (culled != culled_ && st.rebuilds > 0) {
    culled_ = culled;
    s.events.push_back({"culled", "", "", Sim3(),
                        std::to_string(culled) + " of " + std::to_string(st.culling.keyframes_before) + " keyframes"});
  }
  if (st.last_save != last_save_ && !st.last_save.empty()) {
    last_save_ = st.last_save;
    s.events.push_back({"saved", "", "", Sim3(), service.options().MapPath()});
  }
  const MapGridResult& g = service.grid();
  if (g.ok) {
    s.grid.ok = true;
    s.grid.cells = g.cells;
    s.grid.yaml = g.yaml;
    s.grid.S_gm = g.frame.S_gm;
  }
  last_ = s.status;
  return snap;
}

}  // namespace rumi
