#include "common/trajectory_eval.h"
#include "common/stats.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Eigenvalues>

namespace rumi {
namespace {

Timestamp AbsDiff(Timestamp a, Timestamp b) { return a > b ? a - b : b - a; }

// Index of the element of `sorted` nearest to t; the earlier one on a tie
// (numpy argmin returns the first minimum).
size_t Nearest(const std::vector<Timestamp>& sorted, Timestamp t) {
  const auto it = std::lower_bound(sorted.begin(), sorted.end(), t);
  if (it == sorted.begin()) return 0;
  if (it == sorted.end()) return sorted.size() - 1;
  const size_t hi = static_cast<size_t>(it - sorted.begin());
  return AbsDiff(sorted[hi - 1], t) <= AbsDiff(sorted[hi], t) ? hi - 1 : hi;
}

std::vector<Timestamp> Times(const Trajectory& traj) {
  std::vector<Timestamp> out;
  out.reserve(traj.size());
  for (const StampedPose& p : traj) out.push_back(p.t);
  return out;
}

void RequireIncreasing(const std::vector<Timestamp>& t, const char* what) {
  for (size_t i = 1; i < t.size(); ++i) {
    if (t[i] <= t[i - 1]) {
      throw std::runtime_error(std::string(what) + " timestamps are not strictly increasing at " +
                               std::to_string(i) + " (" + FormatSeconds(t[i]) + " after " +
                               FormatSeconds(t[i - 1]) + ")");
    }
  }
}



// Ground truth on a straight line (a slider, a rail): Umeyama leaves the
// rotation about the line undetermined. The estimate's principal axis is
// turned onto the line, the scale is the 1-D least-squares fit of the
// along-line coordinates, and the free angle about the line is the one that
// best agrees with the orientations (closed form: maximise trace(R M)).
// Position errors do not depend on that angle; estimate positions off the
// estimate's axis still count in full. Returns false when the ground truth
// is not a line or the estimate does not move.
bool LineAlign(const std::vector<Eigen::Vector3d>& p_est, const std::vector<Eigen::Vector3d>& p_gt,
               const std::vector<Eigen::Quaterniond>& q_est, const std::vector<Eigen::Quaterniond>& q_gt,
               bool with_scale, Sim3* S) {
  const size_t n = p_est.size();
  if (n < 3) return false;  // two points are always on a line
  auto principal = [n](const std::vector<Eigen::Vector3d>& p, Eigen::Vector3d* mu, Eigen::Vector3d* eig,
                       Eigen::Vector3d* axis) {
    *mu = Eigen::Vector3d::Zero();
    for (const auto& x : p) *mu += x;
    *mu /= double(n);
    Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
    for (const auto& x : p) c += (x - *mu) * (x - *mu).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(c / double(n));
    *eig = es.eigenvalues();  // ascending
    *axis = es.eigenvectors().col(2);
  };
  Eigen::Vector3d mu_e, mu_g, ev_e, ev_g, u_e, u_g;
  principal(p_est, &mu_e, &ev_e, &u_e);
  principal(p_gt, &mu_g, &ev_g, &u_g);
  // Line: the spread across it is under 0.1 % of the spread along it.
  if (!(ev_g(2) > 1e-20) || ev_g(1) > 1e-6 * ev_g(2) || !(ev_e(2) > 1e-20)) return false;
  double see = 0, seg = 0;
  for (size_t k = 0; k < n; ++k) {
    const double a = (p_est[k] - mu_e).dot(u_e), b = (p_gt[k] - mu_g).dot(u_g);
    see += a * a;
    seg += a * b;
  }
  if (seg < 0) {
    u_e = -u_e;
    seg = -seg;
  }
  const double s = with_scale ? seg / see : 1.0;
  const Eigen::Matrix3d R0 = Eigen::Quaterniond::FromTwoVectors(u_e, u_g).toRotationMatrix();
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (size_t k = 0; k < n; ++k) M += R0 * q_est[k].toRotationMatrix() * q_gt[k].toRotationMatrix().transpose();
  // R(theta) about u_g = cos I + sin [u]x + (1 - cos) u u^T.
  Eigen::Matrix3d ux;
  ux << 0, -u_g.z(), u_g.y(), u_g.z(), 0, -u_g.x(), -u_g.y(), u_g.x(), 0;
  const double A = M.trace() - u_g.dot(M * u_g), B = (ux * M).trace();
  const double th = std::atan2(B, A);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(th, u_g).toRotationMatrix() * R0;
  *S = Sim3(s, Eigen::Quaterniond(R), mu_g - s * R * mu_e);
  return true;
}

}  // namespace

const OptionSpec<AssociationOptions>& AssociationOptions::Spec() {
  using O = AssociationOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("association");
    s->Number("max_diff_s", &O::max_diff_s, AtLeast(0.0), AtMost(1e6), "|t_est - t_gt| of a pair, s");
    s->Flag("one_to_one", &O::one_to_one, "a ground-truth pose pairs at most once");
    return s;
  }();
  return *spec;
}

bool AssociationOptions::Check(std::string* why) const { return Spec().Check(*this, why); }

std::vector<PosePair> AssociateByTimestamp(const Trajectory& est, const Trajectory& gt,
                                           const AssociationOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument("AssociationOptions: " + why);
  const std::vector<Timestamp> te = Times(est), tg = Times(gt);
  RequireIncreasing(te, "estimate");
  RequireIncreasing(tg, "ground truth");
  const Timestamp max_diff = SecondsToNs(options.max_diff_s);
  // As evo: the shorter trajectory drives (the estimate when equally long).
  const bool est_drives = te.size() <= tg.size();
  const std::vector<Timestamp>& drive = est_drives ? te : tg;
  const std::vector<Timestamp>& other = est_drives ? tg : te;
  std::vector<PosePair> pairs;
  if (drive.empty() || other.empty()) return pairs;
  // best[j]: position in `pairs` of the pair currently holding other[j].
  std::vector<long> best(options.one_to_one ? other.size() : 0, -1);
  std::vector<bool> keep;
  for (size_t i = 0; i < drive.size(); ++i) {
    const size_t j = Nearest(other, drive[i]);
    const Timestamp dt = AbsDiff(other[j], drive[i]);
    if (dt > max_diff) continue;
    pairs.push_back(est_drives ? PosePair{i, j} : PosePair{j, i});
    keep.push_back(true);
    if (!options.one_to_one) continue;
    const long k = static_cast<long>(pairs.size()) - 1;
    if (best[j] >= 0) {
      const size_t prev_i = est_drives ? pairs[best[j]].est : pairs[best[j]].gt;
      if (AbsDiff(other[j], drive[prev_i]) <= dt) {
        keep[k] = false;
        continue;
      }
      keep[best[j]] = false;
    }
    best[j] = k;
  }
  std::vector<PosePair> out;
  for (size_t k = 0; k < pairs.size(); ++k) {
    if (keep[k]) out.push_back(pairs[k]);
  }
  // When the ground truth drives, estimate indices still increase with it
  // (nearest-neighbour in time is monotone), but sort to state the contract.
  std::stable_sort(out.begin(), out.end(),
                   [](const PosePair& a, const PosePair& b) { return a.est < b.est; });
  return out;
}

std::vector<PosePair> AssociateByIndex(const Trajectory& est, const Trajectory& gt) {
  std::vector<PosePair> pairs(std::min(est.size(), gt.size()));
  for (size_t i = 0; i < pairs.size(); ++i) pairs[i] = {i, i};
  return pairs;
}

ErrorStats ComputeErrorStats(const std::vector<double>& errors) {
  ErrorStats s;
  s.count = errors.size();
  if (errors.empty()) return s;
  double sum = 0.0;
  s.min = errors[0];
  s.max = errors[0];
  for (double e : errors) {
    sum += e;
    s.sse += e * e;
    s.min = std::min(s.min, e);
    s.max = std::max(s.max, e);
  }
  const double n = static_cast<double>(errors.size());
  s.mean = sum / n;
  s.rmse = std::sqrt(s.sse / n);
  double var = 0.0;
  for (double e : errors) var += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(var / n);
  s.median = Median(errors).value_or(0.0);
  return s;
}

bool ParseAlignment(const std::string& name, Alignment* alignment) {
  if (name == "none") {
    *alignment = Alignment::kNone;
  } else if (name == "se3") {
    *alignment = Alignment::kSe3;
  } else if (name == "sim3") {
    *alignment = Alignment::kSim3;
  } else {
    return false;
  }
  return true;
}

const char* ToString(Alignment alignment) {
  switch (alignment) {
    case Alignment::kNone:
      return "none";
    case Alignment::kSe3:
      return "se3";
    case Alignment::kSim3:
      return "sim3";
  }
  return "?";
}

const OptionSpec<AteOptions>& AteOptions::Spec() {
  using O = AteOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("ate");
    s->Inline(&O::association, AssociationOptions::Spec());
    s->Enum("alignment", &O::alignment,
            {{"none", Alignment::kNone}, {"se3", Alignment::kSe3}, {"sim3", Alignment::kSim3}},
            "alignment before the RMSE");
    s->Flag("match_by_index", &O::match_by_index, "pair by index, not by time (KITTI)");
    return s;
  }();
  return *spec;
}

bool AteOptions::Check(std::string* why) const { return Spec().Check(*this, why); }

AteResult ComputeAte(const Trajectory& est, const Trajectory& gt, const AteOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument("AteOptions: " + why);
  AteResult r;
  r.num_estimate = est.size();
  r.num_ground_truth = gt.size();
  r.alignment = options.alignment;
  r.pairs = options.match_by_index ? AssociateByIndex(est, gt)
                                   : AssociateByTimestamp(est, gt, options.association);
  if (r.pairs.empty()) {
    throw std::runtime_error(
        "no estimate pose has a ground-truth pose within " +
        std::to_string(options.association.max_diff_s) + " s (estimate " +
        (est.empty() ? std::string("empty") : FormatSeconds(est.front().t) + ".." +
                                                  FormatSeconds(est.back().t)) +
        ", ground truth " +
        (gt.empty() ? std::string("empty")
                    : FormatSeconds(gt.front().t) + ".." + FormatSeconds(gt.back().t)) +
        ")");
  }
  std::vector<Eigen::Vector3d> p_est, p_gt;
  p_est.reserve(r.pairs.size());
  p_gt.reserve(r.pairs.size());
  for (const PosePair& pp : r.pairs) {
    p_est.push_back(est[pp.est].T_wc.translation());
    p_gt.push_back(gt[pp.gt].T_wc.translation());
    r.max_abs_dt_s = std::max(r.max_abs_dt_s, NsToSeconds(AbsDiff(est[pp.est].t, gt[pp.gt].t)));
  }
  if (options.alignment != Alignment::kNone) {
    const UmeyamaResult u =
        UmeyamaAlign(p_est, p_gt, /*with_scale=*/options.alignment == Alignment::kSim3);
    if (u.ok) {
      r.S_gt_est = u.transform;
    } else {
      std::vector<Eigen::Quaterniond> q_est, q_gt;
      for (const PosePair& pp : r.pairs) {
        q_est.push_back(est[pp.est].T_wc.rotation());
        q_gt.push_back(gt[pp.gt].T_wc.rotation());
      }
      if (LineAlign(p_est, p_gt, q_est, q_gt, options.alignment == Alignment::kSim3, &r.S_gt_est)) {
        r.line_alignment = true;
      } else {
        throw std::runtime_error(std::string(ToString(options.alignment)) + " alignment failed on " +
                               std::to_string(r.pairs.size()) +
                               " pairs (needs >= 3 non-collinear positions, or ground truth on a "
                               "straight line and an estimate that moves)");
      }
    }
  }
  r.translation_errors.resize(r.pairs.size());
  std::vector<double> rot(r.pairs.size());
  for (size_t k = 0; k < r.pairs.size(); ++k) {
    r.translation_errors[k] = (p_gt[k] - r.S_gt_est * p_est[k]).norm();
    const Eigen::Quaterniond q_err = gt[r.pairs[k].gt].T_wc.rotation().conjugate() *
                                     r.S_gt_est.rotation() * est[r.pairs[k].est].T_wc.rotation();
    rot[k] = RotationAngle(q_err) * 180.0 / M_PI;
  }
  r.translation = ComputeErrorStats(r.translation_errors);
  r.rotation_deg = ComputeErrorStats(rot);
  return r;
}

const OptionSpec<TrackingRateOptions>& TrackingRateOptions::Spec() {
  using O = TrackingRateOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("tracking_rate");
    s->Number("max_gap_factor", &O::max_gap_factor, AtLeast(1.0), AtMost(1e6),
              "a gap longer than this x the median frame interval is not covered");
    s->Number("match_tolerance_s", &O::match_tolerance_s, AtLeast(0.0), AtMost(1e6),
              "pose-to-frame tolerance, s; 0: half the median frame interval");
    return s;
  }();
  return *spec;
}

bool TrackingRateOptions::Check(std::string* why) const { return Spec().Check(*this, why); }

TrackingRate ComputeTrackingRate(const std::vector<Timestamp>& frames,
                                 const std::vector<Timestamp>& tracked,
                                 const TrackingRateOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument("TrackingRateOptions: " + why);
  if (frames.size() < 2) throw std::runtime_error("tracking rate needs at least 2 frames");
  RequireIncreasing(frames, "sequence frame");
  RequireIncreasing(tracked, "tracked");
  TrackingRate r;
  r.num_frames = frames.size();
  const Timestamp first = frames.front(), last = frames.back();
  r.sequence_duration_s = NsToSeconds(last - first);

  std::vector<Timestamp> intervals(frames.size() - 1);
  for (size_t i = 1; i < frames.size(); ++i) intervals[i - 1] = frames[i] - frames[i - 1];
  std::nth_element(intervals.begin(), intervals.begin() + intervals.size() / 2, intervals.end());
  const Timestamp median_dt = intervals[intervals.size() / 2];
  r.median_frame_interval_s = NsToSeconds(median_dt);

  const Timestamp tol =
      options.match_tolerance_s > 0 ? SecondsToNs(options.match_tolerance_s) : median_dt / 2;
  if (!tracked.empty()) {
    for (Timestamp f : frames) {
      if (AbsDiff(tracked[Nearest(tracked, f)], f) <= tol) ++r.num_tracked_frames;
    }
  }
  r.frame_rate = static_cast<double>(r.num_tracked_frames) / static_cast<double>(r.num_frames);

  // Clipped span of [a, b] inside the sequence.
  auto clipped_span = [&](Timestamp a, Timestamp b) {
    return std::max<Timestamp>(0, std::min(b, last) - std::max(a, first));
  };
  Timestamp covered = 0, segments_total = 0;
  if (!tracked.empty()) {
    covered = clipped_span(tracked.front(), tracked.back());
    const double max_gap = options.max_gap_factor * static_cast<double>(median_dt);
    size_t seg_begin = 0;
    for (size_t i = 1; i <= tracked.size(); ++i) {
      if (i == tracked.size() || static_cast<double>(tracked[i] - tracked[i - 1]) > max_gap) {
        segments_total += clipped_span(tracked[seg_begin], tracked[i - 1]);
        ++r.num_segments;
        seg_begin = i;
      }
    }
  }
  r.covered_duration_s = NsToSeconds(covered);
  r.tracked_duration_s = NsToSeconds(segments_total);
  r.covered_rate = r.covered_duration_s / r.sequence_duration_s;
  r.tracked_rate = r.tracked_duration_s / r.sequence_duration_s;
  return r;
}

TrackingRate ComputeTrackingRate(const std::vector<Timestamp>& frames, const Trajectory& tracked,
                                 const TrackingRateOptions& options) {
  return ComputeTrackingRate(frames, Times(tracked), options);
}

}  // namespace rumi
