#include "manager/map_grid.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fmt/format.h>

#include "manager/grid/grid_file.h"
#include "manager/submap_index.h"

namespace rumi {

std::vector<GridKeyframe> GridKeyframesOf(const GlobalMap& map, int component) {
  std::vector<GridKeyframe> out;
  for (int i : map.Members(component)) {
    const Submap& s = map.submap(i);
    const Sim3& S = map.ToGlobal(i);
    const SubmapIndex index(s);
    for (const Keyframe& k : s.keyframes) {
      GridKeyframe g;
      g.timestamp = k.timestamp;
      g.T_wc = S.TransformPose(k.T_wc());
      for (int64_t id : k.point_ids) {
        const int p = id < 0 ? -1 : index.Point(id);
        if (p >= 0) g.points.push_back(S * s.points[p].position);
      }
      out.push_back(std::move(g));
    }
  }
  std::sort(out.begin(), out.end(),
            [](const GridKeyframe& a, const GridKeyframe& b) { return a.timestamp < b.timestamp; });
  return out;
}

Trajectory OdometryOf(const GlobalMap& map, int component) {
  Trajectory out;
  for (int i : map.Members(component))
    for (const OdometryPose& o : map.submap(i).odometry) out.push_back({o.timestamp, o.T_wb});
  std::sort(out.begin(), out.end(), [](const StampedPose& a, const StampedPose& b) { return a.t < b.t; });
  out.erase(std::unique(out.begin(), out.end(), [](const StampedPose& a, const StampedPose& b) { return a.t == b.t; }),
            out.end());
  return out;
}

const OccupancyGrid& LiveGrid::Update(const std::vector<GridKeyframe>& kfs, GridFrame* f, const GridOptions& o,
                                      GridBuildStats* stats) {
  const auto t0 = std::chrono::steady_clock::now();
  const double tol = o.cells.resolution_m / 4;
  const double tol_rad = 0.1 * M_PI / 180;
  // Keys: the n-th keyframe with a timestamp (a back and a front keyframe
  // may share one).
  std::vector<std::pair<Timestamp, int>> keys(kfs.size());
  for (size_t i = 0; i < kfs.size(); ++i)
    keys[i] = {kfs[i].timestamp, i > 0 && kfs[i - 1].timestamp == kfs[i].timestamp ? keys[i - 1].second + 1 : 0};
  std::string why;
  if (!have_) why = "first grid";
  // The frame: kept when it moves no keyframe by more than the tolerance.
  if (why.empty()) {
    const double angle = S_gm_.rotation().angularDistance(f->S_gm.rotation());
    bool same = angle <= tol_rad && std::abs(S_gm_.scale() / f->S_gm.scale() - 1) < 1e-3;
    for (size_t i = 0; same && i < kfs.size(); ++i)
      same = ((S_gm_ * kfs[i].T_wc.translation()) - (f->S_gm * kfs[i].T_wc.translation())).norm() <= tol;
    if (same) f->S_gm = S_gm_;
    else why = "the grid frame moved";
  }
  std::vector<size_t> fresh;
  if (why.empty()) {
    size_t kept = 0;
    for (size_t i = 0; i < kfs.size() && why.empty(); ++i) {
      auto it = placed_.find(keys[i]);
      if (it == placed_.end()) {
        fresh.push_back(i);
        continue;
      }
      ++kept;
      const Se3 T = S_gm_.TransformPose(kfs[i].T_wc);
      if ((T.translation() - it->second.centre).norm() > tol || T.rotation().angularDistance(it->second.q) > tol_rad ||
          kfs[i].points.size() != it->second.points)
        why = kfs[i].points.size() != it->second.points ? "a keyframe sees other points" : "a keyframe moved";
    }
    if (why.empty() && kept != placed_.size()) why = "a keyframe was removed";
  }
  auto place = [&](size_t i) {
    const Se3 T = S_gm_.TransformPose(kfs[i].T_wc);
    placed_[keys[i]] = {T.translation(), T.rotation(), kfs[i].points.size()};
  };
  if (why.empty()) {
    for (size_t i : fresh) {
      AddKeyframeToGrid(kfs[i], S_gm_, o, &grid_, &stats_);
      place(i);
    }
    last_added_ = static_cast<int>(fresh.size());
    last_incremental_ = true;
    ++incremental_;
  } else {
    S_gm_ = f->S_gm;
    grid_ = BuildGrid(kfs, S_gm_, o, &stats_);
    placed_.clear();
    for (size_t i = 0; i < kfs.size(); ++i) place(i);
    have_ = true;
    last_added_ = static_cast<int>(kfs.size());
    last_incremental_ = false;
    reason_ = why;
    ++rebuilds_;
  }
  stats_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (stats) *stats = stats_;
  return grid_;
}

std::string MapGridResult::Summary() const {
  if (!ok) return why;
  return fmt::format(
      "grid {} x {} cells of {:.3g} m: {:.2f} m^2 free, {:.2f} m^2 occupied; {} keyframes, {} obstacle rays, "
      "{} floor rays, {} points overhead; scale from {}, camera {:.3f} m above the floor; {:.3f} s{}",
      width, height, cells.resolution, free_m2, occupied_m2, stats.keyframes, stats.rays_hit, stats.rays_floor, stats.points_overhead,
      frame.scale_source, frame.camera_height_m, stats.seconds,
      incremental ? fmt::format(" (added {} keyframes)", added)
                  : rebuild_reason.empty() ? "" : " (rebuilt: " + rebuild_reason + ")");
}

bool WriteMapGrid(const GlobalMap& map, const GridOptions& o, const Trajectory& odometry_in,
                  const std::string& out_dir, MapGridResult* r, LiveGrid* live) {
  namespace fs = std::filesystem;
  *r = MapGridResult();
  if (map.size() == 0) {
    r->no_frame = true;
    r->why = "the map holds no submap";
    return false;
  }
  const int component = map.LargestComponent();
  const std::vector<GridKeyframe> kfs = GridKeyframesOf(map, component);
  const Trajectory odometry = odometry_in.empty() ? OdometryOf(map, component) : odometry_in;
  r->frame = EstimateGridFrame(kfs, odometry, o.frame);
  if (!r->frame.ok) {
    r->no_frame = true;
    r->why = "no metric grid: " + r->frame.why;
    return false;
  }
  OccupancyGrid built;
  if (live) {
    live->Update(kfs, &r->frame, o, &r->stats);
    r->incremental = live->last_incremental();
    r->added = live->last_added();
    if (!r->incremental) r->rebuild_reason = live->last_rebuild_reason();
  } else {
    built = BuildGrid(kfs, r->frame.S_gm, o, &r->stats);
  }
  const GridFrame& f = r->frame;
  const OccupancyGrid& grid = live ? live->grid() : built;
  if (grid.width() == 0) {
    r->no_frame = true;
    r->why = "no grid: none of " + std::to_string(r->stats.rays_refused + r->stats.points_overhead) +
             " map points gives a ray (overhead, or farther than max_range_m)";
    return false;
  }
  Trajectory traj;  // the keyframes' path, in the grid frame
  std::vector<Eigen::Vector2d> path;
  for (const GridKeyframe& k : kfs) {
    traj.push_back({k.timestamp, f.S_gm.TransformPose(k.T_wc)});
    path.push_back(traj.back().T_wc.translation().head<2>());
  }
  const auto& q = f.S_gm.rotation();
  const auto& t = f.S_gm.translation();
  const std::vector<std::string> extra = {
      "# rumi: the grid frame is metric, z up, the floor at z = 0",
      "rumi_scale_source: " + f.scale_source,
      "rumi_up_source: " + f.up_source,
      "rumi_floor_source: " + f.floor_source,
      fmt::format("rumi_camera_height_m: {:.4f}", f.camera_height_m),
      fmt::format("rumi_map_to_grid: {{s: {:.9f}, q_xyzw: [{:.9f}, {:.9f}, {:.9f}, {:.9f}], "
                  "t: [{:.6f}, {:.6f}, {:.6f}]}}",
                  f.S_gm.scale(), q.x(), q.y(), q.z(), q.w(), t.x(), t.y(), t.z()),
      fmt::format("rumi_band_m: [{:.3f}, {:.3f}]", o.floor_band_m, o.robot_height_m),
      "rumi_keyframes: " + std::to_string(r->stats.keyframes)};
  const fs::path out = out_dir;
  std::error_code ec;
  fs::create_directories(out, ec);
  r->cells = ToMapServerGrid(grid);
  r->yaml = MapServerYaml(r->cells, "grid.pgm", extra);
  if (!WriteMapServerGrid(r->cells, (out / "grid.pgm").string(), (out / "grid.yaml").string(), extra, &r->why) ||
      !WriteGridPreview(grid, path, (out / "grid.png").string(), &r->why))
    return false;
  try {
    SortOnePosePerTime(&traj);  // a readable trajectory: one pose per time
    WriteTumTrajectory((out / "grid_trajectory.txt").string(), traj);
  } catch (const std::exception& e) {
    r->why = e.what();
    return false;
  }
  int counts[3] = {0, 0, 0};
  for (int row = 0; row < grid.height(); ++row)
    for (int col = 0; col < grid.width(); ++col) ++counts[static_cast<int>(grid.State(col, row))];
  const double cell2 = grid.resolution() * grid.resolution();
  r->width = grid.width();
  r->height = grid.height();
  r->free_m2 = counts[static_cast<int>(CellState::kFree)] * cell2;
  r->occupied_m2 = counts[static_cast<int>(CellState::kOccupied)] * cell2;
  r->ok = true;
  return true;
}

}  // namespace rumi
