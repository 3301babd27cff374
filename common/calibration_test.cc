#include "common/calibration.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "common/testing/board_renderer.h"
#include "common/testing/temp_dir.h"
#include "common/camera_config.h"
#include "common/config.h"

namespace rumi {
namespace {
namespace fs = std::filesystem;
using test::BoardRenderer;
using test::MaxModelDifferencePx;
using test::Qvga;
using test::Vga;

void ExpectRecovers(const PinholeCameraOptions& truth, const CalibrationResult& r) {
  ASSERT_TRUE(r.ok) << r.Summary();
  const PinholeCameraOptions& c = r.camera;
  EXPECT_EQ(c.width, truth.width);
  EXPECT_EQ(c.height, truth.height);
  EXPECT_NEAR(c.fx, truth.fx, 0.01 * truth.fx) << r.Summary();
  EXPECT_NEAR(c.fy, truth.fy, 0.01 * truth.fy) << r.Summary();
  EXPECT_NEAR(c.cx, truth.cx, 2.0) << r.Summary();
  EXPECT_NEAR(c.cy, truth.cy, 2.0) << r.Summary();
  EXPECT_LT(r.rms_px, 0.5) << r.Summary();
  const double model_px = MaxModelDifferencePx(truth, c);
  EXPECT_LT(model_px, 1.0) << r.Summary();
  std::printf("%dx%d: fx %+.2f %% fy %+.2f %% cx %+.2f px cy %+.2f px k1 %.4f (true %.4f) k2 %.4f (true %.4f); "
              "RMS %.3f px; model differs by <= %.2f px over the image; coverage %.0f %%\n",
              truth.width, truth.height, 100 * (c.fx / truth.fx - 1), 100 * (c.fy / truth.fy - 1), c.cx - truth.cx,
              c.cy - truth.cy, c.k1, truth.k1, c.k2, truth.k2, r.rms_px, model_px, 100 * r.coverage);
}

TEST(Calibration, RecoversVgaIntrinsicsAndDropsABadView) {
  const PinholeCameraOptions truth = Vga();
  CalibrationOptions o;
  std::vector<CalibrationImage> images = BoardRenderer(truth, o).Views(14, 1, 0.45);
  ASSERT_EQ(images.size(), 14u);
  // One image from another camera (a different lens) must not pull the fit.
  PinholeCameraOptions other = truth;
  other.fx = other.fy = 420;
  other.k1 = 0.15;
  other.k2 = 0;
  std::vector<CalibrationImage> odd = BoardRenderer(other, o).Views(1, 99, 0.4);
  ASSERT_EQ(odd.size(), 1u);
  odd[0].name = "odd.png";
  images.insert(images.begin() + 5, odd[0]);

  const CalibrationResult r = CalibrateCamera(images, o);
  ExpectRecovers(truth, r);
  EXPECT_EQ(r.boards_found, 15);
  EXPECT_EQ(r.views_used, 14);
  EXPECT_FALSE(r.views[5].used);
  EXPECT_NE(r.views[5].rejected.find("reprojection RMS"), std::string::npos) << r.views[5].rejected;
  EXPECT_FALSE(r.k3_fitted);
  EXPECT_EQ(r.camera.k3, 0.0);
  for (const CalibrationView& v : r.views) {
    if (v.used) {
      EXPECT_LT(v.rms_px, 0.5) << v.name;
    }
  }
}

TEST(Calibration, FindsCornersWhereTheModelPutsThem) {
  CalibrationOptions o;
  std::vector<std::vector<cv::Point2f>> truth;
  const std::vector<CalibrationImage> images = BoardRenderer(Vga(), o).Views(9, 10, 0.45, {0, 0, 1, 1}, 0.6, &truth);
  double sum2 = 0, worst = 0;
  cv::Point2d mean(0, 0);
  int n = 0;
  for (size_t i = 0; i < images.size(); ++i) {
    std::vector<cv::Point2f> found;
    ASSERT_TRUE(FindBoardCorners(images[i].grey, cv::Size(o.board_cols, o.board_rows), &found)) << i;
    for (const cv::Point2f& p : found) {  // the detector may start at another corner of the board
      cv::Point2f best = truth[i][0];
      for (const cv::Point2f& q : truth[i])
        if (cv::norm(p - q) < cv::norm(p - best)) best = q;
      const cv::Point2d e = p - best;
      sum2 += e.dot(e);
      worst = std::max(worst, cv::norm(e));
      mean += e;
      ++n;
    }
  }
  mean /= n;
  std::printf("corners: RMS %.3f px, worst %.3f px, mean (%.3f, %.3f) px over %d\n", std::sqrt(sum2 / n), worst,
              mean.x, mean.y, n);
  EXPECT_LT(std::sqrt(sum2 / n), 0.15);
}

// Shared by the tests below: rendering and fitting take a while.
const CalibrationResult& QvgaResult() {
  static const CalibrationResult r = CalibrateCamera(BoardRenderer(Qvga(), CalibrationOptions()).Views(12, 2, 0.4),
                                                     CalibrationOptions());
  return r;
}

TEST(Calibration, RecoversQvgaIntrinsics) {
  const CalibrationResult& r = QvgaResult();
  ExpectRecovers(Qvga(), r);
  EXPECT_EQ(r.views_used, 12);
}

TEST(Calibration, WrittenSectionLoadsBack) {
  const CalibrationResult& r = QvgaResult();
  ASSERT_TRUE(r.ok) << r.Summary();
  const std::string yaml = CalibrationConfigYaml(r, CalibrationOptions());
  EXPECT_NE(yaml.find("# RMS reprojection error"), std::string::npos) << yaml;
  ConfigSection root = LoadConfigString(yaml, "camera.yaml");
  ConfigSection cam = root.Child("camera");
  PinholeCameraOptions back;
  ReadOptions(cam, &back);
  EXPECT_NO_THROW(root.Finish());
  const PinholeCameraOptions& c = r.camera;
  EXPECT_EQ(back.width, c.width);
  EXPECT_EQ(back.height, c.height);
  for (auto [a, b] : {std::pair{back.fx, c.fx}, {back.fy, c.fy}, {back.cx, c.cx}, {back.cy, c.cy}, {back.k1, c.k1},
                      {back.k2, c.k2}, {back.p1, c.p1}, {back.p2, c.p2}, {back.k3, c.k3}}) {
    EXPECT_NEAR(a, b, 1e-9 * std::max(1.0, std::abs(b)));
  }
  EXPECT_FALSE(back.flipped_y);
}

TEST(Calibration, RefusesTooFewViews) {
  CalibrationOptions o;
  const CalibrationResult r = CalibrateCamera(BoardRenderer(Qvga(), o).Views(6, 4, 0.4), o);
  EXPECT_FALSE(r.ok);
  EXPECT_FALSE(r.fitted);
  EXPECT_NE(r.why.find("only 6 of 6 images show the whole board, need >= 10"), std::string::npos) << r.why;
}

TEST(Calibration, RefusesPoorCoverage) {
  CalibrationOptions o;
  // Every board in the top-left part of the image, small and far.
  const CalibrationResult r =
      CalibrateCamera(BoardRenderer(Qvga(), o).Views(12, 5, 0.6, {0.0, 0.0, 0.35, 0.35}), o);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.boards_found, 12);
  EXPECT_LT(r.coverage, 0.5);
  EXPECT_NE(r.why.find("% of the image, need >= 50 %: move the board"), std::string::npos) << r.why;
  EXPECT_NE(r.why.find("bottom right"), std::string::npos) << r.why;
  std::printf("%s\n", r.why.c_str());
  EXPECT_FALSE(r.fitted);
}

TEST(Calibration, RefusesLargeError) {
  CalibrationOptions o;
  o.max_rms_px = 0.01;  // no real fit gets there: the noise alone is more
  o.min_views = 5;      // the outlier pass may drop a view or two at this limit
  const CalibrationResult r = CalibrateCamera(BoardRenderer(Qvga(), o).Views(10, 6, 0.4), o);
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(r.fitted);
  EXPECT_NE(r.why.find("reprojection RMS"), std::string::npos) << r.why;
  EXPECT_NE(r.why.find("> 0.01 px"), std::string::npos) << r.why;
}

TEST(Calibration, RefusesBoardsFacingTheCamera) {
  CalibrationOptions o;
  o.min_coverage = 0.3;
  // Without tilt the focal length trades off against the distance.
  const CalibrationResult r = CalibrateCamera(BoardRenderer(Qvga(), o).Views(10, 7, 0.4, {0, 0, 1, 1}, 0.0), o);
  EXPECT_FALSE(r.ok) << r.Summary();
  EXPECT_NE(r.why.find("tilt"), std::string::npos) << r.why;
  std::printf("%s\n", r.why.c_str());
}

TEST(Calibration, FolderWithoutBoardOrReadableImages) {
  const TempDir tmp;
  const fs::path dir = tmp.Create();
  EXPECT_THROW(
      {
        try {
          ReadCalibrationImages(dir.string());
        } catch (const std::runtime_error& e) {
          EXPECT_NE(std::string(e.what()).find("no image files"), std::string::npos) << e.what();
          throw;
        }
      },
      std::runtime_error);
  EXPECT_THROW(ReadCalibrationImages((dir / "missing").string()), std::runtime_error);

  cv::Mat wall(240, 320, CV_8UC1);
  cv::RNG rng(8);
  for (int i = 0; i < 3; ++i) {
    rng.fill(wall, cv::RNG::UNIFORM, 60, 200);
    ASSERT_TRUE(cv::imwrite((dir / ("wall_" + std::to_string(i) + ".png")).string(), wall));
  }
  std::ofstream(dir / "broken.jpg") << "not a jpeg";
  std::ofstream(dir / "truncated.PNG") << "\x89PNG\r\n";
  std::ofstream(dir / "notes.txt") << "not an image, skipped";
  const std::vector<CalibrationImage> images = ReadCalibrationImages(dir.string());
  ASSERT_EQ(images.size(), 5u);
  EXPECT_EQ(images[0].name, "broken.jpg");
  EXPECT_TRUE(images[0].grey.empty());
  const CalibrationResult r = CalibrateCamera(images, CalibrationOptions());
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.why.find("only 0 of 5 images show the whole board, need >= 10; 2 unreadable; 3 with no whole 9x6 board"),
            std::string::npos)
      << r.why;
  EXPECT_NE(r.why.find("inner corners: 9x6 for a board of 10x7 squares"), std::string::npos) << r.why;
  EXPECT_EQ(r.views[0].rejected, "unreadable");
}

TEST(Calibration, PicksStillNewBoardsFromAStream) {
  const CalibrationOptions o;
  const std::vector<CalibrationImage> boards = BoardRenderer(Qvga(), o).Views(12, 2, 0.4);
  CalibrationViewPicker picker(o);
  using V = CalibrationViewPicker::Verdict;
  const cv::Mat wall(240, 320, CV_8UC1, cv::Scalar(110));
  EXPECT_EQ(picker.Offer(wall, "wall"), V::kNoBoard);
  EXPECT_EQ(picker.Offer(cv::Mat(), "nothing"), V::kUnreadable);
  for (size_t i = 0; i < boards.size(); ++i) {
    // Seen once, between two other views: it was moving (would be blurred).
    EXPECT_EQ(picker.Offer(boards[i].grey, boards[i].name + "a"), V::kMoving) << i;
    // Held still for a second frame: a view.
    EXPECT_EQ(picker.Offer(boards[i].grey, boards[i].name), V::kKept) << i;
    // Held longer: nothing new.
    EXPECT_EQ(picker.Offer(boards[i].grey, boards[i].name + "c"), V::kSeen) << i;
    picker.Offer(wall, "wall");
  }
  // The first board again, later: already a view.
  EXPECT_EQ(picker.Offer(boards[0].grey, "again"), V::kMoving);
  EXPECT_EQ(picker.Offer(boards[0].grey, "again"), V::kSeen);
  EXPECT_EQ(picker.Offer(cv::Mat(120, 160, CV_8UC1, cv::Scalar(0)), "small"), V::kOtherSize);
  ASSERT_EQ(picker.views().size(), boards.size());
  EXPECT_EQ(picker.views()[3].name, boards[3].name);
  // The picked views calibrate as the photos do, with the same coverage.
  std::vector<std::string> empty;
  const double coverage = picker.Coverage(&empty);
  const CalibrationResult r = CalibrateCamera(picker.views(), o);
  ExpectRecovers(Qvga(), r);
  EXPECT_NEAR(coverage, r.coverage, 0.02);
  EXPECT_EQ(empty, r.empty_regions);
}

TEST(Calibration, RejectsBadOptions) {
  CalibrationOptions o;
  o.board_cols = 1;
  EXPECT_THROW(CalibrateCamera({}, o), std::invalid_argument);
  o = CalibrationOptions();
  o.pattern = "charuco";
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("pattern"), std::string::npos) << why;
}

}  // namespace
}  // namespace rumi
