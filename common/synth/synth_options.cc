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

bool SynthOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (frames < 2 || frames > 1000000) return fail("frames must be in [2, 1000000]");
  if (!(fps > 0.5 && fps <= 1000)) return fail("fps must be in (0.5, 1000]");
  if (width < 16 || height < 16 || width > 8192 || height > 8192)
    return fail("size must be between 16x16 and 8192x8192");
  if (threads < 1 || threads > 2) return fail("threads must be 1 or 2");
  if (supersample < 1 || supersample > 8) return fail("supersample must be in [1, 8]");
  if (hard_start < -1 || hard_length < -1) return fail("hard_start/hard_length must be >= 0 (or -1 for default)");
  if (!(noise_sigma >= 0 && noise_sigma < 50)) return fail("noise_sigma must be in [0, 50)");
  if (!(exposure_s >= 0 && exposure_s < 1.0)) return fail("exposure_s must be in [0, 1)");
  if (!(blur_peak_rate_deg > 0 && blur_peak_rate_deg <= 2000)) return fail("blur_peak_rate_deg must be in (0, 2000]");
  if (!(blur_shake_rate_deg >= 0 && blur_shake_rate_deg <= 2000)) return fail("blur_shake_rate_deg must be in [0, 2000]");
  if (!(blur_exposure_frac > 0 && blur_exposure_frac <= 1)) return fail("blur_exposure_frac must be in (0, 1]");
  if (!(blur_gain >= 0 && blur_gain <= 1)) return fail("blur_gain must be in [0, 1]");
  if (!(std::abs(drop_turn_deg) <= 180)) return fail("drop_turn_deg must be in [-180, 180]");
  if (!(dark_gain >= 0 && dark_gain <= 1)) return fail("dark_gain must be in [0, 1]");
  if (!(weak_distance >= 0.5 && weak_distance <= 2.0)) return fail("weak_distance must be in [0.5, 2]");
  if (!(weak_amplitude >= 0 && weak_amplitude <= 0.3)) return fail("weak_amplitude must be in [0, 0.3]");
  if (!(std::abs(odometry_scale_bias) <= 0.5)) return fail("odometry_scale_bias must be in [-0.5, 0.5]");
  if (!(odometry_step_noise >= 0 && odometry_step_noise <= 1)) return fail("odometry_step_noise must be in [0, 1]");
  if (!(odometry_rotation_noise_deg >= 0 && odometry_rotation_noise_deg <= 10))
    return fail("odometry_rotation_noise_deg must be in [0, 10]");
  if (scenario != SynthScenario::kSmooth) {
    const int s = HardStart(), l = HardLength();
    if (l < 1) return fail("hard_length must be >= 1");
    if (s < 1 || s + l >= frames)
      return fail("hard stretch [" + std::to_string(s) + ", " + std::to_string(s + l) +
                  ") must lie strictly inside the " + std::to_string(frames) + " frames");
  }
  return true;
}

void ReadOptions(ConfigSection& s, SynthOptions* o) {
  std::string scenario = SynthScenarioName(o->scenario);
  if (s.Read("scenario", &scenario) && !ParseSynthScenario(scenario, &o->scenario))
    s.Fail("scenario", "unknown scenario '" + scenario + "'");
  s.Read("seed", &o->seed);
  s.ReadInRange("frames", &o->frames, 2, 1000000);
  s.ReadInRange("fps", &o->fps, 0.5, 1000.0);
  s.ReadInRange("width", &o->width, 16, 8192);
  s.ReadInRange("height", &o->height, 16, 8192);
  s.ReadInRange("hard_start", &o->hard_start, -1, 1000000);
  s.ReadInRange("hard_length", &o->hard_length, -1, 1000000);
  s.ReadInRange("threads", &o->threads, 1, 2);
  s.ReadInRange("supersample", &o->supersample, 1, 8);
  s.ReadInRange("noise_sigma", &o->noise_sigma, 0.0, 50.0);
  s.ReadInRange("exposure_s", &o->exposure_s, 0.0, 1.0);
  s.ReadInRange("blur_peak_rate_deg", &o->blur_peak_rate_deg, 1.0, 2000.0);
  s.ReadInRange("blur_shake_rate_deg", &o->blur_shake_rate_deg, 0.0, 2000.0);
  s.ReadInRange("blur_exposure_frac", &o->blur_exposure_frac, 0.01, 1.0);
  s.ReadInRange("blur_gain", &o->blur_gain, 0.0, 1.0);
  s.ReadInRange("drop_turn_deg", &o->drop_turn_deg, -180.0, 180.0);
  s.ReadInRange("dark_gain", &o->dark_gain, 0.0, 1.0);
  s.ReadInRange("weak_distance", &o->weak_distance, 0.5, 2.0);
  s.ReadInRange("weak_amplitude", &o->weak_amplitude, 0.0, 0.3);
  s.ReadInRange("odometry_scale_bias", &o->odometry_scale_bias, -0.5, 0.5);
  s.ReadInRange("odometry_step_noise", &o->odometry_step_noise, 0.0, 1.0);
  s.ReadInRange("odometry_rotation_noise_deg", &o->odometry_rotation_noise_deg, 0.0, 10.0);
  CheckOptions(*o, s, "synth");
}

}  // namespace rumi
