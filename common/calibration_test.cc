#include "common/calibration.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <unistd.h>

#include "common/camera_config.h"
#include "common/config.h"

namespace rumi {
namespace {
namespace fs = std::filesystem;

// Renders chessboard images as a camera with known intrinsics and radtan
// distortion sees them: every pixel averages 8x8 samples, each turned into its
// ray (undistorted at the pixel's corners, bilinear inside: the distortion is
// smooth) and intersected with the board's plane, so the corners sit where the
// model puts them (no warp of an undistorted image, no interpolation of one).
class BoardRenderer {
 public:
  BoardRenderer(const PinholeCameraOptions& cam, const CalibrationOptions& board) : cam_(cam), board_(board) {
    const PinholeCamera c(cam);
    rays_.reserve(static_cast<size_t>(cam.width + 1) * (cam.height + 1));
    for (int v = 0; v <= cam.height; ++v)
      for (int u = 0; u <= cam.width; ++u)
        rays_.push_back(c.Undistort(Eigen::Vector2d((u - 0.5 - cam.cx) / cam.fx, (v - 0.5 - cam.cy) / cam.fy)));
  }

  // The board (inner corner (0,0) at its origin) seen from pose R, t (board -> camera).
  cv::Mat Render(const Eigen::Matrix3d& R, const Eigen::Vector3d& t, uint64_t seed) const {
    Eigen::Matrix3d A;
    A << R.col(0), R.col(1), t;
    const Eigen::Matrix3d G = A.inverse();  // normalised image point -> board plane (homogeneous)
    const double s = board_.square_m, margin = s;
    const double x0 = -s, x1 = board_.board_cols * s, y0 = -s, y1 = board_.board_rows * s;
    const int W = cam_.width + 1;
    cv::Mat img(cam_.height, cam_.width, CV_8UC1);
    for (int v = 0; v < cam_.height; ++v)
      for (int u = 0; u < cam_.width; ++u) {
        const Eigen::Vector2d& r00 = rays_[v * W + u];
        const Eigen::Vector2d& r10 = rays_[v * W + u + 1];
        const Eigen::Vector2d& r01 = rays_[(v + 1) * W + u];
        const Eigen::Vector2d& r11 = rays_[(v + 1) * W + u + 1];
        int sum = 0;
        for (int sy = 0; sy < kSamples; ++sy)
          for (int sx = 0; sx < kSamples; ++sx) {
            const double fx = (sx + 0.5) / kSamples, fy = (sy + 0.5) / kSamples;
            const Eigen::Vector2d ray =
                (1 - fy) * ((1 - fx) * r00 + fx * r10) + fy * ((1 - fx) * r01 + fx * r11);
            const Eigen::Vector3d p = G * Eigen::Vector3d(ray.x(), ray.y(), 1.0);
            int value = 110;  // the wall behind the board
            if (p.z() > 0) {
              const double X = p.x() / p.z(), Y = p.y() / p.z();
              if (X >= x0 && X < x1 && Y >= y0 && Y < y1) {
                const int i_sq = static_cast<int>(std::floor(X / s)), j_sq = static_cast<int>(std::floor(Y / s));
                value = ((i_sq + j_sq) & 1) ? 220 : 30;
              } else if (X >= x0 - margin && X < x1 + margin && Y >= y0 - margin && Y < y1 + margin) {
                value = 220;  // the paper's white border
              }
            }
            sum += value;
          }
        img.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(static_cast<double>(sum) / (kSamples * kSamples));
      }
    cv::Mat noise(img.size(), CV_16SC1);
    cv::RNG rng(seed);
    rng.fill(noise, cv::RNG::NORMAL, 0, 2.0);
    cv::Mat out;
    img.convertTo(out, CV_16SC1);
    out += noise;
    out.convertTo(img, CV_8UC1);
    return img;
  }

  // A pose that puts the board's centre on pixel `target` at `depth`, tilted
  // by (ax, ay) and turned by az (radians); false when the paper would leave the image.
  bool Pose(const Eigen::Vector2d& target, double depth, double ax, double ay, double az, Eigen::Matrix3d* R,
            Eigen::Vector3d* t) const {
    *R = (Eigen::AngleAxisd(ax, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(ay, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(az, Eigen::Vector3d::UnitZ()))
             .toRotationMatrix();
    const double s = board_.square_m;
    const Eigen::Vector3d centre((board_.board_cols - 1) * s / 2, (board_.board_rows - 1) * s / 2, 0);
    const PinholeCamera c(cam_);
    const Eigen::Vector3d ray = c.Unproject(target);
    *t = depth * ray - *R * centre;
    for (double X : {-2 * s, board_.board_cols * s + s})
      for (double Y : {-2 * s, board_.board_rows * s + s}) {
        Eigen::Vector2d px;
        if (!c.Project(*R * Eigen::Vector3d(X, Y, 0) + *t, &px)) return false;
        if (px.x() < 2 || px.y() < 2 || px.x() > cam_.width - 3 || px.y() > cam_.height - 3) return false;
      }
    return true;
  }

  // n views spread over the given region of the image (fractions of width
  // and height): each board is pushed from the region's centre towards one of
  // its corners, edge middles or centre in turn, as far as the paper stays in
  // the image.
  // `corners` (optional) gets each view's true inner corners.
  std::vector<CalibrationImage> Views(int n, uint64_t seed, double depth, cv::Rect2d region = {0, 0, 1, 1},
                                      double max_tilt = 0.6,
                                      std::vector<std::vector<cv::Point2f>>* corners = nullptr) const {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> U(0, 1);
    const Eigen::Vector2d centre((region.x + region.width / 2) * cam_.width,
                                 (region.y + region.height / 2) * cam_.height);
    std::vector<CalibrationImage> out;
    for (int i = 0, tries = 0; static_cast<int>(out.size()) < n && tries < 1000; ++tries) {
      const int anchor = i % 9;
      const Eigen::Vector2d anchor_px((region.x + region.width * (anchor % 3) / 2.0) * cam_.width,
                                   (region.y + region.height * (anchor / 3) / 2.0) * cam_.height);
      Eigen::Matrix3d R;
      Eigen::Vector3d t;
      const double d = depth * (0.85 + 0.3 * U(rng));
      const double ax = max_tilt * (2 * U(rng) - 1), ay = max_tilt * (2 * U(rng) - 1);
      const double az = 0.4 * (2 * U(rng) - 1);
      // From the centre towards the anchor, along x and y in turn, while the paper stays in the image.
      Eigen::Vector2d target = centre;
      if (!Pose(target, d, ax, ay, az, &R, &t)) continue;
      for (int round = 0; round < 2; ++round)
        for (int axis = 0; axis < 2; ++axis) {
          const double step = anchor_px[axis] > target[axis] ? 2 : -2;
          while (std::abs(anchor_px[axis] - target[axis]) >= 2) {
            Eigen::Vector2d next = target;
            next[axis] += step;
            if (!Pose(next, d, ax, ay, az, &R, &t)) break;
            target = next;
          }
        }
      Pose(target, d, ax, ay, az, &R, &t);
      if (corners) {
        const PinholeCamera c(cam_);
        corners->emplace_back();
        for (int y = 0; y < board_.board_rows; ++y)
          for (int x = 0; x < board_.board_cols; ++x) {
            Eigen::Vector2d px;
            c.Project(R * Eigen::Vector3d(x * board_.square_m, y * board_.square_m, 0) + t, &px);
            corners->back().emplace_back(static_cast<float>(px.x()), static_cast<float>(px.y()));
          }
      }
      out.push_back({"view_" + std::to_string(i) + ".png", Render(R, t, seed * 1000 + i)});
      ++i;
    }
    return out;
  }

 private:
  static constexpr int kSamples = 8;
  PinholeCameraOptions cam_;
  CalibrationOptions board_;
  std::vector<Eigen::Vector2d> rays_;
};

PinholeCameraOptions Vga() {
  PinholeCameraOptions c;
  c.width = 640, c.height = 480;
  c.fx = 500, c.fy = 502, c.cx = 322, c.cy = 236;
  c.k1 = -0.25, c.k2 = 0.08, c.p1 = 0.001, c.p2 = -0.0005;
  return c;
}

// The rat robot's ESP32-CAM at QVGA (configs/rat_robot.yaml's guess).
PinholeCameraOptions Qvga() {
  PinholeCameraOptions c;
  c.width = 320, c.height = 240;
  c.fx = 245, c.fy = 245, c.cx = 159.5, c.cy = 119.5;
  c.k1 = -0.2, c.k2 = 0.05;
  return c;
}

// Largest pixel distance between where the two cameras put the same ray,
// over a grid of the image.
double MaxModelDifferencePx(const PinholeCameraOptions& truth, const PinholeCameraOptions& fit) {
  const PinholeCamera a(truth), b(fit);
  double worst = 0;
  for (int v = 0; v <= truth.height; v += truth.height / 24)
    for (int u = 0; u <= truth.width; u += truth.width / 32) {
      Eigen::Vector2d px;
      if (b.Project(a.Unproject(Eigen::Vector2d(u, v)), &px))
        worst = std::max(worst, (px - Eigen::Vector2d(u, v)).norm());
    }
  return worst;
}

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
  const fs::path dir = fs::temp_directory_path() / ("rumi_calibration_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
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
  fs::remove_all(dir);
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
