// The rumi-back executable end to end with a fake colmap (no COLMAP run):
// exit codes, config errors and the files written.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/testing/process.h"
#include "common/testing/require.h"
#include "common/testing/temp_dir.h"

namespace fs = std::filesystem;

namespace {

class BackCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    exe_ = rumi::test::BinPath("rumi-back");
    RUMI_REQUIRE(fs::exists(exe_), "build rumi-back first: " << exe_);
    fs::create_directories(dir_ / "win" / "img");
    std::ofstream idx(dir_ / "win" / "rgb.txt");
    idx << "# timestamp filename\n";
    for (int i = 0; i < 4; ++i) {
      const std::string name = "img/" + std::to_string(i) + ".png";
      cv::Mat img(24, 32, CV_8UC1);
      cv::RNG rng(i + 1);
      rng.fill(img, cv::RNG::UNIFORM, 0, 256);  // texture: blank frames never reach COLMAP
      cv::imwrite((dir_ / "win" / name).string(), img);
      idx << "1341847980.72298" << i << " " << name << "\n";
    }
    const fs::path fake = dir_ / "colmap.sh";
    std::ofstream(fake) << "#!/bin/sh\necho 'fake colmap failing' >&2\nexit 1\n";
    ::chmod(fake.c_str(), 0755);
  }
  std::string Config(const std::string& back) {
    const fs::path p = dir_ / "config.yaml";
    std::ofstream(p) << "camera: {width: 32, height: 24, fx: 30, fy: 30, cx: 15.5, cy: 11.5}\n"
                     << "back: {colmap_path: " << (dir_ / "colmap.sh").string()
                     << ", workspace_dir: " << (dir_ / "ws").string() << back << "}\n";
    return p.string();
  }
  int Run(const std::string& args) { return rumi::test::RunLogged(exe_ + " " + args, dir_ / "out.log"); }
  std::string Log() const { return rumi::test::Slurp(dir_ / "out.log"); }

  std::string exe_;
  rumi::TempDir tmp_;
  fs::path dir_ = tmp_.path();
};

TEST_F(BackCliTest, ColmapFailureIsReportedInResultJson) {
  const std::string out = (dir_ / "out").string();
  EXPECT_EQ(Run("--window-dir " + (dir_ / "win").string() + " --config " + Config("") + " --out " + out), 4);
  std::ifstream in(out + "/result.json");
  ASSERT_TRUE(in.good());
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["status"], "colmap_failed");
  EXPECT_NE(j["message"].get<std::string>().find("fake colmap failing"), std::string::npos);
  EXPECT_EQ(j["num_frames"], 4);
  EXPECT_TRUE(fs::is_empty(dir_ / "ws"));  // workspace cleaned
}

TEST_F(BackCliTest, BadConfigAndMissingInputs) {
  const std::string win = " --window-dir " + (dir_ / "win").string() + " --out " + (dir_ / "o").string();
  EXPECT_EQ(Run(win + " --config " + Config(", num_thread: 2")), 2);  // typo
  EXPECT_EQ(Run(win + " --config " + Config(", matcher: fancy")), 2);
  EXPECT_EQ(Run(win + " --config " + Config(", min_registered_images: 1")), 2);
  EXPECT_EQ(Run("--window-dir " + (dir_ / "nowhere").string() + " --out " + (dir_ / "o").string() +
                " --config " + Config("")),
            2);  // a missing input: bad input, like a bad config
  // A typo anywhere stops every process: at the top level, and in another
  // process's section (the front's), not only in back:.
  const std::string typo = Config("");
  std::ofstream(typo, std::ios::app) << "log_levle: debug\n";
  EXPECT_EQ(Run(win + " --config " + typo), 2);
  EXPECT_NE(Log().find("log_levle"), std::string::npos) << Log();
  const std::string front_typo = Config("");
  std::ofstream(front_typo, std::ios::app) << "front: {fsp: 30}\n";
  EXPECT_EQ(Run(win + " --config " + front_typo), 2);
  EXPECT_NE(Log().find("front.fsp"), std::string::npos) << Log();
  EXPECT_EQ(Run("--instance 0 --config " + Config("")), 2);  // shared-memory mode needs --work
}

}  // namespace
