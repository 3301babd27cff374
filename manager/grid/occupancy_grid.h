#pragma once
// A 2D occupancy grid in log-odds (binary Bayes filter, the grid paper's
// Section 2): each cell holds l = log(p / (1 - p)); an observation adds
// LogOdds(ISM) - LogOdds(prior) to every cell its ray touches, clamped so a
// cell can change its mind later. The grid grows to hold what is observed.
//
// Frame: metric, gravity aligned, z up, the floor at z = 0 (GridFrame maps
// the SLAM map into it); cells are indexed from `origin`, the (x, y) of the
// lower-left corner of cell (0, 0), row index growing with y.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "common/map_server_grid.h"  // CellState
#include "common/option_spec.h"
#include "manager/grid/inverse_sensor_model.h"

namespace rumi {

struct OccupancyGridOptions {
  // Cell side. 0.1 m: monocular map points sit 5-10 cm off their surface at
  // 3-4 m, and 0.05 m cells scored lower on every generated sequence
  // (docs/results/2026-11-25-grid-slices.md, 2026-11-29-grid-cell.md).
  double resolution_m = 0.1;
  double clamp_min = 0.12;     // probability bounds of a cell (log-odds clamped to them)
  double clamp_max = 0.97;
  double max_range_m = 8.0;    // rays to points farther than this are ignored
  double max_extent_m = 500;   // the grid refuses to grow past this side (a wild point)
  double slice_m = 0.25;       // height slices of a column; 0: one (a flat 2D grid)
  InverseSensorModelOptions ism;
  static const OptionSpec<OccupancyGridOptions>& Spec();  // section `grid:` (cells)
  bool Check(std::string* why = nullptr) const { return Spec().Check(*this, why); }
  double Band() const { return ism.band_m > 0 ? ism.band_m : resolution_m * std::sqrt(2.0); }
};

class OccupancyGrid {
 public:
  // Cells are columns over the height band [z_lo, z_hi], cut into slices of
  // options.slice_m: a ray that passes over a low obstacle is free evidence
  // at its own height only, so it cannot erase the obstacle's hits lower down.
  // A column is occupied when one slice is; else it reads as its freest
  // observed slice.
  explicit OccupancyGrid(OccupancyGridOptions options = {}, double z_lo = 0, double z_hi = 0);

  // One ray from `from` (the camera centre on the ground plane) to `to`: with
  // hit, `to` is an obstacle and the full ISM applies (free before it,
  // occupied around it, nothing behind); without, the ray is free evidence up
  // to `to` only (a floor point: no band). False when the ray is ignored
  // (too long, zero length, or it would grow the grid past max_extent_m).
  bool AddRay(const Eigen::Vector2d& from, const Eigen::Vector2d& to, bool hit) {
    return AddRay3d(Eigen::Vector3d(from.x(), from.y(), z_lo_), Eigen::Vector3d(to.x(), to.y(), z_lo_), hit);
  }
  // The same in 3D: each cell's evidence goes to the slice at the ray's
  // height over it.
  bool AddRay3d(const Eigen::Vector3d& from, const Eigen::Vector3d& to, bool hit);

  void Clear();
  int width() const { return width_; }
  int height() const { return height_; }
  double resolution() const { return options_.resolution_m; }
  Eigen::Vector2d origin() const { return origin_; }
  const OccupancyGridOptions& options() const { return options_; }
  // Log-odds of a column (0 = prior): its most occupied slice when that one
  // is above occupied_thresh, else its freest; (col, row) must be inside.
  float log_odds(int col, int row) const;
  int slices() const { return slices_; }
  double probability(int col, int row) const { return Probability(log_odds(col, row) + l0_); }
  // The cell holding a point; false when outside the grid.
  bool CellOf(const Eigen::Vector2d& p, int* col, int* row) const;
  Eigen::Vector2d CellCentre(int col, int row) const;
  // Ternary state with the map_server thresholds.
  CellState State(int col, int row, double occupied_thresh = 0.65, double free_thresh = 0.196) const;
  int64_t cells_updated() const { return cells_updated_; }

 private:
  // Grows the grid (in chunks) so that the box [lo, hi] lies inside.
  bool Cover(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi);

  OccupancyGridOptions options_;
  double l0_, l_min_, l_max_;  // log-odds of prior and clamps; cells store l - l0
  float l_occupied_;           // column log-odds above which a slice makes its column occupied
  double z_lo_ = 0, z_hi_ = 0;
  int slices_ = 1;             // cells_ holds slices_ floats per column
  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
  int width_ = 0, height_ = 0;
  std::vector<float> cells_;
  int64_t cells_updated_ = 0;
};

}  // namespace rumi
