#pragma once
// In-memory generator of challenge sequences with exact ground truth, and the
// writer of the TUM-layout folder (`rumi synth`). Frame i is captured at
// timestamp 1000 s + i / fps (int64 ns); its pose T_wc (camera -> world,
// camera x right, y down, z forward) is the pose at mid-exposure.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/geometry.h"
#include "common/synth/synth_options.h"
#include "common/synth/synth_scene.h"
#include "common/timestamp.h"

namespace rumi {

constexpr Timestamp kSynthFirstTimestamp = 1000 * kNsPerSecond;

class SyntheticSequence {
 public:
  // Throws std::invalid_argument when options.Check() fails.
  explicit SyntheticSequence(const SynthOptions& options);

  const SynthOptions& options() const { return o_; }
  const SynthScene& scene() const { return scene_; }
  // Pinhole, zero distortion; principal point at the image centre with the
  // pixel-centre-at-integer convention (cx = (width - 1) / 2).
  const PinholeCameraOptions& camera() const { return cam_; }

  int num_frames() const { return o_.frames; }  // including dropped ones
  Timestamp timestamp(int i) const;
  Se3 T_wc(int i) const;
  // Pose at an arbitrary time (seconds since the first frame).
  Se3 PoseAt(double t) const;

  // The (first) hard stretch [hard_begin, hard_end); empty for kSmooth.
  // With hard_period it repeats hard_stretches() times, every period frames.
  int hard_begin() const { return hard_begin_; }
  int hard_end() const { return hard_end_; }
  int hard_stretches() const { return stretches_; }
  bool in_hard_stretch(int i) const;
  // Frame missing from the stream (kDrop) - absent from rgb.txt and GT.
  bool dropped(int i) const;
  // Indices of the frames delivered to a tracker, in time order.
  std::vector<int> StreamIndices() const;

  // 8-bit grey image of frame i (rendered even when dropped). Deterministic:
  // same options -> identical bytes, independent of thread count.
  cv::Mat Render(int i) const;

  // Ray-casts pixel (u, v) (pixel centres at integers) of frame i to the
  // first surface; false if nothing is hit.
  bool PixelToPoint(int i, double u, double v, Eigen::Vector3d* X_w) const;
  // World point -> pixel for frame i; false behind the camera.
  bool Project(int i, const Eigen::Vector3d& X_w, Eigen::Vector2d* px) const;

  // Camera-path length over all frames, metres.
  double PathLength() const;
  // Exposure gain (1 = normal, 0 = lens covered) of frame i.
  double Gain(int i) const;

 private:
  void BuildTrajectory();
  double Phase(double t) const;        // base-path time (kidnap jumps)
  Se3 BasePose(double s) const;        // room orbit
  Se3 CorridorPose(double t) const;
  double CorridorTravel(double dt) const;  // metres driven within dt of the turn
  double HardWeight(double t, double ramp) const;  // 0 outside, 1 inside a stretch
  double HardWeightOfFirst(double t, double ramp) const;  // the first stretch only
  int StretchStartedBy(double t) const;  // the last stretch begun by t (0 before the first)
  double RenderRadiance(const Se3& T_wc, double u, double v) const;

  SynthOptions o_;
  PinholeCameraOptions cam_;
  SynthScene scene_;
  int hard_begin_ = 0, hard_end_ = 0;
  double t_hard0_ = 0, t_hard1_ = 0;  // seconds
  int stretches_ = 1;
  double period_s_ = 0;  // seconds between repeated stretches; 0: one stretch
  double exposure_scale_ = 1.0;
  // Room orbit parameters.
  Eigen::Vector3d orbit_center_;
  double phi0_ = 0, orbit_dir_ = 1, loop_s_ = 24;
  double ph_[8] = {0};
  // Weak scenario target.
  Se3 weak_target_;
  Eigen::Vector3d weak_tangent_;
  double weak_ramp_ = 1.5;  // seconds to approach / leave the wall
  // Corridor parameters.
  double cor_la_ = 0, cor_lb_ = 0, cor_w_ = 1.6, cor_r_ = 0.5, cor_v_ = 0.8, cor_x0_ = 1.0;
};

struct SynthWriteResult {
  int frames_written = 0;
  int frames_dropped = 0;
  double path_length_m = 0;
  double render_seconds = 0;
};

// Writes OUT/rgb/<seconds>.png, rgb.txt, groundtruth.txt (same timestamps as
// rgb.txt; dropped frames are absent from both), camera.yaml and
// scenario.json. Creates the folder; throws std::runtime_error on I/O errors.
SynthWriteResult SynthesizeSequence(const SynthOptions& options, const std::string& out_dir);

// ORB keypoints in an image (cv::ORB, 1000 features, FAST threshold 7).
int CountOrbKeypoints(const cv::Mat& image);

}  // namespace rumi
