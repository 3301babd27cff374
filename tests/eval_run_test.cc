// `rumi synth` -> `rumi eval run` (real rumi-front process, shm, replay) on a
// short generated sequence; checks metrics.json's keys and values.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/rumi_cli_util.h"

namespace {
namespace fs = std::filesystem;

using rumi::test::Slurp;
int RunRumi(const std::string& args, const fs::path& log) { return rumi::test::RunRumiLogged(args, log); }

TEST(EvalRun, FrontOnlyRunWritesCompleteMetrics) {
  const fs::path dir = fs::temp_directory_path() / ("rumi_eval_run_test_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path seq = dir / "seq";
  ASSERT_EQ(RunRumi("synth " + seq.string() + " --scenario smooth --frames 60 --size 320x240 --seed 3",
                dir / "synth.log"), 0)
      << Slurp(dir / "synth.log");
  const fs::path out = dir / "eval";
  ASSERT_EQ(RunRumi("eval run " + seq.string() + " --dataset tum --config " + (seq / "camera.yaml").string() +
                    " --out " + out.string() + " --rate max --no-back --sequence smooth60 --odometry " +
                    (seq / "odometry.txt").string(),
                dir / "eval.log"), 0)
      << Slurp(dir / "eval.log");
  const nlohmann::json m = nlohmann::json::parse(Slurp(out / "run_1" / "metrics.json"));
  for (const char* key :
       {"frames", "duration_s", "front_tracking_rate_time", "front_tracking_rate_frames",
        "merged_tracking_rate_time", "merged_tracking_rate_frames", "front_ms_mean", "front_ms_median",
        "front_ms_p95", "back_windows", "back_seconds", "merges", "saved_frames", "saved_frames_postculled",
        "submaps_front", "submaps_back"}) {
    ASSERT_TRUE(m.contains(key)) << key;
    EXPECT_TRUE(m[key].is_number()) << key << " = " << m[key];
  }
  for (const char* key : {"front_ate_rmse", "merged_ate_rmse"}) {
    ASSERT_TRUE(m.contains(key)) << key;
    EXPECT_TRUE(m[key].is_number() || m[key].is_null()) << key;
  }
  EXPECT_EQ(m["sequence"], "smooth60");
  EXPECT_EQ(m["frames"].get<int>(), 60);
  EXPECT_NEAR(m["duration_s"].get<double>(), 59.0 / 30.0, 1e-6);
  // The front initialises within the first frames and tracks the rest.
  const double rate = m["front_tracking_rate_time"].get<double>();
  EXPECT_GT(rate, 0.5);
  EXPECT_LE(rate, 1.0);
  EXPECT_LE(m["front_tracking_rate_frames"].get<double>(), 1.0);
  ASSERT_TRUE(m["front_ate_rmse"].is_number());
  EXPECT_LT(m["front_ate_rmse"].get<double>(), 0.1);  // metres, on a ~0.9 m path
  EXPECT_GT(m["front_ms_median"].get<double>(), 0.0);
  EXPECT_GE(m["front_ms_p95"].get<double>(), m["front_ms_median"].get<double>());
  EXPECT_GE(m["submaps_front"].get<int>(), 1);
  // Front alone: no back, no merges, merged = front.
  EXPECT_EQ(m["back_windows"].get<int>(), 0);
  EXPECT_EQ(m["merges"].get<int>(), 0);
  EXPECT_DOUBLE_EQ(m["merged_tracking_rate_time"].get<double>(), rate);
  EXPECT_TRUE(fs::exists(out / "run_1" / "top_view.png"));
  EXPECT_TRUE(fs::exists(out / "run_1" / "timeline.png"));
  const std::string log = Slurp(dir / "eval.log");
  EXPECT_NE(log.find("| smooth60 |"), std::string::npos) << log;  // the table is printed
  // The synthetic pose source reached the front (one pose per frame).
  const std::string front_log = Slurp(out / "run_1" / "rumi-front.log");
  EXPECT_NE(front_log.find("pose source " + (seq / "odometry.txt").string() + " (60 poses)"), std::string::npos)
      << front_log;
  fs::remove_all(dir);
}

}  // namespace
