// BackSubmapBuilder against fake `colmap` executables (shell scripts written
// here): failures, hangs, empty output and canned models, without COLMAP.
#include "back/testing/canned_colmap_model.h"
#include "back/back_submap_builder.h"
#include "back/colmap_database.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <iterator>
#include <set>
#include <sstream>

#include "common/orb_extractor.h"
#include "common/testing/temp_dir.h"

namespace fs = std::filesystem;

namespace rumi {
namespace {

class BackSubmapBuilderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    tmp_.Create();
    options_.workspace_dir = (root_ / "ws").string();
    options_.step_timeout_s = 20;
    window_.id = 12;
    window_.camera.width = 64;
    window_.camera.height = 48;
    window_.camera.fx = 50;
    window_.camera.fy = 52;
    window_.camera.cx = 31.5;
    window_.camera.cy = 23.25;
    cv::RNG rng(3);
    for (int i = 0; i < 5; ++i) {
      WindowFrame f;
      f.timestamp = 1341847980722988001LL + 33333333LL * i;
      f.image = cv::Mat(48, 64, CV_8UC1);
      rng.fill(f.image, cv::RNG::UNIFORM, 0, 256);  // texture: a blank frame never counts as missing
      window_.frames.push_back(f);
    }
  }

  // A fake colmap: logs its arguments, then runs `body` with $1 = command.
  std::string FakeColmap(const std::string& body) {
    const fs::path p = root_ / "fake_colmap.sh";
    std::ofstream(p) << "#!/bin/sh\necho \"$@\" >> " << (root_ / "args.txt").string() << "\n"
                     << "cmd=$1\nout=''\nwhile [ $# -gt 0 ]; do\n"
                     << "  if [ \"$1\" = --output_path ]; then out=$2; fi\n  shift\ndone\n"
                     << body << "\n";
    ::chmod(p.c_str(), 0755);
    return p.string();
  }
  // A fake colmap whose mapper writes a model of 3 of the 5 frames, or of
  // all 5 into a model folder ending in `full`.
  std::string MapperFewOrAll(const std::string& full, const std::string& before = "") {
    std::vector<Timestamp> t;
    for (const auto& f : window_.frames) t.push_back(f.timestamp);
    const fs::path few = root_ / "few", all = root_ / "all";
    WriteCannedModel(few / "0", window_.camera, {t[0], t[1], t[2]});
    WriteCannedModel(all / "0", window_.camera, t);
    return FakeColmap(before + "if [ $cmd = mapper ]; then case \"$out\" in *" + full + ") cp -r " + all.string() +
                      "/* $out/;; *) cp -r " + few.string() + "/* $out/;; esac; fi");
  }
  // Shell for a fake colmap: its feature extractor leaves a COLMAP database
  // where frames `poor` have 20 SIFT keypoints and the others 500, and the
  // pairs of frames `unlinked` have 5 inliers (not verified).
  std::string DatabaseWithPoorFrames(const std::set<int>& poor, const std::set<int>& unlinked = {}) {
    std::vector<std::pair<std::string, int>> rows;
    for (size_t i = 0; i < window_.frames.size(); ++i)
      rows.push_back({ColmapImageName(window_.frames[i].timestamp), poor.count(int(i)) ? 20 : 500});
    const fs::path db =
        root_ / ("canned_" + std::to_string(poor.size()) + "_" + std::to_string(unlinked.size()) + ".db");
    EXPECT_TRUE(WriteCannedColmapDatabase(db, rows));
    for (const int i : unlinked) {
      sqlite3* h = nullptr;
      EXPECT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
      const std::string id = std::to_string(i + 1);  // image ids follow the frames
      const std::string sql = "UPDATE two_view_geometries SET rows = 5 WHERE pair_id / 2147483647 = " + id +
                              " OR pair_id % 2147483647 = " + id;
      EXPECT_EQ(sqlite3_exec(h, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK);
      sqlite3_close(h);
    }
    return "if [ $cmd = feature_extractor ]; then cp " + db.string() + " $(tail -n 1 " +
           (root_ / "args.txt").string() + " | sed 's/.*--database_path \\([^ ]*\\).*/\\1/'); fi\n";
  }
  // One attempt whose mapper leaves the models under `canned`; no ORB corners.
  void MapperLeaves(const fs::path& canned) {
    options_.colmap_path = FakeColmap("if [ $cmd = mapper ]; then cp -r " + canned.string() + "/* $out/; fi");
    options_.retry_below_registered = 0;
    options_.orb_features = 0;
  }
  // The window becomes 9 frames of noise whose frames 3-5 are covered (blank); their timestamps.
  std::vector<Timestamp> CoverFrames3To5() {
    window_.frames.clear();
    cv::RNG rng(7);
    std::vector<Timestamp> t;
    for (int i = 0; i < 9; ++i) {
      WindowFrame f;
      f.timestamp = 1341847980722988001LL + 33333333LL * i;
      f.image = cv::Mat(48, 64, CV_8UC1, cv::Scalar(0));
      if (i < 3 || i > 5) rng.fill(f.image, cv::RNG::UNIFORM, 0, 256);
      window_.frames.push_back(f);
      t.push_back(f.timestamp);
    }
    return t;
  }
  std::string Args() const {
    std::ifstream in(root_ / "args.txt");
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }
  bool WorkspaceEmpty() const {
    return !fs::exists(options_.workspace_dir) || fs::is_empty(options_.workspace_dir);
  }

  TempDir tmp_;
  fs::path root_ = tmp_.path();
  BackOptions options_;
  ImageWindow window_;
};

TEST_F(BackSubmapBuilderTest, FailingStepIsReportedAndWorkspaceRemoved) {
  options_.colmap_path = FakeColmap(
      "if [ $cmd = matches_importer ]; then echo 'ERROR: database locked' >&2; exit 1; fi");
  BackSubmapBuilder b(options_);
  const BackResult r = b.Build(window_);
  EXPECT_EQ(r.status, BackStatus::kColmapFailed);
  EXPECT_NE(r.message.find("matching"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("database locked"), std::string::npos) << r.message;
  EXPECT_TRUE(r.submaps.empty());
  EXPECT_TRUE(WorkspaceEmpty());
  // The mapper never ran.
  EXPECT_EQ(Args().find("mapper"), std::string::npos);
}

TEST_F(BackSubmapBuilderTest, HangingStepTimesOut) {
  options_.colmap_path = FakeColmap("if [ $cmd = mapper ]; then sleep 60; fi");
  options_.step_timeout_s = 0.5;
  BackSubmapBuilder b(options_);
  const BackResult r = b.Build(window_);
  EXPECT_EQ(r.status, BackStatus::kTimeout);
  EXPECT_NE(r.message.find("mapping"), std::string::npos) << r.message;
  EXPECT_GE(r.times.mapping_s, 0.5);
  EXPECT_LT(r.times.mapping_s, 30.0);  // killed, not waited for
  EXPECT_TRUE(WorkspaceEmpty());
}

TEST_F(BackSubmapBuilderTest, MissingColmapIsReported) {
  options_.colmap_path = (root_ / "no_such_colmap").string();
  BackSubmapBuilder b(options_);
  const BackResult r = b.Build(window_);
  EXPECT_EQ(r.status, BackStatus::kColmapFailed);
  EXPECT_NE(r.message.find("no_such_colmap"), std::string::npos) << r.message;
  EXPECT_TRUE(WorkspaceEmpty());
}

TEST_F(BackSubmapBuilderTest, NoModelIsReported) {
  options_.colmap_path = FakeColmap("exit 0");
  BackSubmapBuilder b(options_);
  const BackResult r = b.Build(window_);
  EXPECT_EQ(r.status, BackStatus::kNoModel);
  EXPECT_TRUE(WorkspaceEmpty());
}

TEST_F(BackSubmapBuilderTest, InvalidWindowsAreRefused) {
  options_.colmap_path = FakeColmap("exit 0");
  BackSubmapBuilder b(options_);
  ImageWindow w = window_;
  w.frames.resize(2);  // below min_registered_images
  EXPECT_EQ(b.Build(w).status, BackStatus::kInvalidWindow);
  w = window_;
  w.frames[3].timestamp = w.frames[2].timestamp;
  BackResult r = b.Build(w);
  EXPECT_EQ(r.status, BackStatus::kInvalidWindow);
  EXPECT_NE(r.message.find("increasing"), std::string::npos) << r.message;
  w = window_;
  w.frames[1].image = cv::Mat(47, 64, CV_8UC1);
  EXPECT_EQ(b.Build(w).status, BackStatus::kInvalidWindow);
  w = window_;
  w.frames[0].image = cv::Mat();
  EXPECT_EQ(b.Build(w).status, BackStatus::kInvalidWindow);
  // Nothing was started for an invalid window.
  EXPECT_EQ(Args(), "");
}

TEST_F(BackSubmapBuilderTest, ModelsBecomeSubmapsAndArgumentsAreRight) {
  // Model 0: 3 frames; model 1: 4 frames; model 2: 2 frames (below the minimum).
  for (size_t i = 0; i < window_.frames.size(); ++i) window_.frames[i].image.setTo(10 * i);  // flat: no ORB corner
  options_.blank_max_stddev = 0;  // flat frames are blank otherwise
  std::vector<Timestamp> t;
  for (const auto& f : window_.frames) t.push_back(f.timestamp);
  const fs::path canned = root_ / "canned";
  WriteCannedModel(canned / "0", window_.camera, {t[0], t[1], t[2]});
  WriteCannedModel(canned / "1", window_.camera, {t[1], t[2], t[3], t[4]});
  WriteCannedModel(canned / "2", window_.camera, {t[3], t[4]});
  options_.colmap_path = FakeColmap(
      "if [ $cmd = feature_extractor ]; then ls " + (root_ / "ws").string() +
      "/*/images > " + (root_ / "names.txt").string() +
      "; fi\nif [ $cmd = mapper ]; then cp -r " + canned.string() + "/* $out/; fi");
  options_.keep_workspaces = true;
  BackSubmapBuilder b(options_, /*first_submap_id=*/100);
  const BackResult r = b.Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_EQ(r.window_id, 12);
  ASSERT_EQ(r.submaps.size(), 2u);
  // Largest model first; ids handed out in that order.
  EXPECT_EQ(r.submaps[0].keyframes.size(), 4u);
  EXPECT_EQ(r.submaps[0].id, 100);
  EXPECT_EQ(r.submaps[1].id, 101);
  EXPECT_EQ(r.submaps[0].source, SubmapSource::kBack);
  EXPECT_EQ(r.submaps[0].keyframes.front().timestamp, t[1]);  // exact ns
  EXPECT_EQ(r.submaps[1].keyframes.back().timestamp, t[2]);
  EXPECT_EQ(r.num_registered, 7);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("2 registered"), std::string::npos) << r.warnings[0];
  EXPECT_DOUBLE_EQ(r.submaps[0].camera.cx, 31.5);
  EXPECT_DOUBLE_EQ(r.submaps[0].camera.cy, 23.25);
  EXPECT_FLOAT_EQ(r.submaps[0].keyframes[0].keypoints[0].x(), 100.0f);
  // ORB corners follow the SIFT keypoints (none on these flat images): one
  // descriptor row per keypoint, all zeros for the SIFT ones.
  for (const Submap& m : r.submaps)
    for (const Keyframe& kf : m.keyframes) {
      ASSERT_EQ(kf.descriptors.rows, int(kf.keypoints.size()));
      for (int i = 0; i < kf.descriptors.rows; ++i) EXPECT_FALSE(HasDescriptor(kf.descriptors.ptr<uint8_t>(i)));
    }

  // Images handed to COLMAP are named by zero-padded timestamps.
  std::ifstream names(root_ / "names.txt");
  std::vector<std::string> listed((std::istream_iterator<std::string>(names)), {});
  ASSERT_EQ(listed.size(), 5u);
  for (size_t i = 0; i < 5; ++i) EXPECT_EQ(listed[i], TimestampFileStem(t[i]) + ".png");

  // The COLMAP command lines: CPU only, fixed PINHOLE intrinsics with the
  // half-pixel shift, bounded threads and features, intrinsics not refined.
  const std::string args = Args();
  for (const char* want :
       {"--SiftExtraction.use_gpu 0", "--SiftMatching.use_gpu 0", "--ImageReader.camera_model PINHOLE",
        "--ImageReader.single_camera 1", "--ImageReader.camera_params 50,52,32,23.75",
        "--SiftExtraction.num_threads 2", "--SiftExtraction.max_num_features 2048",
        "--SiftMatching.num_threads 2", "--Mapper.num_threads 2", "--Mapper.ba_refine_focal_length 0",
        "--Mapper.ba_refine_principal_point 0", "--Mapper.ba_refine_extra_params 0",
        "--Mapper.min_model_size 10", "matches_importer", "--match_type pairs"}) {
    EXPECT_NE(args.find(want), std::string::npos) << want << "\nin:\n" << args;
  }
  // The selected pairs, by image name: 5 frames within `overlap` of each
  // other are all paired.
  EXPECT_EQ(r.matched_pairs, 10);
  std::ifstream pair_list(fs::path(r.workspace) / "pairs.txt");
  std::string first, second;
  int pairs = 0;
  while (pair_list >> first >> second) {
    ++pairs;
    EXPECT_LT(first, second);
    EXPECT_NE(std::find(listed.begin(), listed.end(), first), listed.end()) << first;
    EXPECT_NE(std::find(listed.begin(), listed.end(), second), listed.end()) << second;
  }
  EXPECT_EQ(pairs, 10);
  EXPECT_EQ(args.find("domain_size_pooling"), std::string::npos) << "DSP-SIFT is off by default";
  // Workspace kept on request.
  ASSERT_FALSE(r.workspace.empty());
  EXPECT_TRUE(fs::exists(fs::path(r.workspace) / "colmap.log"));
}

// A texture-poor window: the first attempt's largest model misses frames, the
// retry with a lower SIFT peak threshold (its own database) registers them all.
TEST_F(BackSubmapBuilderTest, RetryWithLowerPeakThresholdKeepsTheLargerModel) {
  options_.colmap_path = MapperFewOrAll("sparse_retry");
  options_.sift_domain_size_pooling = true;
  BackSubmapBuilder b(options_);
  BackResult r = b.Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_TRUE(r.retried);
  EXPECT_TRUE(r.retry_kept);
  ASSERT_EQ(r.submaps.size(), 1u);
  EXPECT_EQ(r.submaps[0].keyframes.size(), 5u);
  EXPECT_EQ(r.num_registered, 5);
  std::string args = Args();
  EXPECT_NE(args.find("--SiftExtraction.peak_threshold 0.004"), std::string::npos) << args;
  EXPECT_NE(args.find("--SiftExtraction.peak_threshold 0.0015"), std::string::npos) << args;
  EXPECT_NE(args.find("database_retry.db"), std::string::npos) << args;
  // DSP-SIFT, when asked for, goes to both attempts' extraction.
  const std::string dsp = "--SiftExtraction.domain_size_pooling 1";
  ASSERT_NE(args.find(dsp), std::string::npos) << args;
  EXPECT_NE(args.find(dsp, args.find(dsp) + 1), std::string::npos) << args;
  EXPECT_TRUE(WorkspaceEmpty());

  // 3 of 5 is enough at retry_below_registered 0.6: no second attempt.
  fs::remove(root_ / "args.txt");
  options_.retry_below_registered = 0.6;
  r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_FALSE(r.retried);
  EXPECT_EQ(r.submaps[0].keyframes.size(), 3u);
  EXPECT_EQ(Args().find("database_retry.db"), std::string::npos);

  // Retry off.
  fs::remove(root_ / "args.txt");
  options_.retry_below_registered = 0.9;
  options_.retry_peak_threshold = 0;
  r = BackSubmapBuilder(options_).Build(window_);
  EXPECT_FALSE(r.retried);
  EXPECT_EQ(r.submaps[0].keyframes.size(), 3u);
  EXPECT_EQ(Args().find("database_retry.db"), std::string::npos);
}

// The retry starts from a copy of the first attempt's database without the
// frames in no model: COLMAP extracts only those again and matches only
// their pairs. What its feature extractor finds is kept in retry_seen.db.
TEST_F(BackSubmapBuilderTest, TheRetryKeepsTheFeaturesOfFramesInAModel) {
  std::vector<std::pair<std::string, int>> rows;
  for (size_t i = 0; i < window_.frames.size(); ++i)
    rows.push_back({ColmapImageName(window_.frames[i].timestamp), 300 + int(i)});
  const fs::path canned = root_ / "canned.db", seen = root_ / "retry_seen.db";
  ASSERT_TRUE(WriteCannedColmapDatabase(canned, rows));
  const std::string db = "$(tail -n 1 " + (root_ / "args.txt").string() +
                         " | sed 's/.*--database_path \\([^ ]*\\).*/\\1/')";
  const std::string extractor = "if [ $cmd = feature_extractor ]; then db=" + db +
                                "; case $db in *database.db) cp " + canned.string() + " $db;; *) if [ -f $db ]; then cp $db " +
                                seen.string() + "; fi;; esac; fi\n";
  options_.colmap_path = MapperFewOrAll("sparse_retry", extractor);
  options_.retry_first_below_features = 0;
  options_.matcher = "exhaustive";  // no fill: the retry follows the first attempt
  options_.pairs.overlap = 1;       // frame 2, next to frame 3, is extracted again too
  BackResult r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_TRUE(r.retried);
  EXPECT_TRUE(r.retry_kept);
  ASSERT_TRUE(fs::exists(seen));
  // Frames 0 and 1 (images 1 and 2, in the first model) keep their features
  // and their pair; frames 3 and 4 (in no model) and 2 (1 frame from one)
  // are extracted and matched again.
  std::unordered_map<std::string, int> counts;
  std::string why;
  ASSERT_TRUE(ReadColmapKeypointCounts(seen.string(), &counts, &why)) << why;
  EXPECT_EQ(counts, (std::unordered_map<std::string, int>{{rows[0].first, 300}, {rows[1].first, 301}}));
  sqlite3* h = nullptr;
  ASSERT_EQ(sqlite3_open_v2(seen.c_str(), &h, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(h, "SELECT pair_id FROM matches ORDER BY pair_id", -1, &stmt, nullptr), SQLITE_OK);
  std::vector<int64_t> pairs;
  while (sqlite3_step(stmt) == SQLITE_ROW) pairs.push_back(sqlite3_column_int64(stmt, 0));
  sqlite3_finalize(stmt);
  sqlite3_close(h);
  const int64_t k = 2147483647;
  EXPECT_EQ(pairs, (std::vector<int64_t>{k * 1 + 2}));
  EXPECT_TRUE(WorkspaceEmpty());

  // Frames in a smaller model of their part count as left out: the first
  // attempt splits the window into frames 0-2 and 3-4.
  fs::remove(seen);
  std::vector<Timestamp> t;
  for (const auto& f : window_.frames) t.push_back(f.timestamp);
  const fs::path split = root_ / "split", all = root_ / "all";
  WriteCannedModel(split / "0", window_.camera, {t[0], t[1], t[2]});
  WriteCannedModel(split / "1", window_.camera, {t[3], t[4]});
  options_.min_registered_images = 2;
  options_.colmap_path = FakeColmap(extractor + "if [ $cmd = mapper ]; then case \"$out\" in *sparse_retry) cp -r " +
                                    all.string() + "/* $out/;; *) cp -r " + split.string() + "/* $out/;; esac; fi");
  r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_TRUE(r.retry_kept);
  ASSERT_TRUE(ReadColmapKeypointCounts(seen.string(), &counts, &why)) << why;
  EXPECT_EQ(counts, (std::unordered_map<std::string, int>{{rows[0].first, 300}, {rows[1].first, 301}}));
  options_.min_registered_images = BackOptions().min_registered_images;

  // Off: the retry starts from an empty database and extracts everything.
  fs::remove(seen);
  options_.retry_reuses_features = false;
  r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_TRUE(r.retried);
  EXPECT_FALSE(fs::exists(seen));
}

// Selected pairs that leave frames out of the model: the remaining pairs are
// matched on the same features (no second extraction) and mapped again; the
// lower-threshold retry is not needed once that model holds the window.
TEST_F(BackSubmapBuilderTest, SelectedPairsFallingShortAreFilledBeforeTheRetry) {
  options_.colmap_path = MapperFewOrAll("sparse_all");
  BackResult r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_TRUE(r.filled);
  EXPECT_TRUE(r.fill_kept);
  EXPECT_FALSE(r.retried);
  ASSERT_EQ(r.submaps.size(), 1u);
  EXPECT_EQ(r.submaps[0].keyframes.size(), 5u);
  const std::string args = Args();
  const size_t importer = args.find("matches_importer"), exhaustive = args.find("exhaustive_matcher");
  ASSERT_NE(importer, std::string::npos) << args;
  ASSERT_NE(exhaustive, std::string::npos) << args;
  EXPECT_LT(importer, exhaustive);
  EXPECT_EQ(args.find("feature_extractor"), args.rfind("feature_extractor")) << "features extracted once";
  EXPECT_EQ(args.find("database_retry.db"), std::string::npos);
  EXPECT_TRUE(WorkspaceEmpty());

  // Exhaustive matching from the start has nothing to fill.
  fs::remove(root_ / "args.txt");
  options_.matcher = "exhaustive";
  r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_FALSE(r.filled);
  EXPECT_TRUE(r.retried);
}

// Frames left out for lack of SIFT features, or without a verified pair to a
// frame in a model: the retry at the lower threshold goes first, and the
// fill (every other pair) only if the retry is short.
TEST_F(BackSubmapBuilderTest, TexturePoorOrUnlinkedFramesAreRetriedBeforeTheFill) {
  // Frames 3 and 4 (the two the first model lacks) have 20 features.
  options_.colmap_path = MapperFewOrAll("sparse_retry", DatabaseWithPoorFrames({3, 4}));
  BackResult r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_TRUE(r.retried);
  EXPECT_TRUE(r.retry_kept);
  EXPECT_FALSE(r.filled);
  EXPECT_EQ(r.num_registered, 5);
  std::string args = Args();
  EXPECT_EQ(args.find("exhaustive_matcher"), std::string::npos) << args;
  EXPECT_NE(args.find("database_retry.db"), std::string::npos) << args;

  // One of the two is enough (a quarter); none: the fill goes first.
  fs::remove(root_ / "args.txt");
  options_.colmap_path = MapperFewOrAll("sparse_retry", DatabaseWithPoorFrames({4}));
  r = BackSubmapBuilder(options_).Build(window_);
  EXPECT_FALSE(r.filled);
  EXPECT_TRUE(r.retry_kept);
  fs::remove(root_ / "args.txt");
  options_.colmap_path = MapperFewOrAll("sparse_retry", DatabaseWithPoorFrames({}));
  r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_TRUE(r.filled);
  EXPECT_FALSE(r.fill_kept);
  EXPECT_TRUE(r.retried);
  args = Args();
  ASSERT_NE(args.find("exhaustive_matcher"), std::string::npos) << args;
  EXPECT_LT(args.find("exhaustive_matcher"), args.find("database_retry.db"));

  // Textured frames without a verified pair to a frame in a model count as
  // texture-poor ones: one of the two is enough.
  fs::remove(root_ / "args.txt");
  options_.colmap_path = MapperFewOrAll("sparse_retry", DatabaseWithPoorFrames({}, {4}));
  r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_FALSE(r.filled);
  EXPECT_TRUE(r.retry_kept);
  EXPECT_EQ(Args().find("exhaustive_matcher"), std::string::npos);

  // 0 turns the decision off: the fill first, as before.
  fs::remove(root_ / "args.txt");
  options_.retry_first_below_features = 0;
  options_.colmap_path = MapperFewOrAll("sparse_retry", DatabaseWithPoorFrames({3, 4}));
  r = BackSubmapBuilder(options_).Build(window_);
  EXPECT_TRUE(r.filled);
  EXPECT_TRUE(r.retried);

  // The retry still short: its own database is filled.
  fs::remove(root_ / "args.txt");
  options_.retry_first_below_features = 100;
  options_.colmap_path = MapperFewOrAll("sparse_retry_all", DatabaseWithPoorFrames({3, 4}));
  r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_TRUE(r.retried);
  EXPECT_FALSE(r.retry_kept);  // 3 frames, as the first attempt
  EXPECT_TRUE(r.filled);
  EXPECT_TRUE(r.fill_kept);
  EXPECT_EQ(r.num_registered, 5);
  args = Args();
  const size_t exhaustive = args.find("exhaustive_matcher");
  ASSERT_NE(exhaustive, std::string::npos) << args;
  EXPECT_NE(args.find("database_retry.db", exhaustive), std::string::npos) << args;
  EXPECT_TRUE(WorkspaceEmpty());
}

// Blank frames (a covered lens) cannot register: a model holding every other
// frame is not short, and nothing runs again.
TEST_F(BackSubmapBuilderTest, BlankFramesDoNotMakeAModelShort) {
  window_.frames[3].image.setTo(7);
  window_.frames[4].image.setTo(7);
  options_.colmap_path = MapperFewOrAll("sparse_retry");
  options_.keep_workspaces = true;
  BackResult r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_FALSE(r.filled);
  EXPECT_FALSE(r.retried);
  EXPECT_EQ(r.num_registered, 3);
  // COLMAP never sees them: no image, no pair.
  EXPECT_EQ(r.matched_pairs, 3);
  const std::string blank_name = ColmapImageName(window_.frames[3].timestamp);
  EXPECT_FALSE(fs::exists(fs::path(r.workspace) / "images" / blank_name));
  EXPECT_TRUE(fs::exists(fs::path(r.workspace) / "images" / ColmapImageName(window_.frames[2].timestamp)));
  std::ifstream list(fs::path(r.workspace) / "pairs.txt");
  const std::string pairs((std::istreambuf_iterator<char>(list)), {});
  EXPECT_EQ(pairs.find(blank_name), std::string::npos) << pairs;
  fs::remove_all(r.workspace);
  options_.keep_workspaces = false;
  // Too few frames that are not blank: no COLMAP run, and the message says why.
  window_.frames[2].image.setTo(7);
  window_.frames[1].image.setTo(7);
  fs::remove(root_ / "args.txt");
  r = BackSubmapBuilder(options_).Build(window_);
  EXPECT_EQ(r.status, BackStatus::kNoModel);
  EXPECT_NE(r.message.find("4 of the window's 5 frames are blank"), std::string::npos) << r.message;
  EXPECT_FALSE(fs::exists(root_ / "args.txt"));
  cv::RNG rng(9);
  rng.fill(window_.frames[1].image, cv::RNG::UNIFORM, 0, 256);
  rng.fill(window_.frames[2].image, cv::RNG::UNIFORM, 0, 256);
  // With the blank test off they count, as before.
  fs::remove(root_ / "args.txt");
  options_.blank_max_stddev = 0;
  r = BackSubmapBuilder(options_).Build(window_);
  EXPECT_TRUE(r.filled);
  EXPECT_TRUE(r.retried);
  EXPECT_EQ(r.num_registered, 5);
}

// A window the queue joined from two: one model per part is what COLMAP
// should give, so each part is judged on its own and nothing is matched again
// (in a stress run a joined 151-frame window spent minutes in the fill).
TEST_F(BackSubmapBuilderTest, AJoinedWindowIsJudgedPartByPart) {
  std::vector<Timestamp> t;
  for (const auto& f : window_.frames) t.push_back(f.timestamp);
  const fs::path two = root_ / "two";
  WriteCannedModel(two / "0", window_.camera, {t[0], t[1], t[2]});
  WriteCannedModel(two / "1", window_.camera, {t[3], t[4]});
  options_.colmap_path = FakeColmap("if [ $cmd = mapper ]; then cp -r " + two.string() + "/* $out/; fi");
  options_.min_registered_images = 2;
  window_.joined_at = {t[3]};  // parts t0-t2 and t3-t4
  BackResult r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_FALSE(r.filled);
  EXPECT_FALSE(r.retried);
  EXPECT_EQ(r.submaps.size(), 2u);
  EXPECT_EQ(Args().find("exhaustive_matcher"), std::string::npos);
  // One window: 3 of 5 frames in its largest model, so the rest is matched.
  fs::remove(root_ / "args.txt");
  window_.joined_at.clear();
  r = BackSubmapBuilder(options_).Build(window_);
  EXPECT_TRUE(r.filled);
  EXPECT_TRUE(r.retried);
  // A part that misses frames still gets them: the joined window t0-t1 | t2-t4.
  fs::remove(root_ / "args.txt");
  window_.joined_at = {t[2]};
  r = BackSubmapBuilder(options_).Build(window_);
  EXPECT_TRUE(r.filled);
}

// A model holding frames before and after a covered lens is cut there: each
// side becomes a back submap of its own.
TEST_F(BackSubmapBuilderTest, AModelIsCutAtABlankStretch) {
  const std::vector<Timestamp> t = CoverFrames3To5();
  const fs::path canned = root_ / "canned";
  WriteCannedModel(canned / "0", window_.camera, {t[0], t[1], t[2], t[6], t[7], t[8]});
  MapperLeaves(canned);
  BackResult r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  ASSERT_EQ(r.submaps.size(), 2u);
  EXPECT_EQ(r.submaps[0].keyframes.size(), 3u);
  EXPECT_EQ(r.submaps[1].keyframes.size(), 3u);
  EXPECT_NE(r.submaps[0].id, r.submaps[1].id);
  ASSERT_EQ(r.stats.size(), 2u);
  EXPECT_EQ(r.stats[0].registered_images, 3);
  EXPECT_EQ(r.num_registered, 6);
  bool warned = false;
  for (const std::string& w : r.warnings) warned |= w.find("blank stretch") != std::string::npos;
  EXPECT_TRUE(warned);
  // Two blank frames are not a stretch; 0 turns the cut off.
  window_.frames[5].image = window_.frames[6].image.clone();
  EXPECT_EQ(BackSubmapBuilder(options_).Build(window_).submaps.size(), 1u);
  window_.frames[5].image.setTo(0);
  options_.blank_max_stddev = 0;
  EXPECT_EQ(BackSubmapBuilder(options_).Build(window_).submaps.size(), 1u);
}

// A frame COLMAP registered far off the path of its time neighbours
// (generated corridor seed 5) is left out of the back submap, and said so.
TEST_F(BackSubmapBuilderTest, AFrameRegisteredOffThePathIsLeftOut) {
  const std::vector<Timestamp> t = CoverFrames3To5();
  cv::RNG rng(8);
  for (int i = 3; i <= 5; ++i) rng.fill(window_.frames[size_t(i)].image, cv::RNG::UNIFORM, 0, 256);  // none blank
  const fs::path canned = root_ / "canned";
  WriteCannedModel(canned / "0", window_.camera, {t[0], t[1], t[2], t[3], t[4]}, 100.5, 50.5, 2);
  MapperLeaves(canned);
  options_.min_point_observations = 2;
  BackResult r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  ASSERT_EQ(r.submaps.size(), 1u);
  ASSERT_EQ(r.submaps[0].keyframes.size(), 4u);
  for (const Keyframe& k : r.submaps[0].keyframes) EXPECT_NE(k.timestamp, t[2]);
  EXPECT_EQ(r.stats[0].registered_images, 4);
  bool warned = false;
  for (const std::string& w : r.warnings)
    warned |= w.find("off the camera path") != std::string::npos && w.find(FormatSeconds(t[2])) != std::string::npos;
  EXPECT_TRUE(warned);
  options_.pose_jump_ratio = 0;  // off: every registered frame stays
  EXPECT_EQ(BackSubmapBuilder(options_).Build(window_).submaps[0].keyframes.size(), 5u);
}

// Each side of a blank stretch is judged on its own, as the parts of a joined
// window are: a model per side is complete (the cut would split one model
// holding both anyway).
TEST_F(BackSubmapBuilderTest, EachSideOfABlankStretchIsJudgedOnItsOwn) {
  const std::vector<Timestamp> t = CoverFrames3To5();
  const fs::path two = root_ / "two";
  WriteCannedModel(two / "0", window_.camera, {t[0], t[1], t[2]});
  WriteCannedModel(two / "1", window_.camera, {t[6], t[7], t[8]});
  options_.colmap_path = FakeColmap("if [ $cmd = mapper ]; then cp -r " + two.string() + "/* $out/; fi");
  BackResult r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_FALSE(r.filled);
  EXPECT_FALSE(r.retried);
  EXPECT_EQ(r.submaps.size(), 2u);
  // Two blank frames are no stretch: one part, and 3 of 7 is short.
  window_.frames[5].image = window_.frames[6].image.clone();
  r = BackSubmapBuilder(options_).Build(window_);
  EXPECT_TRUE(r.filled);
  EXPECT_TRUE(r.retried);
}

// Each side of a blank stretch takes its model from the attempt that
// registered most of it, the earliest on a tie: a fill that joined both sides
// does not replace the first attempt's model of the side they share.
TEST_F(BackSubmapBuilderTest, EachSideOfABlankStretchKeepsItsBestAttempt) {
  const std::vector<Timestamp> t = CoverFrames3To5();
  // The first attempt: side 2 only (keypoints at x 100); the fill: both sides (x 200).
  const fs::path first = root_ / "first", all = root_ / "all";
  WriteCannedModel(first / "0", window_.camera, {t[6], t[7], t[8]}, 100.5);
  WriteCannedModel(all / "0", window_.camera, {t[0], t[1], t[2], t[6], t[7], t[8]}, 200.5);
  options_.colmap_path = FakeColmap("if [ $cmd = mapper ]; then case \"$out\" in *sparse_all) cp -r " +
                                    all.string() + "/* $out/;; *) cp -r " + first.string() + "/* $out/;; esac; fi");
  options_.orb_features = 0;
  BackResult r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_TRUE(r.filled);
  EXPECT_TRUE(r.fill_kept);
  EXPECT_FALSE(r.retried);
  ASSERT_EQ(r.submaps.size(), 2u);
  for (const Submap& m : r.submaps) {
    ASSERT_EQ(m.keyframes.size(), 3u);
    const bool side2 = m.keyframes.front().timestamp == t[6];
    EXPECT_FLOAT_EQ(m.keyframes.front().keypoints[0].x(), side2 ? 100.0f : 200.0f) << "side " << (side2 ? 2 : 1);
  }
  bool said = false;
  for (const std::string& w : r.warnings) said |= w.find("first attempt's model of 3 frames kept") != std::string::npos;
  EXPECT_TRUE(said);
  // No pair crosses the stretch, in the selection or in the fill: every pair of a side, and no other.
  EXPECT_EQ(r.matched_pairs, 6);
  const std::string args = Args();
  EXPECT_EQ(args.find("exhaustive_matcher"), std::string::npos) << args;
  ASSERT_NE(args.find("pairs_fill.txt"), std::string::npos) << args;
}

TEST_F(BackSubmapBuilderTest, NoPairCrossesABlankStretch) {
  const std::vector<Timestamp> t = CoverFrames3To5();
  options_.pairs.overlap = 1;  // the selection: neighbours within a side
  options_.pairs.quadratic = false;
  options_.keep_workspaces = true;
  options_.colmap_path = FakeColmap("exit 0");
  const BackResult r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_FALSE(r.workspace.empty());
  const auto read = [&](const char* name) {
    std::ifstream in(fs::path(r.workspace) / name);
    std::vector<std::pair<std::string, std::string>> pairs;
    std::string a, b;
    while (in >> a >> b) pairs.push_back({a, b});
    return pairs;
  };
  const auto name = [&](int i) { return ColmapImageName(t[i]); };
  using P = std::vector<std::pair<std::string, std::string>>;
  EXPECT_EQ(read("pairs.txt"), (P{{name(0), name(1)}, {name(1), name(2)}, {name(6), name(7)}, {name(7), name(8)}}));
  EXPECT_EQ(read("pairs_fill.txt"), (P{{name(0), name(2)}, {name(6), name(8)}}));
  fs::remove_all(r.workspace);
}

// The retry is kept only when it is larger; a failing retry leaves the first.
TEST_F(BackSubmapBuilderTest, FailedOrSmallerRetryKeepsTheFirstModel) {
  std::vector<Timestamp> t;
  for (const auto& f : window_.frames) t.push_back(f.timestamp);
  const fs::path four = root_ / "four", two = root_ / "two";
  WriteCannedModel(four / "0", window_.camera, {t[0], t[1], t[2], t[3]});
  WriteCannedModel(two / "0", window_.camera, {t[0], t[1], t[2]});
  options_.colmap_path = FakeColmap("if [ $cmd = mapper ]; then case \"$out\" in *sparse_retry) cp -r " +
                                    two.string() + "/* $out/;; *) cp -r " + four.string() + "/* $out/;; esac; fi");
  BackResult r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_TRUE(r.retried);
  EXPECT_FALSE(r.retry_kept);
  EXPECT_EQ(r.submaps[0].keyframes.size(), 4u);

  fs::remove(root_ / "args.txt");
  options_.colmap_path = FakeColmap("case $(tail -n 1 " + (root_ / "args.txt").string() +
                                    ") in *database_retry.db*) echo 'retry broke' >&2; exit 3;; esac\n"
                                    "if [ $cmd = mapper ]; then cp -r " + four.string() + "/* $out/; fi");
  r = BackSubmapBuilder(options_).Build(window_);
  ASSERT_EQ(r.status, BackStatus::kOk) << r.message;
  EXPECT_TRUE(r.retried);
  EXPECT_EQ(r.submaps[0].keyframes.size(), 4u);
  bool warned = false;
  for (const std::string& w : r.warnings) warned |= w.find("retry") != std::string::npos;
  EXPECT_TRUE(warned);
  EXPECT_TRUE(WorkspaceEmpty());
}

TEST_F(BackSubmapBuilderTest, DistortedImagesAreUndistortedBeforeColmap) {
  window_.camera.k1 = -0.3;
  window_.camera.p2 = 0.01;
  cv::Mat pattern(48, 64, CV_8UC1);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) pattern.at<uint8_t>(y, x) = static_cast<uint8_t>(((x / 5 + y / 5) % 2) * 200 + 20);
  // (5-pixel squares: 4-pixel ones fill every 8 x 8 block alike, and a frame
  // whose block means are all equal is blank, back/blank_cut.h.)
  for (auto& f : window_.frames) f.image = pattern.clone();
  options_.colmap_path = FakeColmap("exit 0");
  options_.keep_workspaces = true;
  BackSubmapBuilder b(options_);
  const BackResult r = b.Build(window_);
  EXPECT_EQ(r.status, BackStatus::kNoModel);
  ASSERT_FALSE(r.workspace.empty());
  const cv::Mat written = cv::imread(
      (fs::path(r.workspace) / "images" / (TimestampFileStem(window_.frames[2].timestamp) + ".png")).string(),
      cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(written.empty());
  const cv::Mat expected = PinholeCamera(window_.camera).UndistortImage(pattern);
  EXPECT_EQ(cv::norm(written, expected, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(written, pattern, cv::NORM_L1), 1000.0);  // really remapped
}

TEST_F(BackSubmapBuilderTest, ChangedIntrinsicsAreAnError) {
  PinholeCameraOptions other = window_.camera;
  other.fx += 1.0;
  std::vector<Timestamp> t;
  for (const auto& f : window_.frames) t.push_back(f.timestamp);
  WriteCannedModel(root_ / "canned" / "0", other, t);
  options_.colmap_path =
      FakeColmap("if [ $cmd = mapper ]; then cp -r " + (root_ / "canned").string() + "/* $out/; fi");
  BackSubmapBuilder b(options_);
  const BackResult r = b.Build(window_);
  EXPECT_EQ(r.status, BackStatus::kModelError);
  EXPECT_NE(r.message.find("intrinsics"), std::string::npos) << r.message;
  EXPECT_TRUE(WorkspaceEmpty());
}

TEST(BackOptionsTest, ReadAndCheck) {
  BackOptions o;
  EXPECT_TRUE(o.Check());
  ConfigSection s = LoadConfigString(
      "back: {num_threads: 1, max_num_features: 1024, matcher: sequential, step_timeout_s: 30, "
      "sift_domain_size_pooling: true, pairs: {overlap: 5, quadratic: false}}");
  ConfigSection b = s.Child("back");
  ReadOptions(b, &o);
  EXPECT_EQ(o.num_threads, 1);
  EXPECT_EQ(o.max_num_features, 1024);
  EXPECT_EQ(o.matcher, "sequential");
  EXPECT_EQ(o.step_timeout_s, 30.0);
  EXPECT_TRUE(o.sift_domain_size_pooling);
  EXPECT_EQ(o.pairs.overlap, 5);
  EXPECT_FALSE(o.pairs.quadratic);
  EXPECT_EQ(o.pairs.lost_overlap, PairSelectionOptions().lost_overlap);
  EXPECT_NO_THROW(b.Finish());

  for (const char* bad : {"back: {matcher: fancy}", "back: {num_threads: 0}", "back: {num_threads: x}",
                          "back: {step_timeout_s: -1}", "back: {max_queue_windows: 0}",
                          "back: {pairs: {overlap: 0}}", "back: {pairs: {bridge_frames: -1}}"}) {
    BackOptions o2;
    ConfigSection s2 = LoadConfigString(bad);
    ConfigSection b2 = s2.Child("back");
    EXPECT_THROW(ReadOptions(b2, &o2), ConfigError) << bad;
  }
  ConfigSection s3 = LoadConfigString("back: {num_thread: 2}");
  ConfigSection b3 = s3.Child("back");
  BackOptions o3;
  ReadOptions(b3, &o3);
  EXPECT_THROW(b3.Finish(), ConfigError);  // typo
  o3.min_registered_images = 1;
  std::string why;
  EXPECT_FALSE(o3.Check(&why));
  EXPECT_NE(why.find("min_registered_images"), std::string::npos);
  BackOptions o4;
  o4.orb_features = 10;
  EXPECT_FALSE(o4.Check(&why));
  EXPECT_NE(why.find("orb_features"), std::string::npos);
  o4.orb_features = 0;  // off
  EXPECT_TRUE(o4.Check());
}

}  // namespace
}  // namespace rumi
