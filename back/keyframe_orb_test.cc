#include "back/keyframe_orb.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <random>

namespace rumi {
namespace {

cv::Mat Checkers() {  // random grey blocks: plenty of FAST corners
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> grey(0, 255);
  cv::Mat img(240, 320, CV_8U);
  for (int y = 0; y < img.rows; y += 12)
    for (int x = 0; x < img.cols; x += 12)
      cv::rectangle(img, cv::Rect(x, y, 12, 12), cv::Scalar(grey(rng)), cv::FILLED);
  return img;
}

TEST(KeyframeOrb, AppendsDescribedKeypointsAfterTheSiftOnes) {
  Keyframe kf;
  for (int i = 0; i < 5; ++i) {  // COLMAP's keypoints, two with a point
    kf.keypoints.emplace_back(10.f * i, 20.f);
    kf.octaves.push_back(0);
    kf.point_ids.push_back(i < 2 ? i : -1);
  }
  OrbExtractorOptions oo;
  oo.num_features = 300;
  OrbExtractor orb(oo);
  const int added = AddOrbKeypoints(Checkers(), &orb, &kf);
  ASSERT_GT(added, 150);
  ASSERT_EQ(kf.keypoints.size(), size_t(5 + added));
  ASSERT_EQ(kf.octaves.size(), kf.keypoints.size());
  ASSERT_EQ(kf.point_ids.size(), kf.keypoints.size());
  ASSERT_EQ(kf.descriptors.rows, int(kf.keypoints.size()));
  ASSERT_EQ(kf.descriptors.cols, 32);
  EXPECT_EQ(kf.point_ids[0], 0);
  EXPECT_EQ(kf.point_ids[1], 1);
  for (int i = 0; i < 5; ++i) EXPECT_FALSE(HasDescriptor(kf.descriptors.ptr<uint8_t>(i)));
  int levels_above_0 = 0;
  for (int i = 5; i < kf.descriptors.rows; ++i) {
    EXPECT_TRUE(HasDescriptor(kf.descriptors.ptr<uint8_t>(i)));
    EXPECT_EQ(kf.point_ids[i], -1);
    EXPECT_LT(kf.octaves[i], oo.num_levels);
    levels_above_0 += kf.octaves[i] > 0;
    EXPECT_GE(kf.keypoints[i].x(), 0.f);
    EXPECT_LT(kf.keypoints[i].x(), 320.f);
  }
  EXPECT_GT(levels_above_0, 0);  // the pyramid is used
}

TEST(KeyframeOrb, BlankImageAddsNothingButKeepsRowsAligned) {
  Keyframe kf;
  kf.keypoints.emplace_back(1.f, 2.f);
  kf.octaves.push_back(0);
  kf.point_ids.push_back(7);
  OrbExtractorOptions oo;
  oo.num_features = 300;
  OrbExtractor orb(oo);
  EXPECT_EQ(AddOrbKeypoints(cv::Mat(240, 320, CV_8U, cv::Scalar(90)), &orb, &kf), 0);
  EXPECT_EQ(kf.keypoints.size(), 1u);
  EXPECT_EQ(kf.descriptors.rows, 1);
  EXPECT_EQ(kf.point_ids[0], 7);
}

}  // namespace
}  // namespace rumi
