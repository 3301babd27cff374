// End-to-end checks of the `rumi` CLI as a user runs it: exit codes, printed
// figures and error messages.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace {
namespace fs = std::filesystem;

struct Result {
  int code;
  std::string out;
};

Result RunRumi(const std::string& args) {
  const std::string cmd = std::string(std::getenv("RUMI_BIN_DIR")) + "/rumi " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  Result r{-1, ""};
  if (!p) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

const std::string kEvo = std::string(RUMI_SHARED_DATA_DIR) + "/eval-reference/evo/";

TEST(Cli, EvalAteSim3MatchesEvo) {
  const Result r = RunRumi("eval ate " + kEvo + "freiburg1_xyz-ORB_kf_mono.txt " + kEvo +
                       "freiburg1_xyz-groundtruth.txt --align sim3 --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("0.0097545818986"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("32"), std::string::npos) << r.out;
}

TEST(Cli, EvalAteFollowsEvoOnSharedAndDuplicatedPosesUnlessStrict) {
  // The official TUM fr2_desk ground truth has a duplicated timestamp: evo
  // reads it (its nearest search picks the first); --strict refuses it.
  const std::string fr2 = kEvo + "fr2_desk_ORB.txt " + kEvo + "fr2_desk_groundtruth.txt";
  Result r = RunRumi("eval ate " + fr2 + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("\"one_to_one\": false"), std::string::npos) << r.out;
  r = RunRumi("eval ate " + fr2 + " --strict");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("duplicates"), std::string::npos) << r.out;
  // Two estimate poses 12 ms apart nearest to one ground-truth pose: evo
  // pairs both with it, --strict only the closer.
  const fs::path dir = fs::temp_directory_path() / ("rumi_cli_evo_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  // (evo walks the shorter trajectory, here the estimate.)
  std::ofstream(dir / "gt.txt") << "0.000 0 0 0 0 0 0 1\n1.000 1 0 0 0 0 0 1\n2.000 2 1 0 0 0 0 1\n"
                                   "3.000 3 0 1 0 0 0 1\n4.000 4 1 1 0 0 0 1\n5.000 5 2 1 0 0 0 1\n";
  std::ofstream(dir / "est.txt") << "0.005 0 0 0 0 0 0 1\n0.017 0 0 0 0 0 0 1\n2.000 2 1 0 0 0 0 1\n"
                                    "3.000 3 0 1 0 0 0 1\n4.000 4 1 1 0 0 0 1\n";
  const std::string pair = (dir / "est.txt").string() + " " + (dir / "gt.txt").string() + " --json";
  r = RunRumi("eval ate " + pair);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("\"pairs\": 5"), std::string::npos) << r.out;
  r = RunRumi("eval ate " + pair + " --strict");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("\"pairs\": 4"), std::string::npos) << r.out;
  fs::remove_all(dir);
}

TEST(Cli, EvalAteMissingFileIsAClearError) {
  const Result r = RunRumi("eval ate /nonexistent/est.txt " + kEvo + "freiburg1_xyz-groundtruth.txt");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("/nonexistent/est.txt"), std::string::npos) << r.out;
}

TEST(Cli, GridBadInputIsAClearError) {
  Result r = RunRumi("grid /nonexistent/state");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("/nonexistent/state: no such folder or map file"), std::string::npos) << r.out;
  const fs::path cfg = fs::temp_directory_path() / ("rumi_cli_grid_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(cfg) << "grid: {resolution_m: 0, ism: {p_occ: 0.95}}\n";
  r = RunRumi("grid /nonexistent/state --config " + cfg.string());
  fs::remove(cfg);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("resolution_m"), std::string::npos) << r.out;
}

TEST(Cli, EvalTablePrintsPaperLayout) {
  const fs::path dir = fs::temp_directory_path() / ("rumi_cli_test_" + std::to_string(getpid()));
  fs::create_directories(dir / "drop" / "run_01");
  std::ofstream(dir / "drop" / "run_01" / "metrics.json")
      << R"({"sequence":"drop","front_tracking_rate_time":0.31,"front_ate_rmse":null,)"
      << R"("merged_tracking_rate_time":0.97,"merged_ate_rmse":0.012,"front_saved_frames":50,)"
      << R"("saved_frames":300,"saved_frames_postculled":90})";
  const Result r = RunRumi("eval table " + (dir / "drop").string() + " --format md");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("| drop | 97.0 | 0.012 | 90 | 97.0 | 0.012 | 300 | 31.0 | - | 50 |"), std::string::npos)
      << r.out;
  const Result bad = RunRumi("eval table " + dir.string());  // no metrics.json directly or in run dirs
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.out.find("no metrics.json"), std::string::npos) << bad.out;
  fs::remove_all(dir);
}

}  // namespace
