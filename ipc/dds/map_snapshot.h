#pragma once
// What the DDS server answers from: an immutable copy of the manager's
// product after a rebuild (rumi-manager builds it, manager/map_snapshot_of.h,
// and hands it over by pointer swap; the merge loop never waits on DDS).
// Poses and points are in the global frame of the main component.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/timestamp.h"
#include "common/map_server_grid.h"

namespace rumi {

// The robot link's figures from rumid's status (front.link); present false
// for other sources. The JSON keys are LinkStats::ToJson's.
struct SnapshotLink {
  bool present = false, robot_heard = false, robot_halted = false, robot_failsafe = false, clock_synced = false;
  int rssi_dbm = 0;
  int64_t frames_delivered = 0, frames_dropped = 0, fragments_recovered = 0;
  double latency_p50_ms = 0, latency_p95_ms = 0, latency_max_ms = 0, clock_offset_ms = 0, asked_fps = 0;
  int64_t imu_samples = 0, imu_gaps = 0, gyro_predicted = 0, gyro_bridged = 0;
  bool authenticated = false, insecure = false, halt_alarm = false;
  int64_t auth_failures = 0;
};

// SnapshotLink and the DDS type rumi_dds_LinkStatus name their fields alike:
// one copy serves both directions (map_server.cc, map_client.cc).
template <class From, class To>
void CopyLinkFields(const From& f, To* t) {
  t->present = f.present;
  t->robot_heard = f.robot_heard;
  t->robot_halted = f.robot_halted;
  t->robot_failsafe = f.robot_failsafe;
  t->rssi_dbm = f.rssi_dbm;
  t->frames_delivered = f.frames_delivered;
  t->frames_dropped = f.frames_dropped;
  t->fragments_recovered = f.fragments_recovered;
  t->latency_p50_ms = f.latency_p50_ms;
  t->latency_p95_ms = f.latency_p95_ms;
  t->latency_max_ms = f.latency_max_ms;
  t->clock_synced = f.clock_synced;
  t->clock_offset_ms = f.clock_offset_ms;
  t->asked_fps = f.asked_fps;
  t->imu_samples = f.imu_samples;
  t->imu_gaps = f.imu_gaps;
  t->gyro_predicted = f.gyro_predicted;
  t->gyro_bridged = f.gyro_bridged;
  t->authenticated = f.authenticated;
  t->insecure = f.insecure;
  t->auth_failures = f.auth_failures;
  t->halt_alarm = f.halt_alarm;
}

struct SnapshotStatus {
  std::string instance;
  std::string state;  // starting | running | rebuilding | done | stopping
  int64_t stamp_ns = 0;  // wall clock when built
  int64_t rebuilds = 0;
  int submaps_front = 0, submaps_back = 0, components = 0, keyframes = 0, trajectory_frames = 0;
  int64_t points = 0;
  std::string last_save, grid, json;
  SnapshotLink link;
};

// SnapshotStatus and the DDS type rumi_dds_Status name their fields alike too;
// `text` converts a string field (std::string to the DDS's char* and back).
template <class From, class To, class Text>
void CopyStatusFields(const From& f, To* t, const Text& text) {
  t->instance = text(f.instance);
  t->state = text(f.state);
  t->stamp_ns = f.stamp_ns;
  t->rebuilds = f.rebuilds;
  t->submaps_front = f.submaps_front;
  t->submaps_back = f.submaps_back;
  t->components = f.components;
  t->keyframes = f.keyframes;
  t->points = f.points;
  t->trajectory_frames = f.trajectory_frames;
  t->last_save = text(f.last_save);
  t->grid = text(f.grid);
  t->json = text(f.json);
  CopyLinkFields(f.link, &t->link);
}

struct SnapshotKeyframe {
  int64_t id = -1;
  Timestamp timestamp = 0;
  std::string submap;  // "front#3"
  int component = 0;   // 0: main
  Se3 T_wc;            // camera -> global (of its component)
};

struct SnapshotPose {
  Timestamp timestamp = 0;
  bool from_back = false;
  Se3 T_wc;
};

struct SnapshotSubmap {
  std::string key;
  int component = 0;
  int keyframes = 0;
  int64_t points = 0;
  Timestamp first = 0, last = 0;
  Sim3 S_gl;
};

struct SnapshotGrid {
  bool ok = false;
  MapServerGrid cells;  // map_server values
  std::string yaml;     // grid.yaml as written
  Sim3 S_gm;            // global (main component) -> grid frame (metric, z up)
};

// What happened since the previous snapshot (the events topic).
struct SnapshotEvent {
  std::string kind;  // received | merged | rejected | culled | saved
  std::string submap, other;
  Sim3 S;            // merged: submap -> other
  std::string detail;
};

struct MapSnapshot {
  int64_t seq = 0;  // the rebuild it comes from
  SnapshotStatus status;
  std::vector<Eigen::Vector3f> points;           // main component
  std::vector<SnapshotKeyframe> keyframes;       // main component first
  std::vector<SnapshotPose> trajectory;          // main component, by time
  std::vector<SnapshotSubmap> submaps;
  SnapshotGrid grid;
  std::vector<SnapshotEvent> events;
};

}  // namespace rumi
