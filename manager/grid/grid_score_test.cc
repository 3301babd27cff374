#include "manager/grid/grid_score.h"

#include <gtest/gtest.h>

#include <cmath>

namespace rumi {
namespace {

// A 4 x 3 m room (walls 2.5 m high) with a 0.5 m cube in it, as a scene's
// clearance: distance to the nearest wall or the cube, negative outside.
double RoomClearance(const Eigen::Vector3d& p) {
  const double walls = std::min({p.x(), 4 - p.x(), p.y(), 3 - p.y()});
  const Eigen::Vector3d lo(1, 1, 0), hi(1.5, 1.5, 0.5);
  const Eigen::Vector3d d = (lo - p).cwiseMax(p - hi).cwiseMax(0);
  const bool in_cube = (p.array() > lo.array()).all() && (p.array() < hi.array()).all();
  const double cube = in_cube ? -std::min({p.x() - 1, 1.5 - p.x(), p.y() - 1, 1.5 - p.y()}) : d.norm();
  if (walls < 0) return walls;
  return cube < 0 ? cube : std::min(walls, cube);
}

TEST(GridScore, FloorPlanOfARoom) {
  const MapServerGrid t = RasterizeFloorPlan(RoomClearance, {-0.5, -0.5}, {4.5, 3.5}, 0.05, 0.05, 0.6);
  auto at = [&](double x, double y) {
    return t.State(static_cast<int>((x + 0.5) / 0.05), static_cast<int>((y + 0.5) / 0.05));
  };
  EXPECT_EQ(at(2.0, 2.0), CellState::kFree);
  EXPECT_EQ(at(0.01, 1.5), CellState::kOccupied);   // a wall
  EXPECT_EQ(at(1.01, 1.2), CellState::kOccupied);   // the cube's side
  EXPECT_EQ(at(1.25, 1.25), CellState::kUnknown);   // inside the cube
  EXPECT_EQ(at(-0.3, 1.0), CellState::kUnknown);    // behind the wall
  // Above the cube: a band that starts higher sees no cube.
  const MapServerGrid high = RasterizeFloorPlan(RoomClearance, {-0.5, -0.5}, {4.5, 3.5}, 0.05, 0.7, 1.5);
  EXPECT_EQ(high.State(static_cast<int>(1.51 / 0.05), static_cast<int>(1.7 / 0.05)), CellState::kFree);
}

TEST(GridScore, PerfectShiftedAndBlindEstimates) {
  const MapServerGrid t = RasterizeFloorPlan(RoomClearance, {-0.5, -0.5}, {4.5, 3.5}, 0.05, 0.05, 0.6);
  GridScore s = ScoreGrid(t, t, Sim3());
  EXPECT_DOUBLE_EQ(s.occupied_iou, 1.0);
  EXPECT_DOUBLE_EQ(s.free_iou, 1.0);
  EXPECT_DOUBLE_EQ(s.coverage, 1.0);
  EXPECT_GT(s.true_free, 4000);
  EXPECT_GT(s.true_occupied, 200);

  // The same map in another frame (turned 90 deg, moved): scored through the
  // transform that relates the frames, it is still perfect.
  const Sim3 S(1.0, Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ())), {10, -3, 0});
  const MapServerGrid moved = RasterizeFloorPlan(
      [&](const Eigen::Vector3d& p) { return RoomClearance(S.Inverse() * p); }, {6, -3.5}, {10.5, 1.5}, 0.05, 0.05,
      0.6);
  s = ScoreGrid(moved, t, S);
  EXPECT_GT(s.occupied_iou, 0.9);
  EXPECT_GT(s.free_iou, 0.99);
  // Scored without it, the walls no longer agree.
  const GridScore wrong = ScoreGrid(moved, t, Sim3());
  EXPECT_LT(wrong.observed, s.observed / 10);

  // An estimate that saw nothing covers nothing.
  MapServerGrid blind = t;
  std::fill(blind.pixels.begin(), blind.pixels.end(), kPgmUnknown);
  s = ScoreGrid(blind, t, Sim3());
  EXPECT_EQ(s.observed, 0);
  EXPECT_EQ(s.coverage, 0.0);
}

}  // namespace
}  // namespace rumi
