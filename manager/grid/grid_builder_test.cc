// The grid of a known room, seen from a camera that circles in it, in a map
// with the wrong scale, a tilted "up" and an offset (as a monocular SLAM map
// is): the frame estimate must recover metric, gravity-aligned axes and the
// grid must show the walls where they are and the room free.
#include "manager/grid/grid_builder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace rumi {
namespace {

constexpr double kRoom = 4.0, kCamHeight = 1.0, kWallTop = 2.5;

struct Scene {
  std::vector<Eigen::Vector3d> points;  // world: walls x,y in {0, kRoom}, floor z = 0
  Trajectory truth;                     // camera poses, world
  Sim3 S_mw;                            // world -> map (what SLAM would have)
  std::vector<GridKeyframe> keyframes;  // map frame
};

Scene MakeScene(uint32_t seed) {
  Scene s;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> noise(0, 0.005);
  for (int i = 0; i < 6000; ++i) {
    const double a = u(rng) * kRoom, z = u(rng) * kWallTop;
    const int wall = i % 4;
    Eigen::Vector3d p = wall == 0 ? Eigen::Vector3d(a, 0, z)
                      : wall == 1 ? Eigen::Vector3d(a, kRoom, z)
                      : wall == 2 ? Eigen::Vector3d(0, a, z)
                                  : Eigen::Vector3d(kRoom, a, z);
    s.points.push_back(p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
  }
  for (int i = 0; i < 3000; ++i)  // a textured floor
    s.points.push_back(Eigen::Vector3d(u(rng) * kRoom, u(rng) * kRoom, noise(rng)));
  // A small obstacle (a box 0.4 m high) in a corner of the room.
  for (int i = 0; i < 300; ++i)
    s.points.push_back(Eigen::Vector3d(0.6 + 0.3 * u(rng), 0.6 + 0.3 * u(rng), 0.4 + noise(rng)));
  const Eigen::Quaterniond tilt(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, -1, 0.5).normalized()));
  s.S_mw = Sim3(0.37, tilt, Eigen::Vector3d(2, -1, 0.5));
  for (int k = 0; k < 60; ++k) {
    // The camera circles (radius 1 m) about the room's centre, looking
    // outwards, level: camera z = heading, camera y = world -z (image down).
    const double a = 2 * M_PI * k / 60, h = a + 0.3 * std::sin(3 * a);
    const Eigen::Vector3d c(kRoom / 2 + std::cos(a), kRoom / 2 + std::sin(a), kCamHeight);
    Eigen::Matrix3d R_wc;
    R_wc.col(2) = Eigen::Vector3d(std::cos(h), std::sin(h), 0);
    R_wc.col(1) = Eigen::Vector3d(0, 0, -1);
    R_wc.col(0) = R_wc.col(1).cross(R_wc.col(2));
    const Se3 T_wc(Eigen::Quaterniond(R_wc), c);
    s.truth.push_back({static_cast<Timestamp>(k) * 100000000, T_wc});
    GridKeyframe kf;
    kf.timestamp = s.truth.back().t;
    kf.T_wc = s.S_mw.TransformPose(T_wc);
    for (const auto& p : s.points) {
      const Eigen::Vector3d pc = R_wc.transpose() * (p - c);
      if (pc.z() > 0.2 && std::abs(pc.x()) < pc.z() && std::abs(pc.y()) < 0.75 * pc.z())
        kf.points.push_back(s.S_mw * p);
    }
    s.keyframes.push_back(std::move(kf));
  }
  return s;
}

// Share of the probes (world) whose grid cell is in `state`.
double Share(const OccupancyGrid& g, const Sim3& S_gw, const std::vector<Eigen::Vector3d>& probes, CellState state) {
  int n = 0;
  for (const auto& p : probes) {
    int c, r;
    if (g.CellOf((S_gw * p).head<2>(), &c, &r) && g.State(c, r) == state) ++n;
  }
  return static_cast<double>(n) / probes.size();
}

void CheckGrid(const Scene& s, const GridFrame& f, const GridOptions& o) {
  ASSERT_TRUE(f.ok) << f.why;
  const Sim3 S_gw = f.S_gm * s.S_mw;
  // Metric, z up, floor at 0.
  EXPECT_NEAR(S_gw.scale(), 1.0, 0.02);
  EXPECT_NEAR((S_gw.R() * Eigen::Vector3d::UnitZ()).z(), 1.0, 1e-3);
  EXPECT_NEAR((S_gw * Eigen::Vector3d(1, 1, 0)).z(), 0.0, 0.02);
  EXPECT_NEAR(f.camera_height_m, kCamHeight, 0.02);

  GridBuildStats stats;
  const OccupancyGrid g = BuildGrid(s.keyframes, f.S_gm, o, &stats);
  EXPECT_EQ(stats.keyframes, 60);
  EXPECT_GT(stats.rays_hit, 0);
  EXPECT_GT(stats.rays_floor, 0);
  EXPECT_GT(stats.points_overhead, 0);  // wall points above the robot
  std::vector<Eigen::Vector3d> walls, inside, box;
  for (double a = 0.3; a <= kRoom - 0.3; a += 0.1) {
    walls.push_back({a, 0.01, 0});
    walls.push_back({a, kRoom - 0.01, 0});
    walls.push_back({0.01, a, 0});
    walls.push_back({kRoom - 0.01, a, 0});
  }
  // The ring between the camera's circle and the walls (it looks outwards).
  for (double x = 0.3; x <= kRoom - 0.3; x += 0.1)
    for (double y = 0.3; y <= kRoom - 0.3; y += 0.1) {
      const double d = std::hypot(x - kRoom / 2, y - kRoom / 2);
      if (d > 1.2 && (std::abs(x - 0.75) > 0.5 || std::abs(y - 0.75) > 0.5)) inside.push_back({x, y, 0});
    }
  for (double x = 0.65; x <= 0.85; x += 0.05)
    for (double y = 0.65; y <= 0.85; y += 0.05) box.push_back({x, y, 0});
  const double walls_occ = Share(g, S_gw, walls, CellState::kOccupied);
  const double inside_free = Share(g, S_gw, inside, CellState::kFree);
  const double box_occ = Share(g, S_gw, box, CellState::kOccupied);
  std::printf("walls occupied %.2f, inside free %.2f, box occupied %.2f (%s scale)\n", walls_occ, inside_free,
              box_occ, f.scale_source.c_str());
  EXPECT_GT(walls_occ, 0.8);
  EXPECT_GT(inside_free, 0.9);
  EXPECT_GT(box_occ, 0.1);  // its top seen from one side, partly out of view
  // Outside the room nothing was seen through the walls.
  std::vector<Eigen::Vector3d> outside;
  for (double a = 0.3; a <= kRoom - 0.3; a += 0.1) outside.push_back({a, -0.5, 0});
  EXPECT_LT(Share(g, S_gw, outside, CellState::kFree), 0.05);
}

TEST(GridBuilder, CameraHeightGivesScaleAndTheTrajectoryGivesUp) {
  const Scene s = MakeScene(1);
  GridOptions o;
  o.frame.camera_height_m = kCamHeight;
  const GridFrame f = EstimateGridFrame(s.keyframes, {}, o.frame);
  EXPECT_EQ(f.scale_source, "camera_height");
  EXPECT_EQ(f.up_source, "trajectory_plane");
  CheckGrid(s, f, o);
}

TEST(GridBuilder, OdometryGivesScaleAndUp) {
  const Scene s = MakeScene(2);
  GridOptions o;  // no camera height: odometry is enough
  const GridFrame f = EstimateGridFrame(s.keyframes, s.truth, o.frame);
  EXPECT_EQ(f.scale_source, "odometry");
  EXPECT_EQ(f.odometry_pairs, 60);
  CheckGrid(s, f, o);
}

// A merged map holds a front and a back keyframe of one frame, in any
// order: the odometry fit takes one pose per time (it refused the map of
// generated corridor seed 1, "timestamps are not strictly increasing").
TEST(GridBuilder, OdometryFitsKeyframesOfOneFrameFromTwoSubmaps) {
  Scene s = MakeScene(2);
  std::vector<GridKeyframe> kfs = s.keyframes;
  kfs.push_back(kfs[10]);  // the back's keyframe of frame 10
  std::swap(kfs[3], kfs[20]);
  GridOptions o;
  const GridFrame f = EstimateGridFrame(kfs, s.truth, o.frame);
  EXPECT_TRUE(f.why.empty()) << f.why;
  EXPECT_EQ(f.scale_source, "odometry");
  EXPECT_EQ(f.odometry_pairs, 60);
}

TEST(GridBuilder, NoScaleNoGridAndTheReasonSaysWhy) {
  Scene s = MakeScene(3);
  GridOptions o;
  GridFrame f = EstimateGridFrame(s.keyframes, {}, o.frame);
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.why.find("camera_height_m"), std::string::npos) << f.why;
  // A hand-held camera (not planar): up unknown without a pose source.
  o.frame.camera_height_m = kCamHeight;
  for (size_t k = 0; k < s.keyframes.size(); ++k) {
    Eigen::Vector3d c = s.truth[k].T_wc.translation();
    c.z() += 0.8 * std::sin(0.5 * k);
    s.keyframes[k].T_wc = s.S_mw.TransformPose(Se3(s.truth[k].T_wc.rotation(), c));
  }
  f = EstimateGridFrame(s.keyframes, {}, o.frame);
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.why.find("plane"), std::string::npos) << f.why;
  // Odometry with other timestamps: nothing pairs.
  Trajectory far = s.truth;
  for (auto& p : far) p.t += 50000000;
  f = EstimateGridFrame(MakeScene(3).keyframes, far, o.frame);
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.why.find("odometry"), std::string::npos) << f.why;
}

TEST(GridBuilder, OptionsChecked) {
  GridOptions o;
  std::string why;
  EXPECT_TRUE(o.Check(&why)) << why;
  o.robot_height_m = 0.01;
  EXPECT_FALSE(o.Check(&why));
  o = {};
  o.cells.ism.p_occ = 0.2;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("p_"), std::string::npos) << why;
}

}  // namespace
}  // namespace rumi
