#include "manager/grid/grid_frame.h"

#include "common/stats.h"
#include "common/trajectory_eval.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <map>

namespace rumi {

const OptionSpec<GridFrameOptions>& GridFrameOptions::Spec() {
  using O = GridFrameOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("grid frame");
    s->Number("camera_height_m", &O::camera_height_m, AtLeast(0.0), AtMost(100.0),
              "camera above the floor (the scale without odometry); 0: not known");
    s->Number("planar_ratio", &O::planar_ratio, Above(0.0), Below(1.0),
              "the keyframe centres are planar when their thinnest spread is below this x the middle one");
    s->Number("association_s", &O::association_s, Above(0.0), AtMost(1.0), "odometry pairing window (s)");
    return s;
  }();
  return *spec;
}

namespace {


// Rotation taking `up` to +z (the x axis: `x_hint` made perpendicular).
Eigen::Matrix3d UpToZ(const Eigen::Vector3d& up, const Eigen::Vector3d& x_hint) {
  const Eigen::Vector3d z = up.normalized();
  Eigen::Vector3d x = x_hint - x_hint.dot(z) * z;
  if (x.norm() < 1e-9) x = z.unitOrthogonal();
  x.normalize();
  Eigen::Matrix3d R;
  R.row(0) = x;
  R.row(1) = z.cross(x);
  R.row(2) = z;
  return R;
}

// The floor in a frame whose z is up: the lowest dense layer (bins of `bin`)
// of point heights below the cameras' median height. False when that layer
// holds fewer than 20 points or 5 % of them.
bool FindFloor(const std::vector<GridKeyframe>& kfs, const Sim3& S, double bin, double* floor_z, double* cam_z,
               double* share, std::string* why) {
  std::vector<double> cams;
  for (const auto& k : kfs) cams.push_back((S * k.T_wc.translation()).z());
  *cam_z = UpperMedian(cams);
  std::map<long, int> hist;
  std::vector<double> below;
  for (const auto& k : kfs)
    for (const auto& p : k.points) {
      const double z = (S * p).z();
      if (z < *cam_z && std::isfinite(z)) {
        below.push_back(z);
        ++hist[static_cast<long>(std::floor(z / bin))];
      }
    }
  // The lowest layer at least half as dense as the densest: a table top may
  // hold more points than the visible floor, but it is never below it.
  int densest = 0;
  for (const auto& [b, n] : hist) densest = std::max(densest, n);
  long best = 0;
  for (const auto& [b, n] : hist)  // ascending heights
    if (n >= std::max(20, densest / 2)) {
      best = b;
      break;
    }
  // The layer: that bin and its neighbours (a plane with noise spans a few).
  std::vector<double> layer;
  for (double z : below)
    if (std::abs(z - (best + 0.5) * bin) <= 1.5 * bin) layer.push_back(z);
  *share = below.empty() ? 0 : static_cast<double>(layer.size()) / below.size();
  if (layer.size() < 20 || *share < 0.05) {
    *why = "no floor seen: of " + std::to_string(below.size()) +
           " map points below the cameras, no layer holds 20 and 5 % of them";
    return false;
  }
  *floor_z = UpperMedian(layer);
  return true;
}

}  // namespace

GridFrame EstimateGridFrame(const std::vector<GridKeyframe>& kfs, const Trajectory& odometry,
                            const GridFrameOptions& o) {
  GridFrame f;
  if (kfs.size() < 3) {
    f.why = "too few keyframes (" + std::to_string(kfs.size()) + ") for a grid";
    return f;
  }
  // A ground robot's camera moves in a plane parallel to the floor: its
  // normal is up, sharper than a drifting pose source's z. Signed against
  // the images' "down" (+y).
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& k : kfs) mean += k.T_wc.translation();
  mean /= kfs.size();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  Eigen::Vector3d down = Eigen::Vector3d::Zero();
  for (const auto& k : kfs) {
    const Eigen::Vector3d d = k.T_wc.translation() - mean;
    cov += d * d.transpose();
    down += k.T_wc.rotation() * Eigen::Vector3d::UnitY();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov / kfs.size());
  const Eigen::Vector3d ev = es.eigenvalues().cwiseMax(0).cwiseSqrt();  // spreads, ascending
  const bool planar = ev(1) > 0 && ev(0) <= o.planar_ratio * ev(1);
  Eigen::Vector3d up = es.eigenvectors().col(0);
  if (up.dot(down) > 0) up = -up;

  double odometry_height = 0;  // the camera's median height in the odometry frame
  Sim3 S;  // map -> a frame with z up (metric when the scale is known)
  double bin;
  if (!odometry.empty()) {
    // One pose per time, in time order: a merged map holds a front and a back
    // keyframe of the same frame (generated corridor seed 1: two at
    // 1005.033 s, and the fit refused the map).
    Trajectory keyframes;
    for (const auto& k : kfs) keyframes.push_back({k.timestamp, k.T_wc});
    SortOnePosePerTime(&keyframes);
    AteOptions ate;  // the evaluation's own association and Sim(3) Umeyama
    ate.association.max_diff_s = o.association_s;
    AteResult fit;
    try {
      fit = ComputeAte(keyframes, odometry, ate);
    } catch (const std::exception& e) {
      f.why = std::string("the keyframes do not fit the odometry: ") + e.what();
      return f;
    }
    f.odometry_pairs = static_cast<int>(fit.pairs.size());
    std::vector<double> heights;
    for (const PosePair& p : fit.pairs) heights.push_back(odometry[p.gt].T_wc.translation().z());
    odometry_height = UpperMedian(heights);
    if (!(fit.S_gt_est.scale() > 0)) {
      f.why = "the keyframes do not fit the odometry (scale " + std::to_string(fit.S_gt_est.scale()) + ")";
      return f;
    }
    S = fit.S_gt_est;
    f.scale_source = f.up_source = "odometry";
    if (planar) {  // keep the odometry's scale and heading, take up from the plane
      Eigen::Vector3d up_o = S.R() * up;
      if (up_o.z() < 0) up_o = -up_o;
      const Eigen::Matrix3d R = UpToZ(up_o, Eigen::Vector3d::UnitX());
      S = Sim3(1.0, Eigen::Quaterniond(R), Eigen::Vector3d::Zero()) * S;
      f.up_source = "trajectory_plane";
    }
    bin = 0.02;
  } else {
    if (!planar) {
      f.why = "the camera did not move in a plane (spreads " + std::to_string(ev(0)) + " / " +
              std::to_string(ev(1)) + " / " + std::to_string(ev(2)) +
              "): up is unknown without a pose source";
      return f;
    }
    if (!(o.camera_height_m > 0)) {
      f.why = "no scale: no odometry, and grid.camera_height_m is not set";
      return f;
    }
    const Eigen::Matrix3d R = UpToZ(up, es.eigenvectors().col(2));
    S = Sim3(1.0, Eigen::Quaterniond(R), -(R * mean));
    f.scale_source = "camera_height";
    f.up_source = "trajectory_plane";
    bin = std::max(1e-6, ev(2) / 100);  // map units: a hundredth of the trajectory's extent
  }
  double floor_z = 0, cam_z = 0;
  if (odometry_height > 0) {
    // The pose source's frame has the floor at z = 0 (a robot's odometry
    // frame, REP 105): the camera's height over it is measured there, not
    // searched for among map points (a camera that looks at walls sees
    // little floor).
    std::vector<double> cams;
    for (const auto& k : kfs) cams.push_back((S * k.T_wc.translation()).z());
    cam_z = UpperMedian(cams);
    floor_z = cam_z - odometry_height;
    f.floor_source = "odometry";
  } else if (!FindFloor(kfs, S, bin, &floor_z, &cam_z, &f.floor_points_share, &f.why)) {
    return f;
  }
  if (!(cam_z - floor_z > 0)) {
    f.why = "the floor found is not below the cameras";
    return f;
  }
  double s = 1;
  if (f.scale_source == "camera_height") s = o.camera_height_m / (cam_z - floor_z);
  // Scale about the floor, then put the floor at z = 0.
  f.S_gm = Sim3(s, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, -s * floor_z)) * S;
  f.camera_height_m = s * (cam_z - floor_z);
  f.ok = true;
  return f;
}

}  // namespace rumi
