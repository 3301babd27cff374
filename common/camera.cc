#include "common/camera.h"

#include <cmath>
#include <mutex>
#include <stdexcept>

#include <Eigen/LU>
#include <opencv2/imgproc.hpp>

namespace rumi {

namespace {
// Guards the lazy construction of the undistortion maps (they are shared by
// copies of a camera through cv::Mat reference counting, read-only once built).
std::mutex& MapMutex() {
  static std::mutex m;
  return m;
}
}  // namespace

bool PinholeCamera::HasDistortion() const {
  return o_.k1 != 0.0 || o_.k2 != 0.0 || o_.p1 != 0.0 || o_.p2 != 0.0 || o_.k3 != 0.0;
}

cv::Mat PinholeCamera::K() const {
  cv::Mat K = cv::Mat::eye(3, 3, CV_64F);
  K.at<double>(0, 0) = o_.fx;
  K.at<double>(1, 1) = o_.fy;
  K.at<double>(0, 2) = o_.cx;
  K.at<double>(1, 2) = o_.cy;
  return K;
}

cv::Mat PinholeCamera::DistCoeffs() const {
  cv::Mat d(1, 5, CV_64F);
  d.at<double>(0) = o_.k1;
  d.at<double>(1) = o_.k2;
  d.at<double>(2) = o_.p1;
  d.at<double>(3) = o_.p2;
  d.at<double>(4) = o_.k3;
  return d;
}

Eigen::Vector2d PinholeCamera::Distort(const Eigen::Vector2d& xn) const {
  const double x = xn.x(), y = xn.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (o_.k1 + r2 * (o_.k2 + r2 * o_.k3));
  return {x * radial + 2.0 * o_.p1 * x * y + o_.p2 * (r2 + 2.0 * x * x),
          y * radial + o_.p1 * (r2 + 2.0 * y * y) + 2.0 * o_.p2 * x * y};
}

Eigen::Vector2d PinholeCamera::Undistort(const Eigen::Vector2d& xd) const {
  if (!HasDistortion()) return xd;
  // Newton on Distort(x) = xd with step halving when the residual grows; the
  // plain fixed-point iteration (OpenCV's default) stalls at strong distortion.
  Eigen::Vector2d x = xd;
  Eigen::Vector2d r = Distort(x) - xd;
  double err = r.squaredNorm();
  for (int it = 0; it < 50 && err > 1e-30; ++it) {
    const double u = x.x(), v = x.y();
    const double r2 = u * u + v * v;
    const double radial = 1.0 + r2 * (o_.k1 + r2 * (o_.k2 + r2 * o_.k3));
    const double dradial = o_.k1 + r2 * (2.0 * o_.k2 + 3.0 * r2 * o_.k3);  // d radial / d r2
    Eigen::Matrix2d J;
    J(0, 0) = radial + 2.0 * u * u * dradial + 2.0 * o_.p1 * v + 6.0 * o_.p2 * u;
    J(0, 1) = 2.0 * u * v * dradial + 2.0 * o_.p1 * u + 2.0 * o_.p2 * v;
    J(1, 0) = J(0, 1);
    J(1, 1) = radial + 2.0 * v * v * dradial + 6.0 * o_.p1 * v + 2.0 * o_.p2 * u;
    const double det = J.determinant();
    Eigen::Vector2d step = (std::abs(det) > 1e-12) ? Eigen::Vector2d(J.inverse() * r) : r;
    double scale = 1.0;
    bool improved = false;
    for (int h = 0; h < 20; ++h, scale *= 0.5) {
      const Eigen::Vector2d xn = x - scale * step;
      const Eigen::Vector2d rn = Distort(xn) - xd;
      const double en = rn.squaredNorm();
      if (std::isfinite(en) && en < err) {
        x = xn;
        r = rn;
        err = en;
        improved = true;
        break;
      }
    }
    if (!improved) break;
  }
  return x;
}

bool PinholeCamera::Project(const Eigen::Vector3d& p_c, Eigen::Vector2d* px) const {
  if (!(p_c.z() > 0.0) || !p_c.allFinite()) return false;
  const Eigen::Vector2d xd = Distort(Eigen::Vector2d(p_c.x() / p_c.z(), p_c.y() / p_c.z()));
  *px = Eigen::Vector2d(o_.fx * xd.x() + o_.cx, o_.fy * xd.y() + o_.cy);
  return true;
}

Eigen::Vector3d PinholeCamera::Unproject(const Eigen::Vector2d& px) const {
  const Eigen::Vector2d xd((px.x() - o_.cx) / o_.fx, (px.y() - o_.cy) / o_.fy);
  const Eigen::Vector2d xn = Undistort(xd);
  return {xn.x(), xn.y(), 1.0};
}

Eigen::Vector2d PinholeCamera::UndistortPoint(const Eigen::Vector2d& px) const {
  if (!HasDistortion()) return px;
  const Eigen::Vector3d ray = Unproject(px);
  return {o_.fx * ray.x() + o_.cx, o_.fy * ray.y() + o_.cy};
}

std::vector<Eigen::Vector2d> PinholeCamera::UndistortPoints(
    const std::vector<Eigen::Vector2d>& px) const {
  std::vector<Eigen::Vector2d> out;
  out.reserve(px.size());
  for (const auto& p : px) out.push_back(UndistortPoint(p));
  return out;
}

cv::Mat PinholeCamera::UndistortImage(const cv::Mat& img) const {
  if (img.empty()) throw std::invalid_argument("UndistortImage: empty image");
  if (img.cols != o_.width || img.rows != o_.height) {
    throw std::invalid_argument("UndistortImage: image is " + std::to_string(img.cols) + "x" +
                                std::to_string(img.rows) + ", camera is " +
                                std::to_string(o_.width) + "x" + std::to_string(o_.height));
  }
  if (!HasDistortion()) return img.clone();
  cv::Mat map1, map2;
  {
    std::lock_guard<std::mutex> lock(MapMutex());
    if (map1_.empty()) {
      // Built from Distort directly (not initUndistortRectifyMap) so that
      // negative focal lengths follow exactly the same model as Project.
      cv::Mat mx(o_.height, o_.width, CV_32F), my(o_.height, o_.width, CV_32F);
      for (int v = 0; v < o_.height; ++v) {
        float* rx = mx.ptr<float>(v);
        float* ry = my.ptr<float>(v);
        for (int u = 0; u < o_.width; ++u) {
          const Eigen::Vector2d xd = Distort(Eigen::Vector2d((u - o_.cx) / o_.fx, (v - o_.cy) / o_.fy));
          rx[u] = static_cast<float>(o_.fx * xd.x() + o_.cx);
          ry[u] = static_cast<float>(o_.fy * xd.y() + o_.cy);
        }
      }
      cv::Mat f1, f2;
      cv::convertMaps(mx, my, f1, f2, CV_16SC2);  // fixed-point maps remap faster
      map1_ = f1;
      map2_ = f2;
    }
    map1 = map1_;
    map2 = map2_;
  }
  cv::Mat out;
  cv::remap(img, out, map1, map2, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  return out;
}

}  // namespace rumi
