#include "common/synth/synth_options.h"

#include <cmath>

namespace rumi {

const std::vector<std::string>& SynthScenarioNames() {
  static const std::vector<std::string> names = {"smooth", "blur",   "dark",    "drop",
                                                 "weak",   "kidnap", "corridor"};
  return names;
}

std::string SynthScenarioName(SynthScenario s) {
  return SynthScenarioNames()[static_cast<size_t>(s)];
}

bool ParseSynthScenario(const std::string& name, SynthScenario* s) {
  const auto& names = SynthScenarioNames();
  for (size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) {
      *s = static_cast<SynthScenario>(i);
      return true;
    }
  }
  return false;
}

int SynthOptions::HardStart() const {
  if (scenario == SynthScenario::kSmooth) return 0;
  if (hard_start >= 0) return hard_start;
  // The corridor robot needs a longer textured approach before the turn.
  return static_cast<int>(frames * (scenario == SynthScenario::kCorridor ? 0.55 : 0.4));
}

int SynthOptions::HardLength() const {
  if (scenario == SynthScenario::kSmooth) return 0;
  if (hard_length >= 0) return hard_length;
  // Defaults at 30 fps, scaled to keep the same duration.
  int n = 30;
  switch (scenario) {
    case SynthScenario::kBlur: n = 20; break;
    case SynthScenario::kDark: n = 30; break;
    case SynthScenario::kDrop: n = 30; break;
    case SynthScenario::kWeak: n = 45; break;
    case SynthScenario::kKidnap: n = 30; break;
    case SynthScenario::kCorridor: n = 60; break;
    case SynthScenario::kSmooth: n = 0; break;
  }
  return std::max(1, static_cast<int>(std::lround(n * fps / 30.0)));
}

int SynthOptions::HardStretches() const {
  if (scenario == SynthScenario::kSmooth || hard_period <= 0) return 1;
  // Stretch k covers [start + k * period, start + k * period + length), inside the frames.
  return 1 + std::max(0, (frames - 1 - HardLength() - HardStart()) / hard_period);
}

const OptionSpec<SynthOptions>& SynthOptions::Spec() {
  using O = SynthOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("synth");
    std::vector<std::pair<std::string, SynthScenario>> scenarios;
    for (const std::string& n : SynthScenarioNames()) {
      SynthScenario sc = SynthScenario::kSmooth;
      ParseSynthScenario(n, &sc);
      scenarios.push_back({n, sc});
    }
    s->Enum("scenario", &O::scenario, scenarios, "what makes the front lose track");
    s->Number<uint64_t>("seed", &O::seed, Unbounded<uint64_t>(), Unbounded<uint64_t>(), "random seed");
    s->Number("frames", &O::frames, AtLeast(2), AtMost(1000000), "frames");
    s->Number("fps", &O::fps, Above(0.5), AtMost(1000.0), "frame rate");
    s->Number("width", &O::width, AtLeast(16), AtMost(8192), "image width");
    s->Number("height", &O::height, AtLeast(16), AtMost(8192), "image height");
    s->Number("hard_start", &O::hard_start, AtLeast(-1), AtMost(1000000), "first hard frame; -1: default");
    s->Number("hard_length", &O::hard_length, AtLeast(-1), AtMost(1000000), "hard frames; -1: default");
    s->Number("hard_period", &O::hard_period, AtLeast(0), AtMost(1000000),
              "repeat the hard stretch every this many frames (dark, drop); 0: once");
    s->Number("threads", &O::threads, AtLeast(1), AtMost(2), "render threads");
    s->Number("supersample", &O::supersample, AtLeast(1), AtMost(8), "n x n rays per pixel");
    s->Number("noise_sigma", &O::noise_sigma, AtLeast(0.0), Below(50.0), "read noise, grey levels");
    s->Number("exposure_s", &O::exposure_s, AtLeast(0.0), Below(1.0), "shutter time outside the blur stretch");
    s->Number("blur_peak_rate_deg", &O::blur_peak_rate_deg, Above(0.0), AtMost(2000.0), "blur: yaw sweep rate");
    s->Number("blur_shake_rate_deg", &O::blur_shake_rate_deg, AtLeast(0.0), AtMost(2000.0), "blur: shake speed");
    s->Number("blur_exposure_frac", &O::blur_exposure_frac, Above(0.0), AtMost(1.0), "blur: shutter / interval");
    s->Number("blur_gain", &O::blur_gain, AtLeast(0.0), AtMost(1.0), "blur: exposure gain");
    s->Number("drop_turn_deg", &O::drop_turn_deg, AtLeast(-180.0), AtMost(180.0), "drop: turn while frames miss");
    s->Number("dark_gain", &O::dark_gain, AtLeast(0.0), AtMost(1.0), "dark: exposure gain at the bottom");
    s->Number("weak_distance", &O::weak_distance, AtLeast(0.5), AtMost(2.0), "weak: distance to the plain wall");
    s->Number("weak_amplitude", &O::weak_amplitude, AtLeast(0.0), AtMost(0.3), "weak: albedo amplitude");
    s->Number("odometry_scale_bias", &O::odometry_scale_bias, AtLeast(-0.5), AtMost(0.5), "odometry: step bias");
    s->Number("odometry_step_noise", &O::odometry_step_noise, AtLeast(0.0), AtMost(1.0), "odometry: step noise");
    s->Number("odometry_rotation_noise_deg", &O::odometry_rotation_noise_deg, AtLeast(0.0), AtMost(10.0),
              "odometry: rotation noise per frame");
    s->Number("imu_hz", &O::imu_hz, AtLeast(0.0), AtMost(2000.0), "imu.csv sample rate; 0: no imu.csv");
    s->Number("imu_gyro_bias", &O::imu_gyro_bias, AtLeast(-1.0), AtMost(1.0), "imu.csv: gyro bias, rad/s, each axis");
    s->Rule([](const O& o) -> std::string {
      if (o.scenario == SynthScenario::kSmooth) return "";
      const int st = o.HardStart(), l = o.HardLength();
      if (l < 1) return "hard_length must be >= 1";
      if (st < 1 || st + l >= o.frames)
        return "hard stretch [" + std::to_string(st) + ", " + std::to_string(st + l) +
               ") must lie strictly inside the " + std::to_string(o.frames) + " frames";
      if (o.hard_period > 0 && o.scenario != SynthScenario::kDark && o.scenario != SynthScenario::kDrop)
        return "hard_period repeats the hard stretch of dark and drop only";
      if (o.hard_period > 0 && o.hard_period <= l)
        return "hard_period (" + std::to_string(o.hard_period) + ") must exceed hard_length (" + std::to_string(l) +
               "): tracked frames between the stretches";
      return "";
    });
    return s;
  }();
  return *spec;
}

bool SynthOptions::Check(std::string* why) const { return Spec().Check(*this, why); }

}  // namespace rumi
