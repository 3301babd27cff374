#pragma once
// Scores an estimated grid against a true floor plan (both map_server
// grids): the true cells are carried into the estimate's frame by a Sim(3)
// (the estimate's trajectory aligned to the ground truth) and compared where
// both know the cell.
#include <functional>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "manager/grid/grid_file.h"

namespace rumi {

// A true floor plan from a scene's clearance (distance to the nearest
// surface, negative outside the free space), sampled at heights in [z_lo,
// z_hi]: a cell is occupied where a surface passes within half its diagonal
// at some height of the band, unknown where it lies outside the free space
// at some height (behind walls, inside solids), free elsewhere.
MapServerGrid RasterizeFloorPlan(const std::function<double(const Eigen::Vector3d&)>& clearance,
                                 const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, double resolution,
                                 double z_lo, double z_hi);

struct GridScore {
  double occupied_iou = 0;  // |est occ ∩ true occ| / |est occ ∪ true occ|, over the observed true cells
  double free_iou = 0;      // the same for free
  double coverage = 0;      // true free cells the estimate knows (free or occupied) / true free cells
  int true_free = 0, true_occupied = 0, observed = 0;
  // Where the occupied cells disagree: true walls the grid calls free, or
  // does not know; free true cells the grid calls occupied.
  int walls_found = 0, walls_as_free = 0, walls_unknown = 0, false_walls = 0;
};

// One label per true cell (row-major, row 0 = the truth's bottom row), for a
// picture of the comparison.
enum class CellMatch : uint8_t {
  kNotCompared,  // unknown in the truth
  kFreeFound, kFreeUnknown, kFreeAsWall,
  kWallFound, kWallAsFree, kWallUnknown,
};

// S_est_true maps the truth's frame into the estimate's (x, y; z dropped).
// "Observed": true cells (free or occupied) whose estimate is not unknown.
GridScore ScoreGrid(const MapServerGrid& estimate, const MapServerGrid& truth, const Sim3& S_est_true,
                    std::vector<CellMatch>* labels = nullptr);
// The labels as a colour PNG in the truth's frame (first row = largest y).
bool WriteGridComparison(const MapServerGrid& truth, const std::vector<CellMatch>& labels, const std::string& png_path,
                         std::string* why);

}  // namespace rumi
