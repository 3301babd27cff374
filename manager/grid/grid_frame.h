#pragma once
// The grid's frame: metric, gravity aligned, z up, the floor at z = 0. A
// monocular map has neither scale nor "up", so both come from outside:
//
//  - with the robot's pose source (odometry, metric, z up): the Sim(3)
//    Umeyama fit of the map's trajectory to it gives scale and up at once;
//  - else from a ground robot's own motion: its camera moves in a plane
//    parallel to the floor, so up is the normal of the plane fitted to the
//    keyframe centres (signed against the images' "down"), and the scale is
//    the configured camera height over the measured one;
//  - else: no metric grid, and the reason says why.
//
// The floor: with a pose source, its z = 0 (a robot's odometry frame, REP
// 105: z up, the base on the floor); without, the lowest dense layer of map
// points below the cameras (that also gives the scale).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/option_spec.h"
#include "common/timestamp.h"
#include "common/trajectory.h"

namespace rumi {

// One keyframe as the grid sees it: its pose and the map points it observes,
// in the map's frame (any scale).
struct GridKeyframe {
  Timestamp timestamp = 0;
  Se3 T_wc;
  std::vector<Eigen::Vector3d> points;
};

struct GridFrameOptions {
  double camera_height_m = 0;  // camera above the floor: the scale without odometry; 0: not known
  double planar_ratio = 0.2;   // a trajectory is planar when its thinnest spread is below this x its middle one
  double association_s = 0.02;  // odometry pairing (TUM max_diff)
  static const OptionSpec<GridFrameOptions>& Spec();  // keys of section `grid:`
  bool Check(std::string* why = nullptr) const { return Spec().Check(*this, why); }
};

struct GridFrame {
  bool ok = false;
  std::string why;           // when !ok: what is missing
  Sim3 S_gm;                 // map frame -> grid frame
  std::string scale_source;  // "odometry" | "camera_height"
  std::string up_source;     // "odometry" | "trajectory_plane"
  std::string floor_source = "map_points";  // "odometry": its z = 0; "map_points": the lowest dense layer
  double floor_points_share = 0;  // map_points: points in the floor layer / points below the cameras
  double camera_height_m = 0;     // median camera height above the floor, grid frame
  int odometry_pairs = 0;
};

// Odometry given (non-empty): fitted to it; else from the trajectory plane
// and options.camera_height_m.
GridFrame EstimateGridFrame(const std::vector<GridKeyframe>& keyframes, const Trajectory& odometry,
                            const GridFrameOptions& options);

}  // namespace rumi
