#pragma once
// Options of a generated challenge sequence (`rumi synth`).
#include <cstdint>
#include <string>
#include <vector>

#include "common/option_spec.h"

namespace rumi {

// Each scenario has a "hard stretch" of frames [hard_start, hard_start +
// hard_length) where a realtime ORB tracker tends to fail while an offline
// exhaustive matcher can still connect the frames (except kKidnap).
enum class SynthScenario {
  kSmooth,    // no hard stretch
  kBlur,      // fast rotation with motion blur
  kDark,      // exposure falls close to black
  kDrop,      // frames missing from the stream (lossy link)
  kWeak,      // camera faces a texture-poor wall
  kKidnap,    // lens covered, camera moved to an unrelated view
  kCorridor,  // low-texture L-shaped corridor, hard stretch = the turn
};

const std::vector<std::string>& SynthScenarioNames();
std::string SynthScenarioName(SynthScenario s);
bool ParseSynthScenario(const std::string& name, SynthScenario* s);

struct SynthOptions {
  SynthScenario scenario = SynthScenario::kSmooth;
  uint64_t seed = 1;
  int frames = 300;
  double fps = 30.0;
  int width = 640;
  int height = 480;
  int hard_start = -1;   // frame index; -1: 40 % into the sequence (corridor 55 %)
  int hard_length = -1;  // frames; -1: scenario default (scaled with fps)
  // > 0: the hard stretch repeats every hard_period frames while it fits
  // (dark and drop): a loss every few seconds for the back's stress test.
  int hard_period = 0;
  int threads = 2;       // render threads (rows), 1 or 2
  int supersample = 2;   // n x n rays per pixel (at least n * n sub-frames when blurred)
  double noise_sigma = 1.0;  // read noise, grey levels (shot noise added on top)
  double exposure_s = 0.008;  // shutter time outside the blur stretch

  // Scenario knobs (defaults and their calibration figures: docs/synth.md).
  double blur_peak_rate_deg = 180.0;  // blur: yaw sweep rate through the stretch
  double blur_shake_rate_deg = 220.0; // blur: angular speed of the 8 Hz shake
  double blur_gain = 1.0;             // blur: exposure gain in the stretch
  double blur_exposure_frac = 0.3;    // blur: shutter time / frame interval in the stretch
  double dark_gain = 0.1;             // dark: exposure gain at the bottom
  double drop_turn_deg = -45.0;       // drop: turn (deg, + left) while frames are missing, then back
  double weak_distance = 1.0;         // weak: distance to the plain wall
  // odometry.txt (the robot's pose source, for `--odometry`): ground truth
  // integrated through noisy steps, so it drifts like wheel odometry.
  double odometry_scale_bias = 0.02;      // every step's length x (1 + bias)
  double odometry_step_noise = 0.05;      // per-axis sigma, fraction of the step length
  double odometry_rotation_noise_deg = 0.1;   // per-axis sigma per frame (random walk)
  // imu.csv (for `--imu`): gyro and accelerometer from the ground truth of
  // every frame (dropped ones too), white noise and a constant bias of the
  // size an uncalibrated MPU6050 shows (about 1 deg/s).
  double imu_hz = 200.0;
  double imu_gyro_bias = 0.02;
  double weak_amplitude = 0.06;       // weak / corridor turn: albedo amplitude left

  static const OptionSpec<SynthOptions>& Spec();  // a `synth:` style section, keys as the fields
  bool Check(std::string* why = nullptr) const;

  // Defaults resolved (-1 replaced); call after Check().
  int HardStart() const;
  int HardLength() const;
  int HardStretches() const;  // 1, or how many repeats fit strictly inside the frames
};


}  // namespace rumi
