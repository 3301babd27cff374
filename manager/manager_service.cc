#include "manager/manager_service.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>
#include <unistd.h>

#include "common/atomic_file.h"
#include "common/timestamp.h"
#include "manager/odometry_merge.h"
#include "manager/global_trajectory.h"
#include "ipc/submap_codec.h"
#include "manager/loop_audit.h"
#include "manager/map_file.h"
#include "manager/submap_index.h"
#include "manager/map_grid.h"
#include "manager/sim3_json.h"

namespace rumi {
namespace fs = std::filesystem;

namespace {

nlohmann::json ReportJson(const MergeReport& r) {
  nlohmann::json j = {{"kind", r.kind},
                      {"front", ToString(r.front)},
                      {"back", ToString(r.back)},
                      {"merged", r.merged},
                      {"reason", r.reason},
                      {"keyframe_pairs", r.keyframe_pairs},
                      {"frame_pairs", r.frame_pairs},
                      {"common_points", r.common_points},
                      {"inliers", r.inliers},
                      {"inlier_ratio", r.inlier_ratio},
                      {"init_method", r.init_method},
                      {"refine_initial_rmse_px", r.refine_initial_rmse_px},
                      {"refine_final_rmse_px", r.refine_final_rmse_px},
                      {"front_moved", r.front_moved},
                      {"fused_points", r.fused_points},
                      {"welding_keyframes", r.welding.window_keyframes},
                      {"welding_max_shift", r.welding.max_shift_ratio},
                      {"welding_applied", r.welding.applied},
                      {"welding_initial_rmse_px", r.welding.initial_rmse_px},
                      {"welding_final_rmse_px", r.welding.final_rmse_px},
                      {"seconds_align", r.seconds_align},
                      {"seconds_refine", r.seconds_refine},
                      {"seconds_weld", r.seconds_weld},
                      {"rejected_by", r.rejected_by},
                      {"pose_pairs", r.pose_pairs},
                      {"agreeing_pairs", r.agreeing_pairs},
                      {"pose_angle_deg", r.pose_angle_deg},
                      {"pose_offset_ratio", r.pose_offset_ratio}};
  // Also for a merge rejected after refinement, or by the alignment (then
  // only its candidate): the merge audit (merge_audit.h) measures what
  // accepting it would have done.
  if (r.merged || r.refined)
    j["S_bf"] = Sim3ToJson(r.S_bf);
  else if (r.aligned)
    j["S_bf_initial"] = Sim3ToJson(r.S_bf_initial);
  return j;
}

}  // namespace

std::string ManagerServiceOptions::MapPath() const {
  return map_path.empty() ? (fs::path(out_dir) / "map.rumi").string() : map_path;
}

std::string ManagerServiceOptions::JournalDir() const { return MapPath() + ".received"; }

namespace {
std::string JournalPath(const std::string& dir, const SubmapKey& k) {
  return (fs::path(dir) / ((k.source == SubmapSource::kBack ? "back_" : "front_") + std::to_string(k.id) + ".rsub"))
      .string();
}

}  // namespace

GlobalMap CopyWithout(const GlobalMap& map, const std::vector<SubmapKey>& drop) {
  GlobalMap out;
  std::vector<int> new_index(map.size(), -1);
  std::map<int, int> root_of_component;  // old component -> first kept new index
  for (size_t i = 0; i < map.size(); ++i) {
    if (std::find(drop.begin(), drop.end(), map.Key(int(i))) != drop.end()) continue;
    const int n = out.AddSubmap(map.submap(int(i)));
    out.entry(n).S_gl = map.ToGlobal(int(i));
    new_index[i] = n;
    const auto it = root_of_component.emplace(map.Component(int(i)), n).first;
    out.SetParent(n, it->second);
  }
  for (const FusedPoint& f : map.fused()) {
    if (new_index[f.dup] < 0 || new_index[f.kept] < 0) continue;
    FusedPoint g = f;
    g.dup = new_index[f.dup];
    g.kept = new_index[f.kept];
    out.fused().push_back(g);
  }
  return out;
}

namespace {
// Received submaps that the previous map had joined to submaps of the base
// keep that placement: a front submap is resent while it grows, and the
// partner it merged with may have been baked and culled since, unable to pair
// with it again (a culled back window keeps a few of its keyframes). Its
// fused links to the base go along, for the point ids its new version holds.
void CarryPlacements(const GlobalMap& previous, const std::set<SubmapKey>& received, GlobalMap* map) {
  for (int i = 0; i < int(map->size()); ++i) {
    if (!received.count(map->Key(i))) continue;
    const int old_i = previous.Find(map->Key(i));
    if (old_i < 0) continue;
    std::map<int, int> base_of;  // previous index -> index in *map, the base members of its old component
    for (int m : previous.Members(previous.Component(old_i))) {
      if (received.count(previous.Key(m))) continue;
      const int n = map->Find(previous.Key(m));
      if (n >= 0) base_of[m] = n;
    }
    if (base_of.empty()) continue;
    const auto [partner_old, partner] = *base_of.begin();
    map->entry(i).S_gl =
        map->ToGlobal(partner) * (previous.ToGlobal(partner_old).Inverse() * previous.ToGlobal(old_i));
    map->Union(i, partner);
    const SubmapIndex own(map->submap(i));
    for (const FusedPoint& f : previous.fused()) {
      const bool dup = f.dup == old_i, kept = f.kept == old_i;
      const auto other = base_of.find(dup ? f.kept : kept ? f.dup : -1);
      if (other == base_of.end()) continue;
      if (own.Point(dup ? f.dup_point : f.kept_point) < 0) continue;  // gone from the new version
      FusedPoint g = f;
      (dup ? g.dup : g.kept) = i;
      (dup ? g.kept : g.dup) = other->second;
      map->fused().push_back(g);
    }
  }
}
}  // namespace

ManagerService::ManagerService(ManagerServiceOptions options) : options_(std::move(options)) {}

bool ManagerService::Start(std::string* why) {
  std::error_code ec;
  if (!options_.out_dir.empty()) fs::create_directories(options_.out_dir, ec);
  if (ec) {
    if (why) *why = "cannot create out dir " + options_.out_dir + ": " + ec.message();
    return false;
  }
  while (fs::exists(fs::path(options_.out_dir) / ("merged_" + std::to_string(written_components_) + ".txt")))
    ++written_components_;  // left by an earlier run: rewritten or removed at the next write
  const std::string path = options_.MapPath();
  std::string err;
  if (fs::exists(path)) {
    if (LoadGlobalMap(path, &map_, &err)) {
      stats_.base_submaps = int(map_.size());
      // The loops it closed, and the raw poses its corrected keyframes
      // came with: the next rebuild closes them again without a search.
      loop_state_.memory = map_.loops();
      spdlog::info("manager: reloaded {} ({} submaps)", path, map_.size());
    } else if (!MoveAside(path, err, why)) {
      return false;
    }
  } else {
    spdlog::info("manager: no map file at {}, starting empty", path);
  }
  // The submaps as received, unmerged and unculled: a rebuild needs them
  // (culling removes the back keyframes that pair with new front submaps).
  const std::string raw_path = RawPath();
  if (fs::exists(raw_path)) {
    GlobalMap raw;
    if (LoadGlobalMap(raw_path, &raw, &err)) {
      for (size_t i = 0; i < raw.size(); ++i) received_[raw.Key(int(i))] = raw.submap(int(i));
      spdlog::info("manager: reloaded {} received submaps from {}", raw.size(), raw_path);
      // A submap missing from the map file (no usable map file, or a crash
      // between the two saves): the product must be rebuilt.
      for (size_t i = 0; i < raw.size(); ++i) dirty_ |= map_.Find(raw.Key(int(i))) < 0;
    } else if (!MoveAside(raw_path, err, why)) {
      return false;
    }
  }
  // Submaps received after the last raw save (a manager killed in between):
  // newer than what the raw file holds.
  if (options_.journal) {
    fs::create_directories(options_.JournalDir(), ec);
    if (ec) {
      if (why) *why = "cannot create " + options_.JournalDir() + ": " + ec.message();
      return false;
    }
    for (const auto& e : fs::directory_iterator(options_.JournalDir(), ec)) {
      if (e.path().extension() != ".rsub") continue;
      std::vector<uint8_t> bytes;
      Submap s;
      if (!ReadFileBytes(e.path().string(), &bytes, &err) || !DecodeSubmap(bytes.data(), bytes.size(), &s, &err) ||
          !ValidateSubmap(s, &err)) {
        spdlog::error("manager: journal entry {} does not load ({}); moved aside", e.path().string(), err);
        fs::rename(e.path(), e.path().string() + ".bad", ec);
        continue;
      }
      const SubmapKey key{s.source, s.id};
      received_[key] = std::move(s);
      ++stats_.journal_reloaded;
      dirty_ = raw_dirty_ = true;
    }
    if (stats_.journal_reloaded > 0)
      spdlog::info("manager: reloaded {} submap(s) received after the last save from {}", stats_.journal_reloaded,
                   options_.JournalDir());
  }
  for (const auto& kv : received_) received_at_[kv.first] = std::chrono::steady_clock::now();
  // Until the first rebuild: keyframes received (before culling) and kept.
  for (const auto& kv : received_) stats_.saved_frames += int(kv.second.keyframes.size());
  for (size_t i = 0; i < map_.size(); ++i) stats_.saved_frames_postculled += int(map_.submap(int(i)).keyframes.size());
  if (received_.empty()) stats_.saved_frames = stats_.saved_frames_postculled;
  UpdateCounts();
  return true;
}

std::string ManagerService::RawPath() const { return options_.MapPath() + ".raw"; }

bool ManagerService::MoveAside(const std::string& path, const std::string& error, std::string* why) {
  // Keep the unreadable file for inspection; the next save writes a new one.
  std::string bad = path + ".bad";
  for (int k = 1; fs::exists(bad); ++k) bad = path + ".bad." + std::to_string(k);
  std::error_code ec;
  fs::rename(path, bad, ec);
  if (ec) {
    if (why) *why = path + " does not load (" + error + ") and cannot be moved aside: " + ec.message();
    return false;
  }
  spdlog::error("manager: {}; moved it to {}, not using it", error, bad);
  return true;
}

bool ValidateSubmap(const Submap& s, std::string* why) {
  const auto fail = [&](const std::string& w) {
    if (why) *why = ToString(SubmapKey{s.source, s.id}) + ": " + w;
    return false;
  };
  const auto finite_pose = [](const Se3& T) {
    return T.translation().allFinite() && T.rotation().coeffs().allFinite() &&
           std::abs(T.rotation().norm() - 1.0) < 1e-6;
  };
  if (s.source != SubmapSource::kFront && s.source != SubmapSource::kBack) return fail("source is not front or back");
  if (s.id < 0) return fail("negative id");
  const CameraIntrinsics& c = s.camera;
  if (!(std::isfinite(c.fx) && std::isfinite(c.fy) && std::isfinite(c.cx) && std::isfinite(c.cy)) || c.fx == 0 ||
      c.fy == 0)
    return fail("camera intrinsics unusable");
  std::set<int64_t> ids;
  for (const Keyframe& k : s.keyframes) {
    const std::string kf = "keyframe " + std::to_string(k.id) + ": ";
    if (!ids.insert(k.id).second) return fail(kf + "duplicate keyframe id");
    if (!finite_pose(k.T_cw)) return fail(kf + "pose not finite or not unit");
    if (k.point_ids.size() != k.keypoints.size())
      return fail(kf + std::to_string(k.keypoints.size()) + " keypoints but " + std::to_string(k.point_ids.size()) +
                  " point ids");
    if (!k.octaves.empty() && k.octaves.size() != k.keypoints.size()) return fail(kf + "octaves do not match keypoints");
    if (!k.descriptors.empty() && size_t(k.descriptors.rows) != k.keypoints.size())
      return fail(kf + "descriptor rows do not match keypoints");
    for (const auto& p : k.keypoints)
      if (!p.allFinite()) return fail(kf + "keypoint not finite");
  }
  for (const MapPoint& p : s.points)
    if (!p.position.allFinite()) return fail("map point " + std::to_string(p.id) + " not finite");
  for (const FrameRecord& f : s.frames)
    if (!finite_pose(f.T_wc)) return fail("frame record at " + FormatSeconds(f.timestamp) + ": pose not finite");
  return true;
}

bool ManagerService::AddSubmap(Submap s) {
  const SubmapKey key{s.source, s.id};
  (s.source == SubmapSource::kBack ? stats_.messages_back : stats_.messages_front)++;
  std::string why;
  if (!ValidateSubmap(s, &why)) {
    ++stats_.invalid_submaps;
    spdlog::error("manager: refusing submap {}", why);
    return false;
  }
  if (options_.journal &&
      !WriteFileAtomically(JournalPath(options_.JournalDir(), key), EncodeSubmap(s), &why)) {
    // Not lost yet: it is kept in memory and in the next raw save.
    spdlog::error("manager: cannot journal {}: {}", ToString(key), why);
  }
  if (key.source == SubmapSource::kBack) stats_.back_times.try_emplace(key.id, ManagerStats::BackTimes{WallNowNs(), 0});
  received_fp_.erase(key);
  received_at_[key] = std::chrono::steady_clock::now();
  auto it = received_.find(key);
  if (it != received_.end()) {
    ++stats_.resends;
    spdlog::info("manager: {} received again ({} keyframes, was {}): replaces the earlier version",
                 ToString(key), s.keyframes.size(), it->second.keyframes.size());
    it->second = std::move(s);
  } else {
    spdlog::info("manager: {} received ({} keyframes, {} points, {} frames)", ToString(key), s.keyframes.size(),
                 s.points.size(), s.frames.size());
    received_.emplace(key, std::move(s));
  }
  dirty_ = raw_dirty_ = true;
  return true;
}

void ManagerService::UpdateCounts() {
  stats_.submaps_front = stats_.submaps_back = 0;
  for (size_t i = 0; i < map_.size(); ++i)
    (map_.submap(int(i)).source == SubmapSource::kBack ? stats_.submaps_back : stats_.submaps_front)++;
  stats_.components = int(map_.ComponentsBySize().size());
  stats_.merges = int(map_.size()) - stats_.components;
}

void ManagerService::StampJoinedBackSubmaps() {
  const Timestamp now = WallNowNs();
  for (int root : map_.ComponentsBySize()) {
    const std::vector<int> members = map_.Members(root);
    const bool has_front = std::any_of(members.begin(), members.end(),
                                       [&](int m) { return map_.Key(m).source == SubmapSource::kFront; });
    if (!has_front) continue;
    for (int m : members) {
      const SubmapKey k = map_.Key(m);
      if (k.source != SubmapSource::kBack) continue;
      auto it = stats_.back_times.find(k.id);
      if (it != stats_.back_times.end() && it->second.joined == 0) it->second.joined = now;
    }
  }
}

bool ManagerService::Rebuild(std::string* why, const std::atomic<bool>* cancel,
                             const std::function<void()>& on_rebuilt, bool map_files) {
  const auto t0 = std::chrono::steady_clock::now();
  ManagerStats::Phases phases;
  auto lap = t0;
  const auto time = [&lap](double* phase) {
    const auto now = std::chrono::steady_clock::now();
    *phase = std::chrono::duration<double>(now - lap).count();
    lap = now;
  };
  std::vector<SubmapKey> replaced;
  for (const auto& kv : received_) replaced.push_back(kv.first);
  // The base: the current map without the received submaps, which are added
  // again as they arrived.
  GlobalMap map = CopyWithout(map_, replaced);
  for (const auto& kv : received_) map.AddSubmap(kv.second);
  {
    std::set<SubmapKey> received;
    for (const auto& kv : received_) received.insert(kv.first);
    CarryPlacements(map_, received, &map);
  }
  {
    std::vector<uint64_t> content(map.size(), 0);  // base submaps: hashed by the memo
    for (const auto& [key, submap] : received_) {
      auto [it, inserted] = received_fp_.try_emplace(key, 0);
      if (inserted) it->second = SubmapFingerprint(submap);
      const int i = map.Find(key);
      if (i >= 0) content[size_t(i)] = it->second;
    }
    merge_memo_.SetContentFingerprints(std::move(content));
  }
  // The newest front submap and how far its frames go (a resent snapshot of
  // a submap still being built ends earlier than its finished version).
  int64_t front_upto = -1;
  Timestamp front_upto_end = 0;
  for (const auto& kv : received_)
    if (kv.first.source == SubmapSource::kFront && kv.first.id >= front_upto) {
      front_upto = kv.first.id;
      front_upto_end = kv.second.frames.empty() ? 0 : kv.second.frames.back().timestamp;
    }
  const auto abandoned = [&] {
    if (!(cancel && cancel->load())) return false;
    if (why) *why = "rebuild abandoned: stop requested";
    return true;
  };
  time(&phases.copy);
  std::vector<MergeReport> reports = MergeAll(&map, options_.manager, &merge_memo_, cancel);
  if (abandoned()) return false;
  time(&phases.merge);
  for (MergeReport& r : PlaceMergeAll(&map, options_.manager, &place_memo_, &merge_memo_, cancel))
    reports.push_back(std::move(r));
  if (abandoned()) return false;
  time(&phases.place);
  stats_.reports = std::move(reports);
  stats_.front_submap_upto = front_upto;
  stats_.front_submap_upto_end = front_upto_end;
  for (MergeReport& r : OdometryMergeAll(&map, options_.manager)) stats_.reports.push_back(std::move(r));
  time(&phases.odometry);
  {
    // The received submaps come as they arrived; the base as an earlier
    // rebuild left it, loop corrections applied.
    std::vector<bool> fresh(map.size(), false);
    for (size_t i = 0; i < map.size(); ++i) fresh[i] = received_.count(map.Key(int(i))) > 0;
    stats_.loops = CloseLoops(&map, options_.manager, &loop_state_, &fresh, cancel);
  }
  if (abandoned()) return false;
  int loops_before = 0, loops_waiting = 0;
  for (const LoopReport& l : stats_.loops.loops) {
    // Loops decided at an earlier rebuild were logged then; waiting ones
    // are counted.
    if (l.reason == "closed at an earlier rebuild" || l.reason == "refused at an earlier rebuild") {
      ++loops_before;
      continue;
    }
    if (!l.closed && l.reason.rfind("waits", 0) == 0) {
      ++loops_waiting;
      continue;
    }
    spdlog::info("manager: loop {} kf {} -> {} kf {} ({} keyframes agree, {} inliers): {} ({:.3f}, {:.1f} % of the depth, "
                 "{:.2f} deg)",
                 ToString(l.edge.query_submap), l.edge.query_keyframe, ToString(l.edge.match_submap),
                 l.edge.match_keyframe, l.support, l.edge.inliers, l.closed ? "closed" : "refused: " + l.reason,
                 l.shift, 100 * l.shift_ratio, l.rotation_deg);
  }
  if (loops_before + loops_waiting > 0)
    spdlog::info("manager: {} loops decided at earlier rebuilds, {} waiting for the next (loop_max_solves)",
                 loops_before, loops_waiting);
  time(&phases.loops);
  stats_.merges_replayed = merge_memo_.hits();
  stats_.merge_attempts = int(stats_.reports.size());
  for (const auto& r : stats_.reports) {
    if (r.merged) {
      spdlog::info("manager: merged {} + {}: {} pairs, {} common points, inlier ratio {:.2f}, refine {:.2f} px",
                   ToString(r.front), ToString(r.back), r.keyframe_pairs, r.common_points, r.inlier_ratio,
                   r.refine_final_rmse_px);
    } else {
      spdlog::debug("manager: {} + {} not merged: {}", ToString(r.front), ToString(r.back), r.reason);
    }
  }
  int keyframes = 0;
  for (size_t i = 0; i < map.size(); ++i) keyframes += int(map.submap(int(i)).keyframes.size());
  stats_.saved_frames = keyframes;
  stats_.culling = CullingReport();
  stats_.culling.keyframes_before = stats_.culling.keyframes_after = keyframes;
  if (options_.post_culling) {
    // Revisit fusion searches the received submaps: the base's links are in
    // the map from the rebuilds that had them as received.
    std::vector<bool> received(map.size(), false);
    for (size_t i = 0; i < map.size(); ++i) received[i] = received_.count(map.Key(int(i))) > 0;
    stats_.culling = CullRedundantKeyframes(&map, options_.manager, &received, &revisit_memo_);
    revisit_memo_.Retain(map, received);
  }
  stats_.saved_frames_postculled = stats_.culling.keyframes_after;
  map_ = std::move(map);
  map_dirty_ = true;
  time(&phases.culling);
  stats_.last_rebuild_phases = phases;
  dirty_ = false;
  ++stats_.rebuilds;
  UpdateCounts();
  StampJoinedBackSubmaps();
  stats_.last_rebuild_seconds = SecondsSince(t0);
  spdlog::info("manager: rebuild {} in {:.2f} s: {} submaps, {} components, {} merges, keyframes {} -> {} after culling"
               " ({} merge attempts replayed, {} computed)",
               stats_.rebuilds, stats_.last_rebuild_seconds, map_.size(), stats_.components, stats_.merges,
               stats_.saved_frames, stats_.saved_frames_postculled, merge_memo_.hits(), merge_memo_.misses());
  if (on_rebuilt) on_rebuilt();
  const bool saved = WriteOutputs(why, map_files);
  const ManagerStats::Phases& p = stats_.last_rebuild_phases;
  spdlog::info("manager: rebuild {} phases (s): copy {:.2f}, merge {:.2f}, place {:.2f}, odometry {:.2f}, loops {:.2f}, "
               "culling {:.2f}, save raw {:.2f}, save map {:.2f}, other outputs {:.2f}",
               stats_.rebuilds, p.copy, p.merge, p.place, p.odometry, p.loops, p.culling, p.save_raw, p.save_map,
               p.outputs);
  return saved;
}

int ManagerService::BakeSettled(double min_age_s) {
  if (min_age_s <= 0 || dirty_ || unsaved_ || map_files_pending()) return 0;
  const auto now = std::chrono::steady_clock::now();
  std::vector<SubmapKey> settled;
  for (const auto& kv : received_) {
    const SubmapKey& key = kv.first;
    const auto at = received_at_.find(key);
    const bool old_enough =
        at != received_at_.end() && std::chrono::duration<double>(now - at->second).count() >= min_age_s;
    const bool growing = key.source == SubmapSource::kFront && key.id == stats_.front_submap_upto;
    if (old_enough && !growing && map_.Find(key) >= 0) settled.push_back(key);
  }
  if (settled.empty()) return 0;
  // The raw form stays on disk (map_file.h LoadRawSubmaps): the merge audit
  // needs a submap as received however long the back took.
  std::error_code ec;
  fs::create_directories(RawBakedDir(RawPath()), ec);
  for (const SubmapKey& key : settled) {
    std::string why;
    if (!SaveSubmaps({&received_.at(key)}, RawBakedPath(RawPath(), key), &why)) {
      spdlog::warn("manager: not baking settled submaps now: {}", why);
      return 0;
    }
  }
  for (const SubmapKey& key : settled) {
    received_.erase(key);
    received_fp_.erase(key);
    received_at_.erase(key);
  }
  // The map holds their merged, culled versions and the map file has them;
  // the raw file still holds them until its next save, the baked folder after.
  raw_dirty_ = true;
  stats_.baked += int64_t(settled.size());
  spdlog::info("manager: baked {} settled submap(s) into the base ({} in it, {} received kept raw)", settled.size(),
               map_.size() - received_.size(), received_.size());
  return int(settled.size());
}

bool ManagerService::WriteTrajectories(std::string* why) {
  const std::vector<int> roots = map_.ComponentsBySize();
  const auto write = [&](const std::string& name, const std::vector<GlobalPose>& traj) {
    try {
      WriteTumTrajectory((fs::path(options_.out_dir) / name).string(), ToTrajectory(traj));
    } catch (const std::exception& e) {
      if (why) *why = e.what();
      return false;
    }
    return true;
  };
  stats_.trajectory_frames = 0;
  if (roots.empty() && !write("merged.txt", {})) return false;
  for (size_t k = 0; k < roots.size(); ++k) {
    const auto traj = ComputeGlobalTrajectory(map_, roots[k]);
    if (!write("merged_" + std::to_string(k) + ".txt", traj)) return false;
    if (k == 0) {
      stats_.trajectory_frames = int(traj.size());
      if (!write("merged.txt", traj)) return false;
    }
  }
  // A resend can leave fewer components than before: drop stale files.
  for (int k = int(roots.size()); k < written_components_; ++k)
    std::remove((fs::path(options_.out_dir) / ("merged_" + std::to_string(k) + ".txt")).c_str());
  written_components_ = int(roots.size());
  return true;
}

bool ManagerService::WriteStats(std::string* why) const {
  nlohmann::json j;
  j["merges"] = stats_.merges;
  j["grid"] = stats_.grid;
  j["saved_frames"] = stats_.saved_frames;
  j["saved_frames_postculled"] = stats_.saved_frames_postculled;
  j["baked"] = stats_.baked;
  j["submaps_front"] = stats_.submaps_front;
  j["submaps_back"] = stats_.submaps_back;
  j["components"] = stats_.components;
  j["trajectory_frames"] = stats_.trajectory_frames;
  j["messages_front"] = stats_.messages_front;
  j["messages_back"] = stats_.messages_back;
  j["resends"] = stats_.resends;
  j["decode_errors"] = stats_.decode_errors;
  j["invalid_submaps"] = stats_.invalid_submaps;
  j["rebuilds"] = stats_.rebuilds;
  j["merge_attempts"] = stats_.merge_attempts;
  j["merges_replayed"] = stats_.merges_replayed;
  j["base_submaps"] = stats_.base_submaps;
  j["last_rebuild_seconds"] = stats_.last_rebuild_seconds;
  j["map_saves"] = stats_.map_saves;
  j["last_map_save_seconds"] = stats_.last_map_save_seconds;
  const ManagerStats::Phases& p = stats_.last_rebuild_phases;
  j["last_rebuild_phases_s"] = {{"copy", p.copy},         {"merge", p.merge},       {"place", p.place},
                                {"odometry", p.odometry}, {"loops", p.loops},       {"culling", p.culling},
                                {"save_raw", p.save_raw},
                                {"save_map", p.save_map}, {"outputs", p.outputs}};
  j["journal_reloaded"] = stats_.journal_reloaded;
  j["last_save"] = stats_.last_save;
  j["points_before_culling"] = stats_.culling.points_before;
  j["points_after_culling"] = stats_.culling.points_after;
  j["culled_back"] = stats_.culling.culled_back;
  j["culled_front"] = stats_.culling.culled_front;
  j["culled_revisit"] = stats_.culling.culled_revisit;
  j["culled_revisit_detected"] = stats_.culling.culled_revisit_detected;
  j["revisit_points_fused"] = stats_.culling.revisit_fused;
  j["revisit_keyframes_placed"] = stats_.culling.revisit_keyframes_placed;
  j["revisit_submaps_replayed"] = stats_.culling.revisit_submaps_replayed;
  {
    const LoopClosureReport& l = stats_.loops;
    nlohmann::json loops = nlohmann::json::array();
    for (const LoopReport& r : l.loops)
      loops.push_back(LoopReportToJson(r));
    j["loop_closures"] = l.closed;
    j["loops_waiting"] = l.waiting;
    j["loop_detections"] = l.detections;
    j["loop_keyframes_queried"] = l.keyframes_queried;
    j["loop_candidates_verified"] = l.candidates_verified;
    j["loop_keyframes_moved"] = l.keyframes_moved;
    j["loop_seconds"] = {{"detect", l.seconds_detect}, {"close", l.seconds_close}};
    j["loops"] = loops;
  }
  j["map_file"] = options_.MapPath();
  nlohmann::json comps = nlohmann::json::array();
  const std::vector<int> roots = map_.ComponentsBySize();
  for (size_t k = 0; k < roots.size(); ++k) {
    nlohmann::json members = nlohmann::json::array();
    for (int m : map_.Members(roots[k])) members.push_back(ToString(map_.Key(m)));
    comps.push_back({{"trajectory", "merged_" + std::to_string(k) + ".txt"},
                     {"keyframes", map_.NumKeyframes(roots[k])},
                     {"submaps", members}});
  }
  j["component_list"] = comps;
  nlohmann::json reports = nlohmann::json::array();
  for (const auto& r : stats_.reports) reports.push_back(ReportJson(r));
  j["merge_reports"] = reports;
  nlohmann::json back = nlohmann::json::array();
  const auto wall = [](Timestamp t) { return t == 0 ? nlohmann::json(nullptr) : nlohmann::json(NsToSeconds(t)); };
  for (const auto& [id, t] : stats_.back_times)
    back.push_back({{"id", id}, {"received_wall_s", wall(t.received)}, {"joined_wall_s", wall(t.joined)}});
  j["back_submap_times"] = back;
  return WriteFileAtomically((fs::path(options_.out_dir) / "manager_stats.json").string(), j.dump(2) + "\n", why);
}

bool ManagerService::WriteGrid(std::string* why) {
  if (!options_.grid.enabled || map_.size() == 0) return true;
  MapGridResult r;
  const bool ok = WriteMapGrid(map_, options_.grid, {}, options_.out_dir, &r, &live_grid_);
  if (ok || r.no_frame) grid_ = r;  // a write failure keeps the last grid served
  const std::string before = stats_.grid;
  stats_.grid = r.Summary();
  if (ok || r.no_frame) {  // no metric frame yet (no scale, no floor): not an error; said once
    if (!ok && stats_.grid != before) spdlog::info("manager: no grid yet: {}", r.why);
    return true;
  }
  if (why) *why = "grid: " + r.why;
  return false;
}

double ManagerService::SecondsSinceMapSave() const {
  return stats_.map_saves == 0 ? std::numeric_limits<double>::infinity() : SecondsSince(map_saved_at_);
}

bool ManagerService::WriteOutputs(std::string* why, bool map_files) {
  const bool failed_before = unsaved_;
  unsaved_ = true;  // until every file below is written
  std::string err;
  ManagerStats::Phases& phases = stats_.last_rebuild_phases;
  phases.save_raw = phases.save_map = phases.outputs = 0;
  const auto start = std::chrono::steady_clock::now();
  auto t0 = start;
  if (map_files && raw_dirty_) {
    std::vector<const Submap*> raw;
    for (const auto& kv : received_) raw.push_back(&kv.second);
    if (!SaveSubmaps(raw, RawPath(), &err)) {
      if (why) *why = err;
      return false;
    }
    raw_dirty_ = false;
    if (options_.journal) {  // everything in it is in the raw file now
      std::error_code ec;
      for (const auto& kv : received_) fs::remove(JournalPath(options_.JournalDir(), kv.first), ec);
    }
  }
  phases.save_raw = SecondsSince(t0);
  t0 = std::chrono::steady_clock::now();
  if (map_files && (map_dirty_ || stats_.map_saves == 0)) {  // the first whole save writes it even empty
    if (!SaveGlobalMap(map_, options_.MapPath(), &err)) {
      if (why) *why = err;
      return false;
    }
    map_dirty_ = false;
    stats_.last_save = LocalWallClockText();
  }
  phases.save_map = SecondsSince(t0);
  if (map_files) {
    stats_.last_map_save_seconds = SecondsSince(start);
    ++stats_.map_saves;
    map_saved_at_ = std::chrono::steady_clock::now();
  }
  t0 = std::chrono::steady_clock::now();
  if (!WriteTrajectories(why) || !WriteGrid(why)) return false;
  phases.outputs = SecondsSince(t0);  // the stats file below carries it
  if (!WriteStats(why)) return false;
  unsaved_ = false;
  if (failed_before) spdlog::info("manager: saved again after an earlier failure");
  return true;
}

}  // namespace rumi
