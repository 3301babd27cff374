#include "front/feature_extractor.h"

#include "front/testing/front_test_util.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

namespace rumi {
namespace {

cv::Mat Texture(int w, int h) {
  cv::Mat img(h, w, CV_8U);
  cv::RNG rng(7);
  rng.fill(img, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(img, img, cv::Size(5, 5), 1.5);
  return img;
}


TEST(FeatureExtractor, UndistortsKeypointsWithTheCameraModel) {
  const PinholeCamera cam(QvgaCamera(-0.2));
  OrbExtractorOptions orb;
  orb.num_features = 500;
  FeatureExtractor ex(orb, cam);
  const auto f = ex.Extract(Texture(320, 240));
  ASSERT_GT(f->size(), 200u);
  ASSERT_EQ(f->un.size(), f->size());
  double moved = 0;
  for (size_t i = 0; i < f->size(); ++i) {
    const Eigen::Vector2d px(f->keypoints[i].pt.x, f->keypoints[i].pt.y);
    EXPECT_LT((f->un[i] - cam.UndistortPoint(px)).norm(), 1e-9);
    moved = std::max(moved, (f->un[i] - px).norm());
    Eigen::Vector2d back;  // the ideal ray projects back to the detected pixel
    ASSERT_TRUE(cam.Project(UndistortedRay(cam, f->un[i]), &back));
    EXPECT_LT((back - px).norm(), 1e-6);
  }
  EXPECT_GT(moved, 2.0);  // barrel distortion: the corners move outwards by pixels
  // The grid spans the undistorted image: its corners' images (barrel
  // distortion: each corner bounds one side).
  const auto c = cam.UndistortPoints({{0, 0}, {320, 0}, {0, 240}, {320, 240}});
  EXPECT_NEAR(f->min_x, std::min(c[0].x(), c[2].x()), 1e-9);
  EXPECT_NEAR(f->max_x, std::max(c[1].x(), c[3].x()), 1e-9);
  EXPECT_NEAR(f->min_y, std::min(c[0].y(), c[1].y()), 1e-9);
  EXPECT_NEAR(f->max_y, std::max(c[2].y(), c[3].y()), 1e-9);
  for (const Eigen::Vector2d& u : f->un) EXPECT_TRUE(f->InImage(u.x(), u.y())) << u.transpose();
  EXPECT_LT(f->min_x, 0);
  EXPECT_GT(f->max_x, 320);
}

TEST(FeatureExtractor, WithoutDistortionKeepsPixelsAndReadsColourAsGrey) {
  const PinholeCamera cam(QvgaCamera());
  OrbExtractorOptions orb;
  orb.num_features = 500;
  FeatureExtractor ex(orb, cam);
  const cv::Mat grey = Texture(320, 240);
  const auto f = ex.Extract(grey);
  for (size_t i = 0; i < f->size(); ++i) {
    EXPECT_EQ(f->un[i].x(), f->keypoints[i].pt.x);
    EXPECT_EQ(f->un[i].y(), f->keypoints[i].pt.y);
  }
  EXPECT_EQ(f->min_x, 0);
  EXPECT_EQ(f->max_x, 320);
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  const auto g = ex.Extract(bgr);
  ASSERT_EQ(g->size(), f->size());
  EXPECT_EQ(cv::norm(g->descriptors, f->descriptors, cv::NORM_HAMMING), 0);
  // The pyramid the matcher and the optimisers weigh by.
  EXPECT_EQ(ex.pyramid().num_levels, orb.num_levels);
  EXPECT_DOUBLE_EQ(ex.pyramid().scales[2], orb.scale_factor * orb.scale_factor);
  EXPECT_DOUBLE_EQ(ex.pyramid().inv_sigma2[1], 1.0 / (orb.scale_factor * orb.scale_factor));
}

}  // namespace
}  // namespace rumi
