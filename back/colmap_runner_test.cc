// The COLMAP command lines of an attempt, and a run against a fake `colmap`
// (a shell script): no COLMAP needed.
#include "back/colmap_runner.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>

#include "common/testing/temp_dir.h"

namespace rumi {
namespace {

using Args = std::vector<std::string>;

PinholeCameraOptions Camera() {
  PinholeCameraOptions c;
  c.width = 64;
  c.height = 48;
  c.fx = 50;
  c.fy = 52;
  c.cx = 31.5;
  c.cy = 23.25;
  return c;
}

TEST(ColmapRunner, NumbersGoToColmapExactly) {
  EXPECT_EQ(ColmapNumber(32), "32");
  EXPECT_EQ(ColmapNumber(0.004), "0.0040000000000000001");
}

TEST(ColmapRunner, TheFirstAttemptExtractsMatchesTheSelectedPairsAndMaps) {
  BackOptions o;
  o.sift_upsample_below_width = 0;
  const ColmapWorkspace ws("/w", 7, 0);
  const std::string dir = ws.dir().string(), db = dir + "/database.db";
  const std::vector<ColmapStep> steps = ColmapAttemptSteps(o, Camera(), ws, {0.004, ""}, false);
  ASSERT_EQ(steps.size(), 3u);
  EXPECT_STREQ(steps[0].name, "feature_extraction");
  EXPECT_EQ(steps[0].args,
            (Args{"feature_extractor", "--database_path", db, "--image_path", dir + "/images",
                  "--ImageReader.camera_model", "PINHOLE", "--ImageReader.single_camera", "1",
                  "--ImageReader.camera_params", "50,52,32,23.75", "--SiftExtraction.use_gpu", "0",
                  "--SiftExtraction.num_threads", "2", "--SiftExtraction.max_num_features", "2048",
                  "--SiftExtraction.first_octave", "0", "--SiftExtraction.peak_threshold",
                  "0.0040000000000000001"}));
  EXPECT_STREQ(steps[1].name, "matching");
  EXPECT_EQ(steps[1].args, (Args{"matches_importer", "--database_path", db, "--match_list_path", dir + "/pairs.txt",
                                 "--match_type", "pairs", "--SiftMatching.use_gpu", "0",
                                 "--SiftMatching.num_threads", "2"}));
  EXPECT_STREQ(steps[2].name, "mapping");
  EXPECT_EQ(steps[2].args,
            (Args{"mapper", "--database_path", db, "--image_path", dir + "/images", "--output_path",
                  dir + "/sparse", "--Mapper.num_threads", "2", "--Mapper.ba_refine_focal_length", "0",
                  "--Mapper.ba_refine_principal_point", "0", "--Mapper.ba_refine_extra_params", "0",
                  "--Mapper.min_model_size", "10"}));
  EXPECT_EQ(steps[0].seconds, &BackStepTimes::feature_extraction_s);
  EXPECT_EQ(steps[1].cpu_seconds, &BackStepTimes::matching_cpu_s);
  EXPECT_EQ(steps[2].seconds, &BackStepTimes::mapping_s);
}

TEST(ColmapRunner, ExtractionOptionsFollowTheBackOptions) {
  BackOptions o;  // upsampled below 640 pixels across
  o.sift_domain_size_pooling = true;
  const ColmapWorkspace ws("/w", 7, 0);
  const Args a = ColmapAttemptSteps(o, Camera(), ws, {0, "_retry"}, false)[0].args;
  EXPECT_EQ(a[2], ws.dir().string() + "/database_retry.db");
  const Args tail(a.end() - 4, a.end());
  EXPECT_EQ(tail, (Args{"--SiftExtraction.first_octave", "-1", "--SiftExtraction.domain_size_pooling", "1"}))
      << "no peak threshold at 0 (COLMAP's default)";
}

TEST(ColmapRunner, AFillMatchesTheOtherPairsOnTheFeaturesItHas) {
  BackOptions o;
  const ColmapWorkspace ws("/w", 7, 0);
  const std::string dir = ws.dir().string();
  // Without blank stretches every pair; no extraction.
  std::vector<ColmapStep> steps = ColmapAttemptSteps(o, Camera(), ws, {0.004, "_retry", true}, false);
  ASSERT_EQ(steps.size(), 2u);
  EXPECT_EQ(steps[0].args, (Args{"exhaustive_matcher", "--database_path", dir + "/database_retry.db",
                                 "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads", "2"}));
  EXPECT_EQ(steps[1].args[6], dir + "/sparse_retry_all");
  // With them, the pairs within each side (pairs_fill.txt).
  steps = ColmapAttemptSteps(o, Camera(), ws, {0.004, "", true}, true);
  ASSERT_EQ(steps.size(), 2u);
  EXPECT_EQ(steps[0].args[0], "matches_importer");
  EXPECT_EQ(steps[0].args[4], dir + "/pairs_fill.txt");
  EXPECT_EQ(steps[1].args[6], dir + "/sparse_all");
  // The sequential matcher picks its own pairs.
  o.matcher = "sequential";
  o.num_threads = 3;
  steps = ColmapAttemptSteps(o, Camera(), ws, {0.004, ""}, false);
  EXPECT_EQ(steps[1].args, (Args{"sequential_matcher", "--database_path", dir + "/database.db",
                                 "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads", "3",
                                 "--SequentialMatching.overlap", "10"}));
}

TEST(ColmapRunner, AFailingStepEndsTheAttemptWithItsNameAndTime) {
  TempDir tmp;
  std::filesystem::create_directories(tmp.path());
  const std::string fake = tmp / "colmap.sh";
  std::ofstream(fake) << "#!/bin/sh\nif [ $1 = matches_importer ]; then exit 3; fi\n";
  ::chmod(fake.c_str(), 0755);
  BackOptions o;
  o.colmap_path = fake;
  o.low_priority = false;
  ImageWindow w;
  w.id = 4;
  w.camera = Camera();
  ColmapWorkspace ws(tmp / "ws", w.id, 0);
  std::string why;
  ASSERT_TRUE(ws.Create(false, &why)) << why;
  std::vector<std::string> stages;
  const std::function<void(const std::string&)> on_stage = [&](const std::string& s) { stages.push_back(s); };
  BackStepTimes times;
  ColmapRunner runner(o, w, ws, false, nullptr, on_stage, &times);
  const ColmapAttempt at = runner.Run({0.004, ""});
  EXPECT_EQ(at.status, BackStatus::kColmapFailed);
  EXPECT_EQ(at.message.rfind("matching: ", 0), 0u) << at.message;
  EXPECT_EQ(stages, (std::vector<std::string>{"feature_extractor", "matches_importer"}));
  EXPECT_GT(times.feature_extraction_s, 0);
  EXPECT_GT(times.matching_s, 0);
  EXPECT_EQ(times.mapping_s, 0);
  EXPECT_TRUE(std::filesystem::is_directory(ws.sparse("", false)));
}

}  // namespace
}  // namespace rumi
