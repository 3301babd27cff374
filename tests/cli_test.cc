// End-to-end checks of the `rumi` CLI as a user runs it: exit codes, printed
// figures and error messages.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "common/testing/process.h"
#include "common/testing/temp_dir.h"

namespace {
namespace fs = std::filesystem;

using Result = rumi::test::CommandResult;

Result RunRumi(const std::string& args) { return rumi::test::RunCommand(rumi::test::BinPath("rumi") + " " + args); }

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
  const rumi::TempDir tmp;
  const fs::path dir = tmp.Create();
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
  const rumi::TempDir tmp;
  const fs::path cfg = tmp.Create() / "grid.yaml";
  std::ofstream(cfg) << "grid: {resolution_m: 0, ism: {p_occ: 0.95}}\n";
  r = RunRumi("grid /nonexistent/state --config " + cfg.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("resolution_m"), std::string::npos) << r.out;
}

// `rumi view` refuses to serve a network address without a token, before it listens.
TEST(Cli, ViewRefusesANetworkAddressWithoutAToken) {
  const rumi::TempDir tmp;
  tmp.Create();
  Result r = RunRumi("view " + tmp.str() + " --bind 0.0.0.0 --port 0");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("token"), std::string::npos) << r.out;
  r = RunRumi("view /nonexistent/state");
  EXPECT_NE(r.code, 0) << r.out;
}

TEST(Cli, EvalTablePrintsPaperLayout) {
  const rumi::TempDir tmp;
  const fs::path dir = tmp.path();
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
}

// The listing of every option: a section line, then one line per key (nested
// keys dotted) with its default and, as a YAML comment, its meaning and range.
TEST(Cli, ConfigDefaultsListsEveryOptionWithItsMeaning) {
  const Result r = RunRumi("config defaults");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.rfind("log_level: 'info'  # ", 0), 0u) << r.out.substr(0, 200);
  for (const char* section : {"\ncamera:\n", "\nsource:\n", "\nfront:\n", "\nback:\n", "\nmanager:\n",
                              "\ngrid:\n", "\ndaemon:\n"})
    EXPECT_NE(r.out.find(section), std::string::npos) << section;
  EXPECT_NE(r.out.find("\n  link.bind: '0.0.0.0:5600'  # "), std::string::npos) << "a nested key, dotted";
  std::istringstream lines(r.out);
  for (std::string line; std::getline(lines, line);)  // a section, or a key and its default
    EXPECT_TRUE(!line.empty() && (line.back() == ':' || line.find(": ") != std::string::npos)) << line;
  const Result none = RunRumi("config");  // a subcommand is required
  EXPECT_NE(none.code, 0) << none.out;
}

TEST(Cli, LinkPlotDrawsTheFramesLog) {
  const rumi::TempDir tmp;
  const fs::path csv = tmp.Create() / "frames.csv";
  {
    std::ofstream f(csv);
    f << "frame_id,robot_us,ground_capture_us,first_us,complete_us,latency_ms,fragments,recovered,status\n";
    for (int i = 0; i < 20; ++i) f << i << ",1,2,3,4," << 40 + i << ",8,0,complete\n";
    f << "20,0,0,0,0,0,0,0,dropped\n";
  }
  const fs::path png = tmp.path() / "latency.png";
  Result r = RunRumi("link-plot " + csv.string() + " --out " + png.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("link-plot: 21 frames -> " + png.string()), std::string::npos) << r.out;
  EXPECT_GT(fs::file_size(png), 0u);
  r = RunRumi("link-plot " + csv.string());  // beside the CSV by default
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(tmp.path() / "frames.png"));
  std::ofstream(csv) << "frame_id,robot_us\n1,2,3\n";
  r = RunRumi("link-plot " + csv.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find(":2:"), std::string::npos) << r.out;
}

// A map_server grid (P5 PGM + YAML) of 4 x 3 cells: a wall row on top, free below.
void WriteGrid(const fs::path& dir, const std::string& name) {
  fs::create_directories(dir);
  std::string pgm = "P5\n4 3\n255\n";
  pgm += std::string(4, '\0') + std::string(8, '\xfe');
  std::ofstream(dir / (name + ".pgm"), std::ios::binary) << pgm;
  std::ofstream(dir / (name + ".yaml")) << "image: " << name << ".pgm\nresolution: 0.5\norigin: [0, 0, 0]\n"
                                        << "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
}

TEST(Cli, EvalGridScoresAGridAgainstTheTruth) {
  const rumi::TempDir tmp;
  const fs::path run = tmp.path() / "run", seq = tmp.path() / "seq";
  WriteGrid(run, "grid");
  WriteGrid(seq, "floorplan");
  // The same path in both frames: the alignment is the identity.
  const std::string path = "1.0 0.2 0.2 0 0 0 0 1\n2.0 1.2 0.2 0 0 0 0 1\n3.0 1.2 0.7 0 0 0 0 1\n"
                           "4.0 1.7 0.7 0 0 0 0 1\n5.0 0.2 0.7 0 0 0 0 1\n";
  std::ofstream(run / "grid_trajectory.txt") << path;
  std::ofstream(seq / "groundtruth.txt") << path;
  const Result r = RunRumi("eval grid " + run.string() + " " + seq.string() + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* figure : {"\"occupied_iou\": 1.0000", "\"free_iou\": 1.0000", "\"coverage\": 1.0000",
                             "\"true_free_cells\": 8", "\"true_occupied_cells\": 4", "\"alignment_scale\": 1.0000",
                             "\"walls_found\": 4", "\"false_walls\": 0"})
    EXPECT_NE(r.out.find(figure), std::string::npos) << figure << "\n" << r.out;
  const Result missing = RunRumi("eval grid " + (tmp.path() / "nothing").string() + " " + seq.string());
  EXPECT_EQ(missing.code, 1) << missing.out;
  EXPECT_NE(missing.out.find("grid.yaml"), std::string::npos) << missing.out;
}

TEST(Cli, EvalSessionWithoutASessionIsAClearError) {
  const rumi::TempDir tmp;
  const Result r = RunRumi("eval session " + tmp.Create().string() + " /nonexistent/seq --dataset tum");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("holds no merged.txt: is it the state folder of a rumid session?"), std::string::npos)
      << r.out;
}

}  // namespace
