#include "manager/map_grid.h"

#include <gtest/gtest.h>

#include <random>

namespace rumi {
namespace {

// A camera 1.4 m above the floor walking along x in a 6 m wide corridor,
// seeing its walls and floor.
std::vector<GridKeyframe> Walk(int n, uint32_t seed = 2) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<GridKeyframe> kfs;
  for (int k = 0; k < n; ++k) {
    GridKeyframe kf;
    kf.timestamp = 1000000000ll + k * 100000000ll;
    const Eigen::Vector3d c(0.1 * k, 0, 1.4);
    kf.T_wc = Se3(Eigen::Quaterniond::Identity(), c);
    for (int i = 0; i < 200; ++i) {
      const double x = c.x() + (u(rng) - 0.5) * 6;
      kf.points.emplace_back(x, u(rng) < 0.5 ? -3.0 : 3.0, u(rng) * 2);  // a wall
      kf.points.emplace_back(x, (u(rng) - 0.5) * 5, 0.0);                // the floor
    }
    kfs.push_back(std::move(kf));
  }
  return kfs;
}

GridFrame Identity() {
  GridFrame f;
  f.ok = true;
  return f;
}

void ExpectSameCells(const OccupancyGrid& a, const OccupancyGrid& b) {
  ASSERT_EQ(a.width(), b.width());
  ASSERT_EQ(a.height(), b.height());
  ASSERT_EQ(a.origin(), b.origin());
  int differ = 0;
  for (int r = 0; r < a.height(); ++r)
    for (int c = 0; c < a.width(); ++c) differ += std::abs(a.log_odds(c, r) - b.log_odds(c, r)) > 1e-4f;
  EXPECT_EQ(differ, 0);
}

TEST(LiveGridTest, NewKeyframesAreAddedAndGiveTheGridOfAFullBuild) {
  const std::vector<GridKeyframe> all = Walk(60);
  const GridOptions o;
  LiveGrid live;
  GridFrame f = Identity();
  live.Update({all.begin(), all.begin() + 40}, &f, o, nullptr);
  EXPECT_FALSE(live.last_incremental());
  EXPECT_EQ(live.last_rebuild_reason(), "first grid");
  f = Identity();
  GridBuildStats stats;
  const OccupancyGrid& g = live.Update(all, &f, o, &stats);
  EXPECT_TRUE(live.last_incremental());
  EXPECT_EQ(live.last_added(), 20);
  EXPECT_EQ(stats.keyframes, 60);
  ExpectSameCells(g, BuildGrid(all, Sim3(), o));
  EXPECT_EQ(live.rebuilds(), 1);
  EXPECT_EQ(live.incremental_updates(), 1);
}

TEST(LiveGridTest, AMovedOrRemovedKeyframeOrAMovedFrameRebuilds) {
  std::vector<GridKeyframe> all = Walk(40);
  GridOptions o;
  o.cells.resolution_m = 0.05;  // the tolerance is 1.25 cm
  LiveGrid live;
  GridFrame f = Identity();
  live.Update(all, &f, o, nullptr);
  // A welding BA nudge of 5 mm: kept.
  all[10].T_wc.translation().x() += 0.005;
  f = Identity();
  live.Update(all, &f, o, nullptr);
  EXPECT_TRUE(live.last_incremental());
  EXPECT_EQ(live.last_added(), 0);
  // A merge moves it by 5 cm: rebuilt, and equal to a full build.
  all[10].T_wc.translation().x() += 0.05;
  f = Identity();
  const OccupancyGrid& g = live.Update(all, &f, o, nullptr);
  EXPECT_FALSE(live.last_incremental());
  EXPECT_EQ(live.last_rebuild_reason(), "a keyframe moved");
  ExpectSameCells(g, BuildGrid(all, Sim3(), o));
  // Culling removes one.
  all.erase(all.begin() + 5);
  f = Identity();
  live.Update(all, &f, o, nullptr);
  EXPECT_EQ(live.last_rebuild_reason(), "a keyframe was removed");
  // The frame estimate moves by 2 mm: the grid's frame is kept (and handed back).
  f = Identity();
  f.S_gm = Sim3(1.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.002, 0, 0));
  live.Update(all, &f, o, nullptr);
  EXPECT_TRUE(live.last_incremental());
  EXPECT_EQ(f.S_gm.translation(), Eigen::Vector3d::Zero());
  // ... by 10 cm: rebuilt in the new frame.
  f.S_gm = Sim3(1.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1, 0, 0));
  const OccupancyGrid& moved = live.Update(all, &f, o, nullptr);
  EXPECT_EQ(live.last_rebuild_reason(), "the grid frame moved");
  ExpectSameCells(moved, BuildGrid(all, f.S_gm, o));
  // A keyframe that sees more points than before (a resend) also rebuilds.
  all[3].points.emplace_back(0.3, 3.0, 1.0);
  live.Update(all, &f, o, nullptr);
  EXPECT_EQ(live.last_rebuild_reason(), "a keyframe sees other points");
}

}  // namespace
}  // namespace rumi
