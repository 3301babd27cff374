#include "common/pose_buffer.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

namespace rumi {
namespace {

Se3 Yaw(double rad, double x) {
  return Se3(Eigen::Quaterniond(Eigen::AngleAxisd(rad, Eigen::Vector3d::UnitZ())), Eigen::Vector3d(x, 0, 0));
}

TEST(PoseBuffer, InterpolatesPositionAndRotationBetweenNeighbours) {
  PoseBuffer b;
  EXPECT_FALSE(b.At(0));
  ASSERT_TRUE(b.Add(100, Yaw(0.0, 0.0)));
  ASSERT_TRUE(b.Add(200, Yaw(0.4, 2.0)));
  ASSERT_TRUE(b.Add(300, Yaw(0.4, 4.0)));
  const auto mid = b.At(150);
  ASSERT_TRUE(mid);
  EXPECT_NEAR(mid->translation().x(), 1.0, 1e-12);
  EXPECT_NEAR(mid->rotation().angularDistance(Yaw(0.2, 0).rotation()), 0.0, 1e-12);
  const auto quarter = b.At(225);
  ASSERT_TRUE(quarter);
  EXPECT_NEAR(quarter->translation().x(), 2.5, 1e-12);
  EXPECT_NEAR(b.At(200)->translation().x(), 2.0, 0.0);  // exact at a stored pose
  EXPECT_NEAR(b.At(100)->translation().x(), 0.0, 0.0);
  EXPECT_FALSE(b.At(99));  // outside: no extrapolation
  EXPECT_FALSE(b.At(301));
}

TEST(PoseBuffer, KeepsTimeOrderAndItsBound) {
  PoseBuffer b(2);
  EXPECT_TRUE(b.Add(10, Yaw(0, 1)));
  EXPECT_FALSE(b.Add(10, Yaw(0, 5)));  // same time: ignored
  EXPECT_FALSE(b.Add(5, Yaw(0, 5)));   // older: ignored
  EXPECT_TRUE(b.Add(20, Yaw(0, 2)));
  EXPECT_TRUE(b.Add(30, Yaw(0, 3)));
  EXPECT_EQ(b.size(), 2u);  // the oldest dropped
  EXPECT_EQ(b.first_time(), 20);
  EXPECT_EQ(b.last_time(), 30);
  EXPECT_FALSE(b.At(15));
  EXPECT_NEAR(b.At(25)->translation().x(), 2.5, 1e-12);
}

}  // namespace
}  // namespace rumi
