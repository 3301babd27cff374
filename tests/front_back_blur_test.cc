// front -> sampler -> shared memory -> back on a generated `blur` sequence,
// with the real processes (`rumi eval run` starts rumi-manager, rumi-back and
// rumi-front): the front loses track in the blur, the sampler ships the lost
// frames densely, and the back submap COLMAP builds from that window holds
// the frames the front lost, under their exact timestamps.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "common/run_metrics.h"
#include "common/timestamp.h"
#include "common/testing/temp_dir.h"
#include "tests/rumi_cli_util.h"

namespace rumi {
namespace {
namespace fs = std::filesystem;

// The scenario's calibrated defaults at 640x480 (docs/synth.md); 150 frames
// put the 20-frame blur stretch at frames 60..79. (At 320x240 the sharp S1
// frames before the blur registered in some runs only: the pairing with the
// first front submap then fails and the test would be flaky.)
const char* kSynthArgs = "--scenario blur --seed 2 --frames 150 --size 640x480";

using test::Slurp;
int RunRumi(const std::string& args, const fs::path& log) { return test::RunRumiLogged(args, log); }

TEST(FrontBackBlur, BackSubmapCoversTheFramesTheFrontLost) {
  const TempDir tmp;
  const fs::path dir = tmp.Create();
  const fs::path seq = dir / "blur";
  ASSERT_EQ(RunRumi("synth " + seq.string() + " " + kSynthArgs, dir / "synth.log"), 0) << Slurp(dir / "synth.log");
  // The manager bakes settled submaps into its base after 1 s (300 s by
  // default): front#0 is baked long before the back submap arrives, on any
  // machine, and the merge and its audit must not depend on that.
  const fs::path config = dir / "config.yaml";
  {
    std::ofstream c(config);
    c << Slurp(seq / "camera.yaml") << "\nmanager: {bake_after_s: 1}\n";
  }
  const fs::path out = dir / "eval";
  ASSERT_EQ(RunRumi("eval run " + seq.string() + " --dataset tum --config " + config.string() +
                        " --out " + out.string() + " --rate max --sequence blur",
                    dir / "eval.log"),
            0)
      << Slurp(dir / "eval.log");
  const fs::path run = out / "run_1";

  // The blur stretch, from the generator's description.
  const nlohmann::json scen = nlohmann::json::parse(Slurp(seq / "scenario.json"));
  Timestamp hard0 = 0, hard1 = 0;
  ASSERT_TRUE(ParseSecondsToNs(scen["hard_stretch"]["seconds"][0].get<std::string>(), &hard0));
  ASSERT_TRUE(ParseSecondsToNs(scen["hard_stretch"]["seconds"][1].get<std::string>(), &hard1));

  // Premise: the front lost track in (or right after) the blur.
  const std::vector<FrontFrameLine> frames = ReadFrontFrames((run / "front_frames.txt").string());
  ASSERT_EQ(frames.size(), 150u);
  std::set<Timestamp> lost;
  bool tracked_once = false;
  for (const FrontFrameLine& f : frames) {
    tracked_once |= f.state == TrackingState::kTracking;
    if (tracked_once && f.state != TrackingState::kTracking) lost.insert(f.t);
  }
  const auto lost_in_blur =
      std::count_if(lost.begin(), lost.end(), [&](Timestamp t) { return t >= hard0 && t <= hard1; });
  ASSERT_GE(lost_in_blur, 10) << "the front did not lose track in the blur: the test proves nothing";

  // The sampler shipped every lost frame (S2) in one window.
  std::set<Timestamp> s2;
  for (const FrontSampleLine& s : ReadFrontSamples((run / "front_samples.txt").string()))
    if (s.set == 2) s2.insert(s.t);
  for (Timestamp t : lost) EXPECT_TRUE(s2.count(t)) << FormatSeconds(t) << " lost but not shipped";

  // The back built one model holding >= 90 % of the window (the back's
  // target) and >= 80 % of the frames the front lost (COLMAP drops a few of
  // the most smeared ones: 3 of 26-29 in the runs measured); keyframe
  // timestamps are exactly those of the window (the strings compare equal).
  const nlohmann::json bs = nlohmann::json::parse(Slurp(run / "back" / "back_stats.json"));
  ASSERT_EQ(bs["windows_done"].get<int>(), 1) << bs.dump(1);
  const nlohmann::json& w = bs["per_window"][0];
  std::set<std::string> window_stamps, lost_stamps;
  for (const FrontSampleLine& s : ReadFrontSamples((run / "front_samples.txt").string()))
    window_stamps.insert(FormatSeconds(s.t));
  for (Timestamp t : s2) lost_stamps.insert(FormatSeconds(t));
  ASSERT_EQ(static_cast<int>(window_stamps.size()), w["frames"].get<int>());
  size_t best = 0, best_lost = 0;
  for (const auto& stamps : w["submap_timestamps"]) {
    size_t in_window = 0, lost_covered = 0;
    for (const auto& s : stamps) {
      in_window += window_stamps.count(s.get<std::string>());
      lost_covered += lost_stamps.count(s.get<std::string>());
    }
    EXPECT_EQ(in_window, stamps.size()) << "a back keyframe timestamp is not a window timestamp";
    if (stamps.size() > best) {
      best = stamps.size();
      best_lost = lost_covered;
    }
  }
  EXPECT_GE(10 * best, 9 * window_stamps.size()) << w.dump(1);
  EXPECT_GE(10 * best_lost, 8 * s2.size()) << "back submap covers " << best_lost << " of " << s2.size()
                                           << " lost frames\n" << w.dump(1);

  // And with it the manager's merged map covers more than the front alone.
  const nlohmann::json m = nlohmann::json::parse(Slurp(run / "metrics.json"));
  EXPECT_GE(m["merges"].get<int>(), 1);
  EXPECT_GT(m["merged_tracking_rate_time"].get<double>(), m["front_tracking_rate_time"].get<double>() + 0.3);
  // front#0 was baked before the back submap came (the premise of the
  // config above) ...
  const nlohmann::json ms = nlohmann::json::parse(Slurp(run / "manager_stats.json"));
  EXPECT_GE(ms["baked"].get<int>(), 1) << "nothing baked: the audit's baked path is not checked";
  // ... and the merge audit judged the accepted merges against the ground
  // truth, and none of them made the map worse.
  ASSERT_TRUE(m.contains("merge_audit")) << m.dump(1);
  int accepted = 0;
  for (const auto& a : m["merge_audit"]) {
    if (!a["accepted"].get<bool>()) continue;
    ++accepted;
    EXPECT_TRUE(a["ate_joint"].is_number() && a["ate_a"].is_number()) << a.dump();
  }
  EXPECT_EQ(accepted, m["merges"].get<int>()) << m["merge_audit"].dump(1);
  EXPECT_EQ(m["merges_harmful"].get<int>(), 0) << m["merge_audit"].dump(1);
  EXPECT_TRUE(m["merged_ate_front_frames"].is_number());
  std::printf("front lost %zu frames (%ld in the blur), window %zu (S2 %zu), back submap holds %zu (%zu lost ones); "
              "front %.1f %% -> merged %.1f %%, back %.1f s\n",
              lost.size(), static_cast<long>(lost_in_blur), window_stamps.size(), s2.size(), best, best_lost,
              100 * m["front_tracking_rate_time"].get<double>(), 100 * m["merged_tracking_rate_time"].get<double>(),
              m["back_seconds"].get<double>());
}

}  // namespace
}  // namespace rumi
