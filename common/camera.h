#pragma once
// Pinhole camera with radial-tangential distortion (OpenCV / EuRoC "radtan":
// k1 k2 p1 p2 [k3]). Focal lengths are positive; ICL-NUIM publishes fy < 0
// (its renderer's y axis points up), allowed with flipped_y: projection uses
// fy as it is, so the flipped axis stays consistent.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace rumi {

template <typename O> class OptionSpec;

struct PinholeCameraOptions {
  int width = 640;
  int height = 480;
  double fx = 525.0, fy = 525.0, cx = 319.5, cy = 239.5;
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;
  bool flipped_y = false;  // fy < 0 on purpose (ICL-NUIM)
  // fx > 0, fy > 0 (< 0 with flipped_y), principal point inside the image,
  // everything finite (common/camera_config.cc declares the keys).
  static const OptionSpec<PinholeCameraOptions>& Spec();
  bool Check(std::string* why = nullptr) const;
};

class PinholeCamera {
 public:
  PinholeCamera() = default;
  explicit PinholeCamera(const PinholeCameraOptions& o) : o_(o) {}
  const PinholeCameraOptions& options() const { return o_; }
  int width() const { return o_.width; }
  int height() const { return o_.height; }
  double fx() const { return o_.fx; }
  double fy() const { return o_.fy; }
  double cx() const { return o_.cx; }
  double cy() const { return o_.cy; }
  bool HasDistortion() const;
  cv::Mat K() const;             // 3x3 CV_64F
  cv::Mat DistCoeffs() const;    // 1x5 CV_64F (k1 k2 p1 p2 k3)

  // Camera-frame point -> distorted pixel. False when z <= 0.
  bool Project(const Eigen::Vector3d& p_c, Eigen::Vector2d* px) const;
  // Distorted pixel -> unit-depth ray (x, y, 1) in the camera frame.
  Eigen::Vector3d Unproject(const Eigen::Vector2d& px) const;
  // Distorted pixels -> ideal (undistorted) pixels of the same K.
  std::vector<Eigen::Vector2d> UndistortPoints(const std::vector<Eigen::Vector2d>& px) const;
  Eigen::Vector2d UndistortPoint(const Eigen::Vector2d& px) const;
  // Remaps an image to the undistorted pinhole model with the same K.
  cv::Mat UndistortImage(const cv::Mat& img) const;

  // Normalised coordinates <-> distorted normalised coordinates.
  Eigen::Vector2d Distort(const Eigen::Vector2d& xn) const;
  Eigen::Vector2d Undistort(const Eigen::Vector2d& xd) const;

 private:
  PinholeCameraOptions o_;
  mutable cv::Mat map1_, map2_;  // lazily built undistortion maps
};

}  // namespace rumi
