// The matcher's gates on hand-made descriptors (black box: front/matcher.h
// only): the distance thresholds, the ratio test, the search window and the
// pyramid level (the brute-force matcher: common/descriptor_match_test.cc).
#include "front/matcher.h"

#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <utility>
#include <vector>

#include "common/testing/descriptors.h"
#include "front/testing/front_test_util.h"

namespace rumi {
namespace {

using Pairs = std::vector<std::pair<int, int>>;

using test::Flipped;
using test::RandomDescriptor;
using test::Rows;

// Features of a 640 x 480 image: keypoints at `at` (undistorted = detected,
// angle 0), octaves `octave`, descriptor rows `desc`.
std::shared_ptr<Features> MakeFeatures(const std::vector<Eigen::Vector2d>& at, const std::vector<int>& octave,
                                       const std::vector<cv::Mat>& desc) {
  auto f = std::make_shared<Features>();
  f->width = 640;
  f->height = 480;
  f->max_x = 640;
  f->max_y = 480;
  for (size_t i = 0; i < at.size(); ++i) {
    f->keypoints.emplace_back(static_cast<float>(at[i].x()), static_cast<float>(at[i].y()), 31.f, 0.f, 0.f,
                              octave[i]);
    f->un.push_back(at[i]);
  }
  f->descriptors = Rows(desc);
  f->BuildGrid(64, 48);
  return f;
}

TEST(SearchForInitialization, DistanceGateRatioWindowAndLevel) {
  std::mt19937 rng(4);
  std::vector<cv::Mat> desc1;
  for (int i = 0; i < 6; ++i) desc1.push_back(RandomDescriptor(&rng));
  const std::vector<Eigen::Vector2d> at1 = {{100, 100}, {200, 100}, {300, 100}, {400, 100}, {500, 100}, {100, 300}};
  const auto f1 = MakeFeatures(at1, {0, 0, 0, 0, 0, 0}, desc1);
  // In image 2, each feature of image 1 finds:
  //   0: its twin 10 bits away, 3 px off             -> matched
  //   1: its twin 50 bits away (the gate, kDescLow)  -> matched
  //   2: its twin 51 bits away                       -> not
  //   3: two twins 20 and 21 bits away (ratio 0.9)   -> not
  //   4: its twin 0 bits away but 30 px off          -> not (outside the window)
  //   5: its twin 0 bits away at another octave      -> not
  const std::vector<Eigen::Vector2d> at2 = {{103, 100}, {200, 104}, {300, 100}, {398, 100},
                                            {402, 100}, {530, 100}, {100, 300}};
  const auto f2 = MakeFeatures(at2, {0, 0, 0, 0, 0, 0, 1},
                               {Flipped(desc1[0], 10), Flipped(desc1[1], 50), Flipped(desc1[2], 51),
                                Flipped(desc1[3], 20), Flipped(desc1[3], 21), desc1[4], desc1[5]});
  std::vector<Eigen::Vector2d> prev = at1;
  std::vector<int> m12;
  EXPECT_EQ(SearchForInitialization(*f1, *f2, &prev, 10, &m12), 2);
  EXPECT_EQ(m12, (std::vector<int>{0, 1, -1, -1, -1, -1}));
  // A match moves its search centre to where it was found; the rest stay.
  EXPECT_EQ(prev[0], at2[0]);
  EXPECT_EQ(prev[1], at2[1]);
  for (int i = 2; i < 6; ++i) EXPECT_EQ(prev[i], at1[i]) << i;
  // A wider window reaches feature 4's twin.
  prev = at1;
  EXPECT_EQ(SearchForInitialization(*f1, *f2, &prev, 40, &m12), 3);
  EXPECT_EQ(m12[4], 5);
}

// The tracking gate (kDescHigh): the last frame's point projected into the
// current frame takes the nearest feature when it is at most 100 bits away.
TEST(SearchByProjection, TakesTheFeatureUnderTheProjectionWithinTheTrackingGate) {
  const PinholeCamera cam(QvgaCamera());  // principal point (159.5, 119.5)
  const ScalePyramid pyr(8, 1.2);
  std::mt19937 rng(5);
  const cv::Mat d = RandomDescriptor(&rng);
  Landmark p;
  p.pos = Eigen::Vector3d(0, 0, 5);  // projects to the principal point at identity
  p.descriptor = d;
  TrackFrame last;
  last.f = MakeFeatures({{159.5, 119.5}}, {0}, {d});
  last.Reset(1);
  last.points[0] = &p;
  for (const auto& [bits, matched] : {std::make_pair(kDescHigh, 1), std::make_pair(kDescHigh + 1, 0)}) {
    TrackFrame cur;
    cur.f = MakeFeatures({{160.5, 119.5}, {300, 200}}, {0, 0}, {Flipped(d, bits), d});
    cur.Reset(2);
    EXPECT_EQ(SearchByProjection(&cur, last, cam, pyr, 5, false), matched) << bits << " bits";
    EXPECT_EQ(cur.points[0], matched ? &p : nullptr) << bits << " bits";
    EXPECT_EQ(cur.points[1], nullptr) << "outside the window";
  }
}

}  // namespace
}  // namespace rumi
