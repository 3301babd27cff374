#include "manager/grid/grid_score.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

namespace rumi {
namespace {

// A 4 x 3 m room (walls 2.5 m high) with a box 0.5 x 0.5 x 0.8 m in it, as a
// scene's clearance: distance to the nearest wall or the box, negative
// outside (inside the box: to its nearest side).
double RoomClearance(const Eigen::Vector3d& p) {
  const double walls = std::min({p.x(), 4 - p.x(), p.y(), 3 - p.y()});
  const Eigen::Vector3d lo(1, 1, 0), hi(1.5, 1.5, 0.8);
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
  const MapServerGrid high = RasterizeFloorPlan(RoomClearance, {-0.5, -0.5}, {4.5, 3.5}, 0.05, 0.9, 1.5);
  EXPECT_EQ(high.State(static_cast<int>(1.51 / 0.05), static_cast<int>(1.7 / 0.05)), CellState::kFree);
  // Coarse cells: the floor, below the band, is never a wall, however large
  // the cell's tolerance (half its diagonal, 7 cm here, past the band's 5 cm).
  const MapServerGrid coarse = RasterizeFloorPlan(RoomClearance, {-0.5, -0.5}, {4.5, 3.5}, 0.1, 0.05, 0.6);
  EXPECT_EQ(coarse.State(static_cast<int>(2.5 / 0.1), static_cast<int>(2.5 / 0.1)), CellState::kFree);
  EXPECT_EQ(coarse.State(static_cast<int>(0.51 / 0.1), static_cast<int>(2.0 / 0.1)), CellState::kOccupied);
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
  EXPECT_EQ(s.walls_unknown, s.true_occupied);
}

TEST(GridScore, TheComparisonSaysWhereTheGridsDisagree) {
  const MapServerGrid t = RasterizeFloorPlan(RoomClearance, {-0.5, -0.5}, {4.5, 3.5}, 0.05, 0.05, 0.6);
  // The estimate: walls called free where y > 2 m (a row index counts from
  // the bottom, pixel rows from the top), free cells called walls at x < 2 m.
  MapServerGrid e = t;
  int moved_walls = 0, false_walls = 0;
  for (int row = 0; row < t.height; ++row)
    for (int col = 0; col < t.width; ++col) {
      uint8_t& px = e.pixels[static_cast<size_t>(t.height - 1 - row) * t.width + col];
      const double x = t.origin.x() + (col + 0.5) * 0.05, y = t.origin.y() + (row + 0.5) * 0.05;
      if (px == kPgmOccupied && y > 2.0) {
        px = kPgmFree;
        ++moved_walls;
      } else if (px == kPgmFree && x < 2.0 && y < 0.5) {
        px = kPgmOccupied;
        ++false_walls;
      }
    }
  std::vector<CellMatch> labels;
  const GridScore s = ScoreGrid(e, t, Sim3(), &labels);
  EXPECT_EQ(s.walls_as_free, moved_walls);
  EXPECT_EQ(s.false_walls, false_walls);
  EXPECT_EQ(s.walls_found, s.true_occupied - moved_walls);
  EXPECT_EQ(s.walls_unknown, 0);
  ASSERT_EQ(labels.size(), t.pixels.size());
  EXPECT_EQ(std::count(labels.begin(), labels.end(), CellMatch::kWallAsFree), moved_walls);
  EXPECT_EQ(std::count(labels.begin(), labels.end(), CellMatch::kFreeAsWall), false_walls);
  EXPECT_GT(std::count(labels.begin(), labels.end(), CellMatch::kNotCompared), 0);  // behind the walls
  const std::string png = ::testing::TempDir() + "grid_comparison.png";
  std::string why;
  ASSERT_TRUE(WriteGridComparison(t, labels, png, &why)) << why;
  EXPECT_GT(std::filesystem::file_size(png), 100u);
  EXPECT_FALSE(WriteGridComparison(t, {}, png, &why));
}

}  // namespace
}  // namespace rumi
