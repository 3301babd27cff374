#include "common/pnp.h"

#include <gtest/gtest.h>

#include <random>

namespace rumi {
namespace {

TEST(PnpRansacFromGuess, FindsThePoseFromANearbyGuessAndNamesTheOutliers) {
  CameraIntrinsics K;
  K.fx = K.fy = 300;
  K.cx = 160;
  K.cy = 120;
  K.width = 320;
  K.height = 240;
  const Se3 truth(Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d(0.3, 1, 0.1).normalized())),
                  Eigen::Vector3d(0.1, -0.2, 0.5));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<cv::Point3f> points;
  std::vector<cv::Point2f> keypoints;
  for (int i = 0; i < 60; ++i) {
    const Eigen::Vector3d X(u(rng), u(rng), 4 + u(rng));
    const Eigen::Vector3d c = truth * X;
    Eigen::Vector2d uv(K.fx * c.x() / c.z() + K.cx, K.fy * c.y() / c.z() + K.cy);
    if (i % 10 == 0) uv += Eigen::Vector2d(40, -30);  // 6 outliers
    points.emplace_back(float(X.x()), float(X.y()), float(X.z()));
    keypoints.emplace_back(float(uv.x()), float(uv.y()));
  }
  const Se3 guess(Eigen::Quaterniond(Eigen::AngleAxisd(0.15, Eigen::Vector3d(0.3, 1, 0.1).normalized())),
                  Eigen::Vector3d(0.05, -0.1, 0.6));
  Se3 T_cw;
  std::vector<int> inliers;
  ASSERT_TRUE(PnpRansacFromGuess(points, keypoints, K, guess.rotation().toRotationMatrix(), guess.translation(), 2.0,
                                 &T_cw, &inliers));
  EXPECT_EQ(inliers.size(), 54u);
  for (int i : inliers) EXPECT_NE(i % 10, 0) << i;
  EXPECT_LT((T_cw.translation() - truth.translation()).norm(), 1e-3);
  EXPECT_LT(T_cw.rotation().angularDistance(truth.rotation()), 1e-4);
}

}  // namespace
}  // namespace rumi
