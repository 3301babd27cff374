#include "manager/odometry_merge.h"

#include <spdlog/spdlog.h>

#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <unordered_map>

#include "common/timestamp.h"

namespace rumi {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

bool Fail(std::string* why, const std::string& msg) {
  if (why) *why = msg;
  return false;
}

// First and last tracked frame of a front submap; false when none.
bool TrackedSpan(const Submap& s, Timestamp* first, Timestamp* last) {
  bool any = false;
  for (const FrameRecord& f : s.frames) {
    if (f.state != TrackingState::kTracking) continue;
    if (!any) *first = *last = f.timestamp;
    *first = std::min(*first, f.timestamp);
    *last = std::max(*last, f.timestamp);
    any = true;
  }
  return any;
}

}  // namespace

std::optional<OdometryFit> FitOdometry(const Submap& s, Timestamp t_begin, Timestamp t_end,
                                       const ManagerOptions& options, std::string* why) {
  std::unordered_map<Timestamp, const Se3*> odom;
  for (const OdometryPose& o : s.odometry) odom[o.timestamp] = &o.T_wb;
  std::vector<Se3> cam, od;  // camera -> submap, camera -> odometry world
  for (const FrameRecord& f : s.frames) {
    if (f.state != TrackingState::kTracking || f.timestamp < t_begin || f.timestamp > t_end) continue;
    const auto it = odom.find(f.timestamp);
    if (it == odom.end()) continue;
    cam.push_back(f.T_wc);
    od.push_back(*it->second);
  }
  const int n = int(cam.size());
  if (n < options.odometry_min_frames) {
    Fail(why, std::to_string(n) + " tracked frames with odometry < " + std::to_string(options.odometry_min_frames));
    return std::nullopt;
  }
  OdometryFit fit;
  fit.frames = n;
  for (int i = 1; i < n; ++i) fit.path_m += (od[i].translation() - od[i - 1].translation()).norm();
  if (fit.path_m < options.odometry_min_path_m) {
    Fail(why, "odometry moved " + std::to_string(fit.path_m) + " m < " + std::to_string(options.odometry_min_path_m) +
                  " m: scale not observable");
    return std::nullopt;
  }
  // Rotation: R_os R_wc_i = R_odom_i for every frame; the chordal mean of
  // R_odom_i R_wc_i^T projected onto SO(3).
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (int i = 0; i < n; ++i) M += od[i].rotation().toRotationMatrix() * cam[i].rotation().toRotationMatrix().transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) D(2, 2) = -1;
  const Eigen::Matrix3d R = svd.matrixU() * D * svd.matrixV().transpose();
  const Eigen::Quaterniond q(R);
  double rot2 = 0;
  for (int i = 0; i < n; ++i) {
    const Eigen::AngleAxisd e((q * cam[i].rotation()).inverse() * od[i].rotation());
    rot2 += e.angle() * e.angle();
  }
  fit.rotation_rmse_deg = std::sqrt(rot2 / n) * kRadToDeg;
  if (fit.rotation_rmse_deg > options.odometry_max_rotation_deg) {
    Fail(why, "rotation residual " + std::to_string(fit.rotation_rmse_deg) + " deg > " +
                  std::to_string(options.odometry_max_rotation_deg) + " deg (camera not where front.odometry_T_bc says?)");
    return std::nullopt;
  }
  // Scale and translation given the rotation: least squares on the centres.
  Eigen::Vector3d mc = Eigen::Vector3d::Zero(), mo = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) mc += cam[i].translation(), mo += od[i].translation();
  mc /= n;
  mo /= n;
  double num = 0, den = 0, spread2 = 0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d c = R * (cam[i].translation() - mc), o = od[i].translation() - mo;
    num += c.dot(o);
    den += c.squaredNorm();
    spread2 += o.squaredNorm();
  }
  fit.spread_m = std::sqrt(spread2 / n);
  if (!(den > 0) || !(num > 0)) {
    Fail(why, "the submap's camera centres do not follow the odometry (scale " + std::to_string(den > 0 ? num / den : 0) + ")");
    return std::nullopt;
  }
  const double scale = num / den;
  fit.S_os = Sim3(scale, q, mo - scale * (R * mc));
  double pos2 = 0;
  for (int i = 0; i < n; ++i) pos2 += (fit.S_os * cam[i].translation() - od[i].translation()).squaredNorm();
  fit.position_rmse_m = std::sqrt(pos2 / n);
  if (fit.position_rmse_m > options.odometry_max_residual * fit.spread_m) {
    Fail(why, "position residual " + std::to_string(fit.position_rmse_m) + " m > " +
                  std::to_string(options.odometry_max_residual) + " x spread " + std::to_string(fit.spread_m) + " m");
    return std::nullopt;
  }
  return fit;
}

MergeReport OdometryMergePair(GlobalMap* map, int a, int b, const ManagerOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  MergeReport r;
  r.kind = "odometry";
  r.front = map->Key(a);
  r.back = map->Key(b);
  r.init_method = "odometry";
  auto reject = [&](const std::string& why) { return RejectMerge(r, "odometry merge", why); };
  if (map->Connected(a, b)) return reject("already connected");
  const Submap &A = map->submap(a), &B = map->submap(b);
  Timestamp a0 = 0, a1 = 0, b0 = 0, b1 = 0;
  if (!TrackedSpan(A, &a0, &a1) || !TrackedSpan(B, &b0, &b1)) return reject("no tracked frames");
  if (b0 <= a1) return reject("the submaps overlap in time");
  const double gap_s = NsToSeconds(b0 - a1);
  if (gap_s > options.odometry_max_gap_s)
    return reject("gap " + std::to_string(gap_s) + " s > " + std::to_string(options.odometry_max_gap_s) + " s");
  const Timestamp window = SecondsToNs(options.odometry_window_s);
  std::string why;
  const auto fa = FitOdometry(A, a1 - window, a1, options, &why);
  if (!fa) return reject(ToString(r.front) + ": " + why);
  const auto fb = FitOdometry(B, b0, b0 + window, options, &why);
  if (!fb) return reject(ToString(r.back) + ": " + why);
  r.common_points = fa->frames + fb->frames;
  r.inliers = r.common_points;
  r.inlier_ratio = 1.0;
  r.S_bf_initial = r.S_bf = fb->S_os.Inverse() * fa->S_os;
  r.seconds_align = SecondsSince(t0);
  r.front_moved = JoinComponents(map, a, b, r.S_bf);
  r.merged = true;
  spdlog::info(
      "odometry merge {} with {} over a {:.2f} s gap ({} side moved): fits on {} + {} frames, odometry path "
      "{:.2f} + {:.2f} m, residual {:.1f} + {:.1f} mm, {:.2f} + {:.2f} deg, scale {:.4f}",
      ToString(r.front), ToString(r.back), gap_s, r.front_moved ? "first" : "second", fa->frames, fb->frames,
      fa->path_m, fb->path_m, 1e3 * fa->position_rmse_m, 1e3 * fb->position_rmse_m, fa->rotation_rmse_deg,
      fb->rotation_rmse_deg, r.S_bf.scale());
  return r;
}

std::vector<MergeReport> OdometryMergeAll(GlobalMap* map, const ManagerOptions& options) {
  std::vector<MergeReport> reports;
  if (!options.odometry_merge) return reports;
  std::vector<std::pair<Timestamp, int>> fronts;  // (first tracked frame, index)
  for (int i = 0; i < int(map->size()); ++i) {
    const Submap& s = map->submap(i);
    Timestamp t0 = 0, t1 = 0;
    if (s.source == SubmapSource::kFront && !s.odometry.empty() && TrackedSpan(s, &t0, &t1)) fronts.push_back({t0, i});
  }
  std::sort(fronts.begin(), fronts.end());
  for (size_t k = 1; k < fronts.size(); ++k) {
    const int a = fronts[k - 1].second, b = fronts[k].second;
    if (!map->Connected(a, b)) reports.push_back(OdometryMergePair(map, a, b, options));
  }
  return reports;
}

}  // namespace rumi
