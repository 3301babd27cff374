#include "common/synth/synthetic_sequence.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "common/imu.h"
#include "common/imu_synth.h"

namespace rumi {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

double Unit(uint64_t h) { return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0); }

double SmoothStep01(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

// Camera orientation (x right, y down, z forward) from yaw/pitch about world
// z-up, then roll about the optical axis.
Eigen::Matrix3d LookRotation(double yaw, double pitch, double roll) {
  const Eigen::Vector3d f(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw),
                          std::sin(pitch));
  const Eigen::Vector3d x = f.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = f.cross(x);
  Eigen::Matrix3d R;
  R.col(0) = std::cos(roll) * x + std::sin(roll) * y;
  R.col(1) = -std::sin(roll) * x + std::cos(roll) * y;
  R.col(2) = f;
  return R;
}

constexpr double kRoomLx = 8.0, kRoomLy = 6.0, kRoomH = 3.0;
constexpr double kEyeHeight = 1.35;

}  // namespace

SyntheticSequence::SyntheticSequence(const SynthOptions& options) : o_(options) {
  std::string why;
  if (!o_.Check(&why)) throw std::invalid_argument("synth options: " + why);
  cam_.width = o_.width;
  cam_.height = o_.height;
  // 525 px at 640 wide (about 63 deg horizontal field of view), square pixels.
  cam_.fx = cam_.fy = 525.0 * o_.width / 640.0;
  cam_.cx = (o_.width - 1) / 2.0;
  cam_.cy = (o_.height - 1) / 2.0;
  if (o_.scenario != SynthScenario::kSmooth) {
    hard_begin_ = o_.HardStart();
    hard_end_ = hard_begin_ + o_.HardLength();
    t_hard0_ = hard_begin_ / o_.fps;
    t_hard1_ = (hard_end_ - 1) / o_.fps;
    stretches_ = o_.HardStretches();
    period_s_ = o_.hard_period > 0 ? o_.hard_period / o_.fps : 0.0;
  }
  BuildTrajectory();
}

void SyntheticSequence::BuildTrajectory() {
  const uint64_t rs = SynthHash(o_.seed, 0x7a0);
  for (int k = 0; k < 8; ++k) ph_[k] = 2 * kPi * Unit(SynthHash(rs, k));
  if (o_.scenario == SynthScenario::kCorridor) {
    const double duration = (o_.frames - 1) / o_.fps;
    const double d1 = CorridorTravel(t_hard0_);
    const double d2 = CorridorTravel(std::max(0.0, duration - t_hard1_));
    // Legs at least 12 m long: the camera starts well inside leg A.
    cor_la_ = std::max(12.0, 1.0 + d1 + cor_r_ + cor_w_ / 2);
    cor_x0_ = cor_la_ - cor_w_ / 2 - cor_r_ - d1;
    cor_lb_ = std::max(12.0, cor_w_ / 2 + cor_r_ + d2 + 1.5);
    scene_ = BuildCorridorScene(o_.seed, cor_la_, cor_lb_, cor_w_, 1.5);
    scene_.quiet_amplitude = o_.weak_amplitude;
    exposure_scale_ = 1.2;
    return;
  }
  scene_ = BuildRoomScene(o_.seed, kRoomLx, kRoomLy, kRoomH);
  exposure_scale_ = 1.1;
  orbit_center_ = Eigen::Vector3d(kRoomLx / 2, kRoomLy / 2, kEyeHeight);
  phi0_ = 2 * kPi * Unit(SynthHash(rs, 100));
  orbit_dir_ = Unit(SynthHash(rs, 101)) < 0.5 ? -1.0 : 1.0;
  loop_s_ = 24.0;
  if (o_.scenario == SynthScenario::kWeak) {
    // Mid-stretch the orbit is at an end of its long axis, nearest to a wall.
    const double tm = 0.5 * (t_hard0_ + t_hard1_);
    phi0_ = (Unit(SynthHash(rs, 102)) < 0.5 ? 0.0 : kPi) - orbit_dir_ * 2 * kPi * tm / loop_s_;
  }
  if (o_.scenario == SynthScenario::kWeak) {
    // Find the wall the camera faces mid-stretch; paint it plain around the
    // hit point, clear furniture there, and park the camera in front of it.
    const double tm = 0.5 * (t_hard0_ + t_hard1_);
    const Se3 base = BasePose(Phase(tm));
    Eigen::Vector3d f = base.R().col(2);
    f.z() = 0;
    f.normalize();
    Eigen::Vector3d o = base.translation();
    double best = 1e9;
    int axis = 0;
    for (const SynthQuad& q : scene_.quads) {
      if (q.axis == 2 || std::abs(f[q.axis]) < 1e-9) continue;
      const double t = (q.offset - o[q.axis]) / f[q.axis];
      if (t > 0 && t < best) {
        best = t;
        axis = q.axis;
      }
    }
    Eigen::Vector3d p = o + best * f;
    const int along = 1 - axis;  // horizontal in-wall axis (0 or 1)
    const double len = along == 0 ? kRoomLx : kRoomLy;
    p[along] = std::clamp(p[along], 1.3, len - 1.3);
    p.z() = kEyeHeight;
    Eigen::Vector3d n_in = Eigen::Vector3d::Zero();
    n_in[axis] = p[axis] < 1.0 ? 1.0 : -1.0;
    scene_.quiet_zones.push_back({p, 1.6, 0.4});
    scene_.quiet_amplitude = o_.weak_amplitude;
    std::vector<SynthBox> kept;
    for (const SynthBox& b : scene_.boxes) {
      Eigen::Vector3d q = p;
      q.z() = 0.5 * (b.lo.z() + b.hi.z());
      double d2 = 0;
      for (int k = 0; k < 3; ++k) {
        const double d = std::max({b.lo[k] - q[k], 0.0, q[k] - b.hi[k]});
        d2 += d * d;
      }
      if (std::sqrt(d2) > 2.2) kept.push_back(b);
    }
    scene_.boxes = kept;
    const double yaw = std::atan2(-n_in.y(), -n_in.x());
    weak_target_ = Se3(LookRotation(yaw, -0.05, 0.0), p + o_.weak_distance * n_in);
    weak_tangent_ = Eigen::Vector3d::Zero();
    weak_tangent_[along] = 1.0;
    // Approach slowly enough: smoothstep peaks at 1.5x the mean speed.
    double ramp = 1.0;
    for (double t : {t_hard0_, t_hard1_}) {
      const Se3 b = BasePose(Phase(t));
      const double dist = (b.translation() - weak_target_.translation()).norm() + 0.25;
      const double ang = RotationAngle(b.rotation().inverse() * weak_target_.rotation());
      ramp = std::max({ramp, 1.5 * dist / 0.8, 1.5 * ang / (40.0 * kDeg)});
    }
    weak_ramp_ = std::min(ramp, 2.5);
  }
}

bool SyntheticSequence::in_hard_stretch(int i) const {
  if (hard_end_ <= hard_begin_ || i < hard_begin_) return false;
  if (o_.hard_period <= 0) return i < hard_end_;
  return (i - hard_begin_) / o_.hard_period < stretches_ && (i - hard_begin_) % o_.hard_period < hard_end_ - hard_begin_;
}

int SyntheticSequence::StretchStartedBy(double t) const {
  if (period_s_ <= 0) return 0;
  const int k = static_cast<int>(std::floor((t - (t_hard0_ - 0.5 / o_.fps)) / period_s_));
  return std::clamp(k, 0, stretches_ - 1);
}

double SyntheticSequence::HardWeight(double t, double ramp) const {
  if (period_s_ <= 0) return HardWeightOfFirst(t, ramp);
  // The stretch begun last and the next one (its ramp starts before it).
  const int k = StretchStartedBy(t);
  double w = HardWeightOfFirst(t - k * period_s_, ramp);
  if (k + 1 < stretches_) w = std::max(w, HardWeightOfFirst(t - (k + 1) * period_s_, ramp));
  return w;
}

double SyntheticSequence::HardWeightOfFirst(double t, double ramp) const {
  if (hard_end_ <= hard_begin_) return 0.0;
  if (t >= t_hard0_ && t <= t_hard1_) return 1.0;
  if (ramp <= 0) return 0.0;
  if (t < t_hard0_) return SmoothStep01((t - (t_hard0_ - ramp)) / ramp);
  return SmoothStep01(((t_hard1_ + ramp) - t) / ramp);
}

double SyntheticSequence::Phase(double t) const {
  if (o_.scenario != SynthScenario::kKidnap) return t;
  // While the lens is covered the camera is carried half an orbit away, so
  // the next view shares nothing with the last one.
  const double a = t_hard0_ - 0.5 / o_.fps, b = t_hard1_ + 0.5 / o_.fps;
  return t + 0.5 * loop_s_ * SmoothStep01((t - a) / (b - a));
}

Se3 SyntheticSequence::BasePose(double s) const {
  const double phi = phi0_ + orbit_dir_ * 2 * kPi * s / loop_s_;
  const Eigen::Vector3d p =
      orbit_center_ + Eigen::Vector3d(2.0 * std::cos(phi) + 0.15 * std::sin(2.3 * phi + ph_[0]),
                                      1.1 * std::sin(phi) + 0.15 * std::sin(1.7 * phi + ph_[1]),
                                      0.12 * std::sin(3.1 * phi + ph_[2]));
  // Look outwards at the walls, sweeping left and right; a little hand tremor.
  const double yaw = phi + 0.45 * std::sin(2 * kPi * s / 7.0 + ph_[3]) +
                     0.004 * std::sin(2 * kPi * 3.3 * s + ph_[6]);
  const double pitch = -0.12 + 0.08 * std::sin(2 * kPi * s / 5.3 + ph_[4]) +
                       0.004 * std::sin(2 * kPi * 2.7 * s + ph_[7]);
  const double roll = 0.04 * std::sin(2 * kPi * s / 4.1 + ph_[5]);
  return Se3(LookRotation(yaw, pitch, roll), p);
}

double SyntheticSequence::CorridorTravel(double dt) const {
  // Cruise at cor_v_, easing (1 s, smoothstep speed profile) to the turn's
  // speed next to it: distance covered within dt of the arc's start or end.
  const double v_arc = 0.5 * kPi * cor_r_ / std::max(1e-9, t_hard1_ - t_hard0_);
  const double ease = 1.0, u = dt / ease;
  const double integral = u <= 1 ? u * u * u - 0.5 * u * u * u * u : 0.5 + (u - 1);
  return v_arc * dt + (cor_v_ - v_arc) * ease * integral;
}

Se3 SyntheticSequence::CorridorPose(double t) const {
  const double y0 = cor_w_ / 2;
  const double xa = cor_la_ - cor_w_ / 2 - cor_r_;  // arc start (x)
  Eigen::Vector3d p;
  double heading;
  if (t < t_hard0_) {
    p = Eigen::Vector3d(xa - CorridorTravel(t_hard0_ - t), y0, 0);
    heading = 0;
  } else if (t <= t_hard1_) {
    // Quarter circle to the left at constant speed over the hard stretch.
    const double a = 0.5 * kPi * (t - t_hard0_) / std::max(1e-9, t_hard1_ - t_hard0_);
    p = Eigen::Vector3d(xa + cor_r_ * std::sin(a), y0 + cor_r_ * (1 - std::cos(a)), 0);
    heading = a;
  } else {
    p = Eigen::Vector3d(cor_la_ - cor_w_ / 2, y0 + cor_r_ + CorridorTravel(t - t_hard1_), 0);
    heading = 0.5 * kPi;
  }
  // Robot camera: low, bumping slightly on the rough floor.
  p.z() = 0.45 + 0.01 * std::sin(2 * kPi * 1.7 * t + ph_[0]);
  const double yaw = heading + 0.06 * std::sin(2 * kPi * t / 3.1 + ph_[1]);
  const double pitch = 0.03 + 0.015 * std::sin(2 * kPi * 1.3 * t + ph_[2]);
  const double roll = 0.02 * std::sin(2 * kPi * 0.9 * t + ph_[3]);
  return Se3(LookRotation(yaw, pitch, roll), p);
}

namespace {

// Extra yaw (rad) of a detour: the rate ramps linearly 0 -> rate over
// [a0, a0 + ramp], holds, ramps down over [a1 - ramp, a1], then the angle
// gained swings back to 0 at about back_rate (smooth start and stop).
double YawDetour(double t, double a0, double a1, double ramp, double rate, double back_rate) {
  if (t <= a0) return 0;
  auto ramp_angle = [&](double x) {  // integral of a linear rate ramp 0..rate over [0, ramp]
    x = std::clamp(x, 0.0, ramp);
    return 0.5 * rate * x * x / ramp;
  };
  const double total = rate * (a1 - a0 - ramp);
  double extra = ramp_angle(t - a0) + rate * std::clamp(t - (a0 + ramp), 0.0, a1 - a0 - 2 * ramp);
  if (t > a1 - ramp) extra += rate * std::min(t - (a1 - ramp), ramp) - ramp_angle(t - (a1 - ramp));
  if (t > a1) extra -= total * SmoothStep01((t - a1) / (std::abs(total) / back_rate));
  return extra;
}

}  // namespace

Se3 SyntheticSequence::PoseAt(double t) const {
  if (o_.scenario == SynthScenario::kCorridor) return CorridorPose(t);
  Se3 pose = BasePose(Phase(t));
  if (o_.scenario == SynthScenario::kWeak) {
    const double w = HardWeight(t, weak_ramp_);
    if (w > 0) {
      const double tau = (t - t_hard0_) / std::max(1e-9, t_hard1_ - t_hard0_);
      // Slow scan along the plain wall while facing it.
      const Eigen::Vector3d tp = weak_target_.translation() +
                                 0.25 * std::sin(kPi * (tau - 0.5)) * weak_tangent_;
      const Eigen::Quaterniond tq =
          weak_target_.rotation() *
          Eigen::Quaterniond(Eigen::AngleAxisd(0.06 * std::sin(2 * kPi * tau), Eigen::Vector3d::UnitY()));
      pose = Se3(pose.rotation().slerp(w, tq), (1 - w) * pose.translation() + w * tp);
    }
  } else if (o_.scenario == SynthScenario::kBlur) {
    // Peak yaw rate held through the stretch (ramps just outside it), then a
    // slow swing back (about 35 deg/s).
    const double ramp = 0.12;
    const double a0 = t_hard0_ - 0.5 / o_.fps - ramp, a1 = t_hard1_ + 0.5 / o_.fps + ramp;
    const double extra = YawDetour(t, a0, a1, ramp, o_.blur_peak_rate_deg * kDeg, 35.0 * kDeg);
    // Hand shake on top: the view direction circles at 8 Hz, so within one
    // exposure the blur path curves and edges of every orientation smear.
    const double w = HardWeight(t, ramp);
    const double omega = 2 * kPi * 8.0;
    const double amp = w * o_.blur_shake_rate_deg * kDeg / omega;
    const Eigen::Matrix3d shake =
        (Eigen::AngleAxisd(amp * std::cos(omega * t), Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd(amp * std::sin(omega * t), Eigen::Vector3d::UnitY()))
            .toRotationMatrix();
    pose = Se3(Eigen::AngleAxisd(extra, Eigen::Vector3d::UnitZ()) * pose.R() * shake, pose.translation());
  } else if (o_.scenario == SynthScenario::kDrop && o_.drop_turn_deg != 0) {
    // While the link is down the camera turns away from where it looked at
    // the last frame received (so the first frames after the gap share
    // little with it), turns back to that view at about 30 deg/s, and then
    // rejoins its path. The view overlaps the pre-gap frames again only
    // after the realtime front has given up relocalising; an offline matcher
    // given the frames after the gap can still tie them to those before.
    const double shift = StretchStartedBy(t) * period_s_;  // repeated gaps: the last one begun
    const double t_last = shift + t_hard0_ - 1.0 / o_.fps;  // last frame before the gap
    const double a0 = shift + t_hard0_ - 0.5 / o_.fps, a1 = shift + t_hard1_ + 0.5 / o_.fps;
    if (t > a0) {
      const double turn = o_.drop_turn_deg * kDeg;
      const double t_ret = std::abs(turn) / (30.0 * kDeg);  // turning back
      const double detour = t < a1 ? turn * SmoothStep01((t - a0) / (a1 - a0))
                                   : turn * (1.0 - SmoothStep01((t - a1) / t_ret));
      const Eigen::Quaterniond held =
          Eigen::Quaterniond(Eigen::AngleAxisd(detour, Eigen::Vector3d::UnitZ())) * BasePose(Phase(t_last)).rotation();
      // Rejoin the path's orientation slowly (the path itself keeps turning).
      const double t_join = a1 + t_ret;
      const double w = t < t_join ? 0.0 : SmoothStep01((t - t_join) / 2.0);
      pose = Se3(held.slerp(w, pose.rotation()), pose.translation());
    }
  }
  return pose;
}

Timestamp SyntheticSequence::timestamp(int i) const {
  return kSynthFirstTimestamp + static_cast<Timestamp>(std::llround(i * 1e9 / o_.fps));
}

Se3 SyntheticSequence::T_wc(int i) const {
  return PoseAt(NsToSeconds(timestamp(i) - kSynthFirstTimestamp));
}

bool SyntheticSequence::dropped(int i) const {
  return o_.scenario == SynthScenario::kDrop && in_hard_stretch(i);
}

std::vector<int> SyntheticSequence::StreamIndices() const {
  std::vector<int> out;
  for (int i = 0; i < o_.frames; ++i)
    if (!dropped(i)) out.push_back(i);
  return out;
}

double SyntheticSequence::Gain(int i) const {
  const double t = NsToSeconds(timestamp(i) - kSynthFirstTimestamp);
  if (o_.scenario == SynthScenario::kDark) return 1.0 - (1.0 - o_.dark_gain) * HardWeight(t, 1.0);
  if (o_.scenario == SynthScenario::kKidnap && in_hard_stretch(i)) return 0.0;
  if (o_.scenario == SynthScenario::kBlur) return 1.0 - (1.0 - o_.blur_gain) * HardWeight(t, 0.3);
  return 1.0;
}

double SyntheticSequence::RenderRadiance(const Se3& T_wc, double u, double v) const {
  const Eigen::Vector3d d_c((u - cam_.cx) / cam_.fx, (v - cam_.cy) / cam_.fy, 1.0);
  return scene_.Radiance(T_wc.translation(), T_wc.rotation() * d_c);
}

cv::Mat SyntheticSequence::Render(int i) const {
  const int w = o_.width, h = o_.height;
  const double t = NsToSeconds(timestamp(i) - kSynthFirstTimestamp);
  const double gain = Gain(i);
  // Shutter: a still frame gets n x n supersampling. A moving one averages
  // `samples` rays per pixel, each at its own sub-frame pose and sub-pixel
  // offset; poses come from a 4x finer time grid and each pixel picks its own
  // phase in it, so the blur carries no regular ghosting (fake corners).
  double exposure = o_.exposure_s;
  if (o_.scenario == SynthScenario::kBlur && HardWeight(t, 0.15) > 0)
    exposure = o_.blur_exposure_frac / o_.fps;
  double blur_px = 0;  // image path length over the exposure, roughly
  for (int k = 0; k < 8; ++k) {
    const Se3 a = PoseAt(t + exposure * (k / 8.0 - 0.5)), b = PoseAt(t + exposure * ((k + 1) / 8.0 - 0.5));
    blur_px += (RotationAngle(a.rotation().inverse() * b.rotation()) +
                (a.translation() - b.translation()).norm() / 1.5) * cam_.fx;
  }
  // Stratified n x n sub-pixel offsets.
  const int n = o_.supersample, nn = n * n;
  auto offset = [n](int j) {
    return Eigen::Vector2d(((j % n) + 0.5) / n - 0.5, ((j / n) + 0.5) / n - 0.5);
  };
  const bool moving = blur_px >= 0.7;
  const int samples = moving ? std::clamp(static_cast<int>(std::ceil(blur_px)), nn, 48 * nn) : nn;
  std::vector<Se3> poses;
  if (!moving) {
    poses.push_back(PoseAt(t));
  } else {
    const int m = 4 * samples;
    for (int k = 0; k < m; ++k) poses.push_back(PoseAt(t + exposure * ((k + 0.5) / m - 0.5)));
  }
  const double scale = 255.0 * exposure_scale_ * gain / samples;
  cv::Mat img(h, w, CV_8UC1);
  const uint64_t noise_seed = SynthHash(o_.seed, 0x5e5, static_cast<uint64_t>(i));
  const uint64_t noise_key = SynthHashA(noise_seed);
  auto work = [&](int tid, int nt) {
    for (int y = tid; y < h; y += nt) {
      uint8_t* row = img.ptr<uint8_t>(y);
      for (int x = 0; x < w; ++x) {
        // Per-pixel hash prefix: SynthHash(noise_seed, x, y, d) == SynthHashD(pixel_key, d).
        const uint64_t pixel_key =
            SynthHashC(SynthHashB(noise_key, static_cast<uint64_t>(x)), static_cast<uint64_t>(y));
        double acc = 0;
        if (gain > 0) {
          if (!moving) {
            for (int k = 0; k < nn; ++k) {
              const Eigen::Vector2d j = offset(k);
              acc += RenderRadiance(poses[0], x + j.x(), y + j.y());
            }
          } else {
            const uint64_t hp = SynthHashD(pixel_key, 7);
            for (int k = 0; k < samples; ++k) {
              const int phase = static_cast<int>((hp >> (2 * (k % 16))) & 3);
              const Eigen::Vector2d j = offset(static_cast<int>((hp >> 40) + k) % nn);
              acc += RenderRadiance(poses[4 * k + phase], x + j.x(), y + j.y());
            }
          }
        }
        const double v = scale * acc;
        // Read noise + shot noise, Box-Muller from a per-pixel hash.
        const uint64_t hs = SynthHashD(pixel_key, 0);
        const double u1 = std::max(1e-12, Unit(hs)), u2 = Unit(SynthHash(hs, 1));
        const double g = std::sqrt(-2 * std::log(u1)) * std::cos(2 * kPi * u2);
        const double sigma = std::sqrt(o_.noise_sigma * o_.noise_sigma + 0.02 * std::max(0.0, v));
        row[x] = static_cast<uint8_t>(std::clamp(std::lround(v + sigma * g), 0L, 255L));
      }
    }
  };
  if (o_.threads >= 2 && h >= 2) {
    std::thread other(work, 1, 2);
    work(0, 2);
    other.join();
  } else {
    work(0, 1);
  }
  return img;
}

bool SyntheticSequence::PixelToPoint(int i, double u, double v, Eigen::Vector3d* X_w) const {
  const Se3 T = T_wc(i);
  const Eigen::Vector3d d_c((u - cam_.cx) / cam_.fx, (v - cam_.cy) / cam_.fy, 1.0);
  SynthHit hit;
  if (!scene_.CastRay(T.translation(), T.rotation() * d_c, &hit, false)) return false;
  *X_w = hit.point;
  return true;
}

bool SyntheticSequence::Project(int i, const Eigen::Vector3d& X_w, Eigen::Vector2d* px) const {
  const Eigen::Vector3d p = T_wc(i).Inverse() * X_w;
  if (p.z() <= 1e-9) return false;
  *px = Eigen::Vector2d(cam_.fx * p.x() / p.z() + cam_.cx, cam_.fy * p.y() / p.z() + cam_.cy);
  return true;
}

double SyntheticSequence::PathLength() const {
  double len = 0;
  Eigen::Vector3d prev = T_wc(0).translation();
  for (int i = 1; i < o_.frames; ++i) {
    const Eigen::Vector3d p = T_wc(i).translation();
    len += (p - prev).norm();
    prev = p;
  }
  return len;
}

int CountOrbKeypoints(const cv::Mat& image) {
  auto orb = cv::ORB::create(1000, 1.2f, 8, 31, 0, 2, cv::ORB::HARRIS_SCORE, 31, 7);
  std::vector<cv::KeyPoint> kps;
  orb->detect(image, kps);
  return static_cast<int>(kps.size());
}

namespace {

std::string FormatDouble(double v, int prec = 9) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(prec) << v;
  return s.str();
}

void WriteTextFile(const std::filesystem::path& path, const std::string& text) {
  std::ofstream f(path);
  if (!f) throw std::runtime_error("cannot write " + path.string());
  f << text;
  if (!f) throw std::runtime_error("error writing " + path.string());
}

}  // namespace

namespace {

// The robot's pose source: every frame's ground-truth step (dropped frames
// too: odometry does not stop with the Wi-Fi) with a scale bias, per-axis
// translation noise proportional to the step and rotation noise, integrated.
// Its own random stream, so the images do not depend on it.
std::string FormatOdometry(const SyntheticSequence& seq, const SynthOptions& o) {
  std::mt19937_64 rng(o.seed * 0x9E3779B97F4A7C15ull + 0x0D0Full);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::ostringstream od;
  od << "# synthetic odometry body(=camera)->odometry world, TUM format: ground-truth steps with scale bias "
     << FormatDouble(o.odometry_scale_bias) << ", step noise " << FormatDouble(o.odometry_step_noise)
     << ", rotation noise " << FormatDouble(o.odometry_rotation_noise_deg) << " deg/frame\n"
     << "# timestamp tx ty tz qx qy qz qw\n";
  Se3 T = seq.T_wc(0);
  for (int i = 0; i < seq.num_frames(); ++i) {
    if (i > 0) {
      const Se3 step = seq.T_wc(i - 1).Inverse() * seq.T_wc(i);
      const double len = step.translation().norm();
      Eigen::Vector3d t = step.translation() * (1.0 + o.odometry_scale_bias);
      Eigen::Vector3d w;
      for (int k = 0; k < 3; ++k) t[k] += o.odometry_step_noise * len * n01(rng);
      for (int k = 0; k < 3; ++k) w[k] = o.odometry_rotation_noise_deg * kDeg * n01(rng);
      const double angle = w.norm();
      const Eigen::Vector3d axis = angle > 0 ? Eigen::Vector3d(w / angle) : Eigen::Vector3d::UnitX();
      T = T * Se3(step.rotation() * Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis)), t);
    }
    const Eigen::Quaterniond& q = T.rotation();
    const Eigen::Vector3d& p = T.translation();
    od << FormatSeconds(seq.timestamp(i)) << ' ' << FormatDouble(p.x()) << ' ' << FormatDouble(p.y()) << ' '
       << FormatDouble(p.z()) << ' ' << FormatDouble(q.x()) << ' ' << FormatDouble(q.y()) << ' '
       << FormatDouble(q.z()) << ' ' << FormatDouble(q.w()) << '\n';
  }
  return od.str();
}

// The IMU: ImuSynth over every frame's ground truth (the body is the camera),
// its own random stream.
std::string FormatImu(const SyntheticSequence& seq, const SynthOptions& o) {
  std::vector<std::pair<Timestamp, Se3>> poses;
  for (int i = 0; i < seq.num_frames(); ++i) poses.push_back({seq.timestamp(i), seq.T_wc(i)});
  ImuSynthOptions io;
  io.gyro_bias = o.imu_gyro_bias;
  io.seed = o.seed * 0x9E3779B97F4A7C15ull + 0x1A1Aull;
  ImuSynth synth(poses, io);
  std::vector<ImuSample> v;
  const Timestamp step = static_cast<Timestamp>(1e9 / o.imu_hz);
  for (Timestamp t = poses.front().first; t <= poses.back().first; t += step) {
    float a[3], g[3];
    synth.Sample(t, a, g);
    ImuSample s;
    s.t = t;
    s.gyro = Eigen::Vector3d(g[0], g[1], g[2]);
    s.accel = Eigen::Vector3d(a[0], a[1], a[2]);
    v.push_back(s);
  }
  return FormatImuCsv(v, "synthetic IMU (rumi synth): body = camera, gyro noise " + FormatDouble(io.gyro_noise) +
                             " rad/s, gyro bias " + FormatDouble(io.gyro_bias) + " rad/s per axis, world z up");
}

}  // namespace

SynthWriteResult SynthesizeSequence(const SynthOptions& options, const std::string& out_dir) {
  namespace fs = std::filesystem;
  const SyntheticSequence seq(options);
  const fs::path out(out_dir);
  std::error_code ec;
  fs::create_directories(out / "rgb", ec);
  if (ec) throw std::runtime_error("cannot create " + (out / "rgb").string() + ": " + ec.message());

  SynthWriteResult r;
  std::ostringstream rgb, gt;
  rgb << "# synthetic grey images (rumi synth, scenario " << SynthScenarioName(options.scenario)
      << ", seed " << options.seed << ")\n# timestamp filename\n";
  gt << "# ground truth camera->world (T_wc), TUM format\n# timestamp tx ty tz qx qy qz qw\n";
  const auto t_start = std::chrono::steady_clock::now();
  for (int i = 0; i < seq.num_frames(); ++i) {
    if (seq.dropped(i)) {
      ++r.frames_dropped;
      continue;
    }
    const std::string ts = FormatSeconds(seq.timestamp(i));
    const std::string name = "rgb/" + ts + ".png";
    const cv::Mat img = seq.Render(i);
    if (!cv::imwrite((out / name).string(), img))
      throw std::runtime_error("cannot write image " + (out / name).string());
    const Se3 T = seq.T_wc(i);
    const Eigen::Quaterniond& q = T.rotation();
    const Eigen::Vector3d& p = T.translation();
    rgb << ts << ' ' << name << '\n';
    gt << ts << ' ' << FormatDouble(p.x()) << ' ' << FormatDouble(p.y()) << ' ' << FormatDouble(p.z())
       << ' ' << FormatDouble(q.x()) << ' ' << FormatDouble(q.y()) << ' ' << FormatDouble(q.z()) << ' '
       << FormatDouble(q.w()) << '\n';
    ++r.frames_written;
    if (r.frames_written % 50 == 0) spdlog::info("synth: {} / {} frames", i + 1, seq.num_frames());
  }
  r.render_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  WriteTextFile(out / "rgb.txt", rgb.str());
  WriteTextFile(out / "groundtruth.txt", gt.str());
  WriteTextFile(out / "odometry.txt", FormatOdometry(seq, options));
  if (options.imu_hz > 0 && seq.num_frames() >= 2) WriteTextFile(out / "imu.csv", FormatImu(seq, options));

  const PinholeCameraOptions& c = seq.camera();
  std::ostringstream cam;
  cam << "# rumi camera config written by `rumi synth` (zero distortion)\ncamera:\n"
      << "  width: " << c.width << "\n  height: " << c.height << "\n  fx: " << FormatDouble(c.fx, 6)
      << "\n  fy: " << FormatDouble(c.fy, 6) << "\n  cx: " << FormatDouble(c.cx, 6)
      << "\n  cy: " << FormatDouble(c.cy, 6)
      << "\n  k1: 0.0\n  k2: 0.0\n  p1: 0.0\n  p2: 0.0\n  k3: 0.0\n";
  WriteTextFile(out / "camera.yaml", cam.str());

  r.path_length_m = seq.PathLength();
  nlohmann::json j;
  j["scenario"] = SynthScenarioName(options.scenario);
  j["seed"] = options.seed;
  j["frames"] = options.frames;
  j["frames_written"] = r.frames_written;
  j["fps"] = options.fps;
  j["size"] = {options.width, options.height};
  j["first_timestamp"] = FormatSeconds(seq.timestamp(0));
  if (seq.hard_end() > seq.hard_begin()) {
    j["hard_stretch"] = {
        {"frames", {seq.hard_begin(), seq.hard_end()}},  // [begin, end)
        {"seconds",
         {FormatSeconds(seq.timestamp(seq.hard_begin())), FormatSeconds(seq.timestamp(seq.hard_end() - 1))}},
    };
    if (options.hard_period > 0) j["hard_stretch"]["repeats"] = {{"every_frames", options.hard_period},
                                                                  {"count", seq.hard_stretches()}};
  } else {
    j["hard_stretch"] = nullptr;
  }
  j["path_length_m"] = r.path_length_m;
  j["ground_truth"] = "T_wc camera->world; timestamps exactly those of rgb.txt";
  WriteTextFile(out / "scenario.json", j.dump(2) + "\n");
  return r;
}

}  // namespace rumi
