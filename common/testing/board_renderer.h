#pragma once
// Test helper: chessboard images rendered through a known camera (pinhole +
// radtan), for the calibration tests (common/calibration_test.cc and the live
// link's tests/calibrate_link_test.cc).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <vector>

#include "common/calibration.h"
#include "common/camera.h"

namespace rumi::test {

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

inline PinholeCameraOptions Vga() {
  PinholeCameraOptions c;
  c.width = 640, c.height = 480;
  c.fx = 500, c.fy = 502, c.cx = 322, c.cy = 236;
  c.k1 = -0.25, c.k2 = 0.08, c.p1 = 0.001, c.p2 = -0.0005;
  return c;
}

// The rat robot's ESP32-CAM at QVGA (configs/rat_robot.yaml's guess).
inline PinholeCameraOptions Qvga() {
  PinholeCameraOptions c;
  c.width = 320, c.height = 240;
  c.fx = 245, c.fy = 245, c.cx = 159.5, c.cy = 119.5;
  c.k1 = -0.2, c.k2 = 0.05;
  return c;
}

// Largest pixel distance between where the two cameras put the same ray,
// over a grid of the image.
inline double MaxModelDifferencePx(const PinholeCameraOptions& truth, const PinholeCameraOptions& fit) {
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

}  // namespace rumi::test
