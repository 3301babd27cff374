#include "back/back_result_io.h"

#include <filesystem>
#include <sstream>

#include "common/atomic_file.h"
#include "common/trajectory.h"

namespace rumi {

nlohmann::json SubmapToJson(const Submap& s) {
  using nlohmann::json;
  json j;
  j["format"] = "rumi-submap-debug-json";
  j["version"] = 1;
  j["id"] = s.id;
  j["source"] = s.source == SubmapSource::kBack ? "back" : s.source == SubmapSource::kFront ? "front" : "merged";
  j["camera"] = {{"width", s.camera.width}, {"height", s.camera.height}, {"fx", s.camera.fx},
                 {"fy", s.camera.fy},       {"cx", s.camera.cx},         {"cy", s.camera.cy}};
  json kfs = json::array();
  for (const Keyframe& kf : s.keyframes) {
    const Eigen::Quaterniond& q = kf.T_cw.rotation();
    const Eigen::Vector3d& t = kf.T_cw.translation();
    json kp = json::array(), ids = json::array();
    for (size_t i = 0; i < kf.keypoints.size(); ++i) {
      kp.push_back({kf.keypoints[i].x(), kf.keypoints[i].y()});
      ids.push_back(i < kf.point_ids.size() ? kf.point_ids[i] : -1);
    }
    // Timestamps as integer ns: exact through JSON (int64).
    kfs.push_back({{"id", kf.id},
                   {"timestamp_ns", kf.timestamp},
                   {"T_cw_qwxyz", {q.w(), q.x(), q.y(), q.z()}},
                   {"T_cw_t", {t.x(), t.y(), t.z()}},
                   {"keypoints", kp},
                   {"point_ids", ids}});
  }
  j["keyframes"] = kfs;
  json pts = json::array();
  for (const MapPoint& p : s.points) {
    json obs = json::array();
    for (const auto& o : p.observations) obs.push_back({o.keyframe_id, o.keypoint_index});
    pts.push_back({{"id", p.id},
                   {"xyz", {p.position.x(), p.position.y(), p.position.z()}},
                   {"obs", obs}});
  }
  j["points"] = pts;
  return j;
}

nlohmann::json BackResultSummaryJson(const BackResult& r) {
  using nlohmann::json;
  json j;
  j["window_id"] = r.window_id;
  j["status"] = ToString(r.status);
  j["message"] = r.message;
  j["warnings"] = r.warnings;
  j["num_frames"] = r.num_frames;
  j["num_registered"] = r.num_registered;
  j["retried"] = r.retried;
  j["matched_pairs"] = r.matched_pairs;
  j["filled"] = r.filled;
  j["fill_kept"] = r.fill_kept;
  j["retry_kept"] = r.retry_kept;
  j["seconds"] = {{"undistort_write", r.times.undistort_write_s},
                  {"feature_extraction", r.times.feature_extraction_s},
                  {"matching", r.times.matching_s},
                  {"mapping", r.times.mapping_s},
                  {"read_convert", r.times.read_convert_s},
                  {"total", r.times.total_s}};
  j["cpu_seconds"] = {{"feature_extraction", r.times.feature_extraction_cpu_s},
                      {"matching", r.times.matching_cpu_s},
                      {"mapping", r.times.mapping_cpu_s}};
  json subs = json::array();
  for (size_t i = 0; i < r.submaps.size(); ++i) {
    const BackSubmapStats& s = r.stats[i];
    subs.push_back({{"id", r.submaps[i].id},
                    {"registered_images", s.registered_images},
                    {"num_points", s.num_points},
                    {"num_observations", s.num_observations},
                    {"mean_reprojection_error_px", s.mean_reprojection_error_px},
                    {"mean_track_length", s.mean_track_length}});
  }
  j["submaps"] = subs;
  if (!r.workspace.empty()) j["workspace"] = r.workspace;
  return j;
}

bool WriteBackResult(const BackResult& r, const std::string& dir, std::string* error) {
  auto fail = [error](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return fail("cannot create " + dir + ": " + ec.message());
  auto write = [&](const std::string& name, const std::string& text) {
    std::string why;
    return WriteFileAtomically(dir + "/" + name, text, &why) || fail(why);
  };
  if (!write("result.json", BackResultSummaryJson(r).dump(1) + "\n")) return false;
  for (const Submap& s : r.submaps) {
    const std::string stem = "submap_" + std::to_string(s.id);
    if (!write(stem + ".json", SubmapToJson(s).dump() + "\n")) return false;
    Trajectory traj;
    for (const Keyframe& kf : s.keyframes) traj.push_back({kf.timestamp, kf.T_wc()});
    std::ostringstream tum;
    FormatTumTrajectory(traj, tum);
    if (!write(stem + "_tum.txt", tum.str())) return false;
  }
  return true;
}

}  // namespace rumi
