#include "manager/grid/occupancy_grid.h"

#include <gtest/gtest.h>

#include <cmath>

namespace rumi {
namespace {

// A camera at the origin looking at a wall along x = 2 (y in [-1, 1]): one
// ray per 2 cm of wall, as from one keyframe.
void ObserveWall(OccupancyGrid* g, const Eigen::Vector2d& cam, int times = 1) {
  for (int t = 0; t < times; ++t)
    for (double y = -1; y <= 1; y += 0.02) EXPECT_TRUE(g->AddRay(cam, {2.0, y}, true));
}

CellState At(const OccupancyGrid& g, double x, double y) {
  int c, r;
  EXPECT_TRUE(g.CellOf({x, y}, &c, &r)) << x << " " << y;
  return g.State(c, r);
}

TEST(OccupancyGrid, AWallSeenFromInFront) {
  OccupancyGrid g;
  ObserveWall(&g, {0, 0}, 3);
  EXPECT_EQ(At(g, 2.01, 0.0), CellState::kOccupied);
  EXPECT_EQ(At(g, 2.01, 0.5), CellState::kOccupied);
  EXPECT_EQ(At(g, 2.01, -0.9), CellState::kOccupied);
  EXPECT_EQ(At(g, 1.0, 0.0), CellState::kFree);
  EXPECT_EQ(At(g, 0.5, 0.2), CellState::kFree);
  EXPECT_EQ(At(g, 1.8, 0.3), CellState::kFree);
  EXPECT_EQ(At(g, 2.5, 0.0), CellState::kUnknown);  // behind the wall
  EXPECT_EQ(At(g, 0.5, 1.5), CellState::kUnknown);  // outside the view
  // Every cell touched is on a ray: none past the wall's reach.
  int occupied = 0;
  for (int r = 0; r < g.height(); ++r)
    for (int c = 0; c < g.width(); ++c)
      if (g.State(c, r) == CellState::kOccupied) {
        ++occupied;
        // Within the band and the range noise (sigma 6.5 cm at 2.2 m) of the wall.
        EXPECT_NEAR(g.CellCentre(c, r).x(), 2.0, 0.2);
      }
  EXPECT_GE(occupied, 38);  // 2 m of wall at 5 cm
}

TEST(OccupancyGrid, FloorPointsAreFreeEvidenceOnly) {
  OccupancyGrid g;
  for (int t = 0; t < 3; ++t)
    for (double y = -1; y <= 1; y += 0.02) EXPECT_TRUE(g.AddRay({0, 0}, {2.0, y}, false));
  EXPECT_EQ(At(g, 1.0, 0.0), CellState::kFree);
  for (int r = 0; r < g.height(); ++r)
    for (int c = 0; c < g.width(); ++c) EXPECT_NE(g.State(c, r), CellState::kOccupied);
}

TEST(OccupancyGrid, GrowingKeepsWhatWasObserved) {
  OccupancyGrid g;
  ObserveWall(&g, {0, 0}, 3);
  const Eigen::Vector2d origin = g.origin();
  const int w = g.width();
  // Far to the lower left: the grid grows, the wall stays where it was.
  for (int t = 0; t < 3; ++t)
    for (double x = -30; x <= -29; x += 0.02) EXPECT_TRUE(g.AddRay({-29.5, -28.5}, {x, -30}, true));
  EXPECT_GT(g.width(), w);
  EXPECT_LT(g.origin().x(), origin.x());
  const double shift = (origin.x() - g.origin().x()) / g.resolution();
  EXPECT_NEAR(shift, std::round(shift), 1e-6);  // the same cell lattice
  EXPECT_EQ(At(g, 2.01, 0.0), CellState::kOccupied);
  EXPECT_EQ(At(g, 1.0, 0.0), CellState::kFree);
  EXPECT_EQ(At(g, -29.5, -30.01), CellState::kOccupied);
}

TEST(OccupancyGrid, ACellChangesItsMind) {
  // A wall that was there and is gone (a door opened): seen through many
  // times, its cells turn free; the clamp keeps that possible.
  OccupancyGrid g;
  ObserveWall(&g, {0, 0}, 20);
  ASSERT_EQ(At(g, 2.01, 0.0), CellState::kOccupied);
  for (int t = 0; t < 20; ++t)
    for (double y = -1; y <= 1; y += 0.02) g.AddRay({0, 0}, {4.0, 2 * y}, true);
  EXPECT_EQ(At(g, 2.01, 0.0), CellState::kFree);
  EXPECT_EQ(At(g, 4.01, 0.0), CellState::kOccupied);
}

TEST(OccupancyGrid, BadRaysAreRefused) {
  OccupancyGridOptions o;
  o.max_range_m = 5;
  o.max_extent_m = 50;
  OccupancyGrid g(o);
  EXPECT_FALSE(g.AddRay({0, 0}, {0, 0}, true));                 // zero length
  EXPECT_FALSE(g.AddRay({0, 0}, {6, 0}, true));                 // too long
  EXPECT_FALSE(g.AddRay({0, 0}, {NAN, 0}, true));               // not finite
  EXPECT_TRUE(g.AddRay({0, 0}, {1, 0}, true));
  EXPECT_FALSE(g.AddRay({1000, 0}, {1001, 0}, true));           // would grow the grid past 50 m
  EXPECT_LT(g.width() * g.resolution(), 50 + 2 * 64 * g.resolution() + 1);
}

// A low box (top at 0.4 m, x in [1, 1.3]) seen from a camera at 1.2 m: a
// few rays end on its top; many more pass over it, higher up, to a wall at
// x = 3. Height slices keep the box; a flat grid lets the rays erase it.
CellState LowBoxUnderRays(double slice_m) {
  OccupancyGridOptions o;
  o.slice_m = slice_m;
  OccupancyGrid g(o, 0.05, 2.0);
  const Eigen::Vector3d cam(0, 0, 1.2);
  for (int t = 0; t < 3; ++t)
    for (double y = -0.2; y <= 0.2; y += 0.02) {
      for (double x = 1.0; x <= 1.3; x += 0.05) EXPECT_TRUE(g.AddRay3d(cam, {x, y, 0.4}, true));
      for (double z = 0.8; z <= 1.6; z += 0.1) EXPECT_TRUE(g.AddRay3d(cam, {3.0, y, z}, true));
    }
  return At(g, 1.12, 0.01);
}

TEST(OccupancyGrid, ARayOverALowObstacleDoesNotEraseIt) {
  EXPECT_EQ(LowBoxUnderRays(0.25), CellState::kOccupied);
  EXPECT_EQ(LowBoxUnderRays(0), CellState::kFree);  // flat: what the slices are for
}

TEST(OccupancyGrid, AColumnIsItsMostOccupiedOrFreestSlice) {
  OccupancyGridOptions o;
  o.slice_m = 0.5;
  OccupancyGrid g(o, 0.0, 2.0);
  ASSERT_EQ(g.slices(), 4);
  // Free at 1.2 m only (a ray passing over), then a hit at 0.3 m in the same column.
  for (int t = 0; t < 5; ++t) EXPECT_TRUE(g.AddRay3d({0, 0, 1.2}, {2.0, 0.01, 1.2}, true));
  EXPECT_EQ(At(g, 1.0, 0.0), CellState::kFree);
  for (int t = 0; t < 5; ++t) EXPECT_TRUE(g.AddRay3d({0, 0, 1.2}, {1.0, 0.01, 0.3}, true));
  EXPECT_EQ(At(g, 1.0, 0.0), CellState::kOccupied);
  // slice_m 0: one value per column (a flat grid).
  o.slice_m = 0;
  OccupancyGrid flat(o, 0.0, 2.0);
  EXPECT_EQ(flat.slices(), 1);
}

TEST(OccupancyGrid, OptionsChecked) {
  OccupancyGridOptions o;
  std::string why;
  EXPECT_TRUE(o.Check(&why)) << why;
  o.ism.p_prior = 0.98;  // above clamp_max: no cell could ever be unknown again
  EXPECT_FALSE(o.Check(&why));
  o = {};
  o.resolution_m = 0;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("resolution_m"), std::string::npos) << why;
  EXPECT_NEAR(OccupancyGridOptions{}.Band(), 0.1 * std::sqrt(2.0), 1e-12);  // a cell's diagonal
}

}  // namespace
}  // namespace rumi
