#include "common/camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace rumi {
namespace {

PinholeCameraOptions EurocOptions() {  // strong radtan distortion (V1_01 cam0)
  PinholeCameraOptions o;
  o.width = 752;
  o.height = 480;
  o.fx = 458.654;
  o.fy = 457.296;
  o.cx = 367.215;
  o.cy = 248.375;
  o.k1 = -0.28340811;
  o.k2 = 0.07395907;
  o.p1 = 0.00019359;
  o.p2 = 1.76187114e-05;
  return o;
}

PinholeCameraOptions TumFr1Options() {  // all five coefficients, k3 > 0
  PinholeCameraOptions o;
  o.fx = 517.306408;
  o.fy = 516.469215;
  o.cx = 318.643040;
  o.cy = 255.313989;
  o.k1 = 0.262383;
  o.k2 = -0.953104;
  o.p1 = -0.005358;
  o.p2 = 0.002628;
  o.k3 = 1.163314;
  return o;
}

PinholeCameraOptions IclOptions() {  // fy < 0, no distortion
  PinholeCameraOptions o;
  o.fx = 481.20;
  o.fy = -480.0;
  o.flipped_y = true;
  o.cx = 319.5;
  o.cy = 239.5;
  return o;
}

PinholeCameraOptions NegativeFyDistorted() {
  PinholeCameraOptions o = EurocOptions();
  o.fy = -o.fy;
  o.flipped_y = true;
  return o;
}

TEST(PinholeCameraOptions, CheckRejectsBadValues) {
  std::string why;
  EXPECT_TRUE(PinholeCameraOptions().Check(&why)) << why;
  EXPECT_TRUE(IclOptions().Check(&why)) << why;  // negative fy is legal with flipped_y
  PinholeCameraOptions o;
  o.fx = 0;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("focal"), std::string::npos) << why;
  o = PinholeCameraOptions();
  o.fy = 0;
  EXPECT_FALSE(o.Check());
  o = PinholeCameraOptions();
  o.width = 0;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("width"), std::string::npos) << why;
  o = PinholeCameraOptions();
  o.height = -5;
  EXPECT_FALSE(o.Check());
  o = PinholeCameraOptions();
  o.cx = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(o.Check());
  o = PinholeCameraOptions();
  o.fx = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(o.Check());
  o = PinholeCameraOptions();
  o.k3 = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(o.Check());
}

TEST(PinholeCamera, ProjectKnownValuesNegativeFy) {
  PinholeCamera cam(IclOptions());
  Eigen::Vector2d px;
  ASSERT_TRUE(cam.Project(Eigen::Vector3d(0.2, 0.4, 2.0), &px));
  EXPECT_NEAR(px.x(), 481.2 * 0.1 + 319.5, 1e-12);
  EXPECT_NEAR(px.y(), -480.0 * 0.2 + 239.5, 1e-12);  // +y in camera goes up in the image
  EXPECT_FALSE(cam.Project(Eigen::Vector3d(0.2, 0.4, -1.0), &px));
  EXPECT_FALSE(cam.Project(Eigen::Vector3d(0.2, 0.4, 0.0), &px));
  EXPECT_FALSE(cam.HasDistortion());
}

TEST(PinholeCamera, ProjectMatchesOpenCv) {
  for (const auto& o : {EurocOptions(), TumFr1Options()}) {
    PinholeCamera cam(o);
    std::vector<cv::Point3d> pts;
    for (double x = -0.5; x <= 0.5; x += 0.25)
      for (double y = -0.4; y <= 0.4; y += 0.2) pts.emplace_back(x, y, 1.3);
    std::vector<cv::Point2d> ref;
    cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cam.K(), cam.DistCoeffs(), ref);
    for (size_t i = 0; i < pts.size(); ++i) {
      Eigen::Vector2d px;
      ASSERT_TRUE(cam.Project(Eigen::Vector3d(pts[i].x, pts[i].y, pts[i].z), &px));
      EXPECT_NEAR(px.x(), ref[i].x, 1e-9);
      EXPECT_NEAR(px.y(), ref[i].y, 1e-9);
    }
  }
}

// Project then Unproject gives back the ray, for every model incl. fy < 0.
TEST(PinholeCamera, ProjectUnprojectRoundTrip) {
  for (const auto& o : {IclOptions(), EurocOptions(), TumFr1Options(), NegativeFyDistorted()}) {
    PinholeCamera cam(o);
    int n = 0;
    for (double x = -0.6; x <= 0.6; x += 0.1) {
      for (double y = -0.45; y <= 0.45; y += 0.09) {
        const Eigen::Vector3d p(x * 3.0, y * 3.0, 3.0);
        Eigen::Vector2d px;
        ASSERT_TRUE(cam.Project(p, &px));
        const Eigen::Vector3d ray = cam.Unproject(px);
        EXPECT_DOUBLE_EQ(ray.z(), 1.0);
        EXPECT_NEAR(ray.x(), x, 1e-10) << "fx " << o.fx << " fy " << o.fy << " at " << x << "," << y;
        EXPECT_NEAR(ray.y(), y, 1e-10) << "fx " << o.fx << " fy " << o.fy << " at " << x << "," << y;
        ++n;
      }
    }
    EXPECT_GT(n, 100);
  }
}

TEST(PinholeCamera, UndistortInvertsDistortAtImageCorners) {
  PinholeCamera cam(EurocOptions());
  // The corners of a EuRoC image are where distortion is strongest (~40 px).
  for (const Eigen::Vector2d& px : {Eigen::Vector2d(0, 0), Eigen::Vector2d(751, 0),
                                   Eigen::Vector2d(0, 479), Eigen::Vector2d(751, 479)}) {
    const Eigen::Vector2d xd((px.x() - cam.cx()) / cam.fx(), (px.y() - cam.cy()) / cam.fy());
    const Eigen::Vector2d xn = cam.Undistort(xd);
    EXPECT_GT((xn - xd).norm() * cam.fx(), 10.0);  // distortion really matters here
    EXPECT_NEAR((cam.Distort(xn) - xd).norm(), 0.0, 1e-12);
  }
}

TEST(PinholeCamera, UndistortPointsMatchesOpenCv) {
  for (const auto& o : {EurocOptions(), TumFr1Options()}) {
    PinholeCamera cam(o);
    std::vector<Eigen::Vector2d> px;
    std::vector<cv::Point2d> cvpx;
    for (int v = 0; v < o.height; v += 40) {
      for (int u = 0; u < o.width; u += 40) {
        px.emplace_back(u + 0.5, v + 0.25);
        cvpx.emplace_back(u + 0.5, v + 0.25);
      }
    }
    std::vector<cv::Point2d> ref;
    cv::undistortPoints(cvpx, ref, cam.K(), cam.DistCoeffs(), cv::noArray(), cam.K(),
                        cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-14));
    const auto out = cam.UndistortPoints(px);
    ASSERT_EQ(out.size(), px.size());
    for (size_t i = 0; i < px.size(); ++i) {
      EXPECT_NEAR(out[i].x(), ref[i].x, 1e-3) << i;
      EXPECT_NEAR(out[i].y(), ref[i].y, 1e-3) << i;
      EXPECT_EQ(out[i], cam.UndistortPoint(px[i]));
      // And ours is exact: re-distorting lands on the input pixel.
      Eigen::Vector2d back;
      ASSERT_TRUE(cam.Project(Eigen::Vector3d((out[i].x() - o.cx) / o.fx, (out[i].y() - o.cy) / o.fy, 1.0),
                              &back));
      EXPECT_NEAR((back - px[i]).norm(), 0.0, 1e-8);
    }
  }
}

TEST(PinholeCamera, NoDistortionIsIdentity) {
  PinholeCamera cam(IclOptions());
  const Eigen::Vector2d p(12.5, 400.25);
  EXPECT_EQ(cam.UndistortPoint(p), p);
  cv::Mat img(480, 640, CV_8U, cv::Scalar(7));
  img.at<uint8_t>(3, 4) = 200;
  const cv::Mat out = cam.UndistortImage(img);
  EXPECT_EQ(cv::norm(out, img, cv::NORM_INF), 0.0);
  EXPECT_NE(out.data, img.data);  // a copy, the caller may draw on it
}

// A bright blob drawn at the distorted position of an ideal pixel must end up
// at that ideal pixel after UndistortImage (checks map direction and sign).
void CheckBlobMovesToIdealPixel(const PinholeCameraOptions& o, const Eigen::Vector2d& ideal) {
  PinholeCamera cam(o);
  Eigen::Vector2d dist;
  ASSERT_TRUE(cam.Project(Eigen::Vector3d((ideal.x() - o.cx) / o.fx, (ideal.y() - o.cy) / o.fy, 1.0), &dist));
  ASSERT_GT((dist - ideal).norm(), 3.0) << "test point must be visibly distorted";
  cv::Mat img(o.height, o.width, CV_8U, cv::Scalar(0));
  for (int v = 0; v < o.height; ++v) {
    for (int u = 0; u < o.width; ++u) {
      const double d2 = (Eigen::Vector2d(u, v) - dist).squaredNorm();
      img.at<uint8_t>(v, u) = static_cast<uint8_t>(std::lround(250.0 * std::exp(-d2 / (2.0 * 2.0 * 2.0))));
    }
  }
  const cv::Mat out = cam.UndistortImage(img);
  ASSERT_EQ(out.size(), img.size());
  ASSERT_EQ(out.type(), img.type());
  const cv::Moments m = cv::moments(out, false);
  ASSERT_GT(m.m00, 0.0);
  EXPECT_NEAR(m.m10 / m.m00, ideal.x(), 0.3);
  EXPECT_NEAR(m.m01 / m.m00, ideal.y(), 0.3);
  // Second call uses the cached maps and gives the same result.
  EXPECT_EQ(cv::norm(cam.UndistortImage(img), out, cv::NORM_INF), 0.0);
}

TEST(PinholeCamera, UndistortImageMovesBlobToIdealPixel) {
  CheckBlobMovesToIdealPixel(EurocOptions(), Eigen::Vector2d(80, 60));
  CheckBlobMovesToIdealPixel(EurocOptions(), Eigen::Vector2d(680, 420));
  CheckBlobMovesToIdealPixel(NegativeFyDistorted(), Eigen::Vector2d(80, 60));
  CheckBlobMovesToIdealPixel(TumFr1Options(), Eigen::Vector2d(60, 420));
}

TEST(PinholeCamera, UndistortImageMatchesOpenCvUndistort) {
  PinholeCamera cam(EurocOptions());
  cv::Mat img(480, 752, CV_8U);
  cv::randu(img, 0, 255);
  cv::GaussianBlur(img, img, cv::Size(0, 0), 3.0);  // smooth so interpolation differences are small
  cv::Mat ref;
  cv::undistort(img, ref, cam.K(), cam.DistCoeffs());
  const cv::Mat out = cam.UndistortImage(img);
  cv::Mat diff;
  cv::absdiff(out, ref, diff);
  const cv::Rect inner(20, 20, 752 - 40, 480 - 40);  // borders differ by fill policy
  EXPECT_LT(cv::mean(diff(inner))[0], 0.5);
}

TEST(PinholeCamera, UndistortImageRejectsWrongSize) {
  PinholeCamera cam(EurocOptions());
  EXPECT_THROW(cam.UndistortImage(cv::Mat(480, 640, CV_8U, cv::Scalar(0))), std::invalid_argument);
  EXPECT_THROW(cam.UndistortImage(cv::Mat()), std::invalid_argument);
}

TEST(PinholeCamera, MatricesHoldParameters) {
  PinholeCamera cam(TumFr1Options());
  const cv::Mat K = cam.K();
  EXPECT_EQ(K.at<double>(0, 0), 517.306408);
  EXPECT_EQ(K.at<double>(1, 1), 516.469215);
  EXPECT_EQ(K.at<double>(0, 2), 318.643040);
  EXPECT_EQ(K.at<double>(1, 2), 255.313989);
  EXPECT_EQ(K.at<double>(2, 2), 1.0);
  EXPECT_EQ(K.at<double>(0, 1), 0.0);
  const cv::Mat d = cam.DistCoeffs();
  ASSERT_EQ(d.total(), 5u);
  EXPECT_EQ(d.at<double>(0), 0.262383);
  EXPECT_EQ(d.at<double>(1), -0.953104);
  EXPECT_EQ(d.at<double>(2), -0.005358);
  EXPECT_EQ(d.at<double>(3), 0.002628);
  EXPECT_EQ(d.at<double>(4), 1.163314);
  EXPECT_TRUE(cam.HasDistortion());
}

}  // namespace
}  // namespace rumi
