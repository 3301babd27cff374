#include "manager/common_points.h"

#include <gtest/gtest.h>

#include <unordered_map>

#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {

void AddKeypoint(Keyframe* kf, float x, float y, int64_t pid) {
  kf->keypoints.emplace_back(x, y);
  kf->octaves.push_back(0);
  kf->point_ids.push_back(pid);
}

TEST(CommonPoints, RadiusAndMapPointRequired) {
  Submap f, b;
  f.keyframes.resize(1);
  b.keyframes.resize(1);
  AddKeypoint(&f.keyframes[0], 100, 100, 1);
  AddKeypoint(&b.keyframes[0], 100.5f, 100, -1);  // nearest, but no map point
  AddKeypoint(&b.keyframes[0], 102, 100, 20);
  AddKeypoint(&f.keyframes[0], 200, 200, 2);
  AddKeypoint(&b.keyframes[0], 200, 203.1f, 21);  // 3.1 px: too far
  AddKeypoint(&f.keyframes[0], 300, 300, -1);      // front keypoint without point
  AddKeypoint(&b.keyframes[0], 300, 300, 22);
  AddKeypoint(&f.keyframes[0], 400, 400, 3);
  AddKeypoint(&b.keyframes[0], 402.9f, 400, 23);   // 2.9 px: in
  const auto c = FindCommonPoints(f, b, {{0, 0, 0}}, 3.0);
  ASSERT_EQ(c.matches.size(), 2u);
  EXPECT_EQ(c.matches[0].front_point_id, 1);
  EXPECT_EQ(c.matches[0].back_point_id, 20);
  EXPECT_EQ(c.matches[1].front_point_id, 3);
  EXPECT_EQ(c.matches[1].back_point_id, 23);
  EXPECT_EQ(c.keypoint_matches, 2);
}

TEST(CommonPoints, FramePairProjectsNeighbourKeyframePoints) {
  Submap f, b;
  f.camera = {640, 480, 500, 500, 320, 240};
  FrameRecord r;
  r.state = TrackingState::kTracking;
  r.T_wc = Se3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0));
  f.frames.push_back(r);
  f.keyframes.resize(1);
  auto point = [&](int64_t id, const Eigen::Vector3d& X, bool observed) {
    MapPoint p;
    p.id = id;
    p.position = X;
    f.points.push_back(p);
    if (observed) AddKeypoint(&f.keyframes[0], 0, 0, id);  // position in the keyframe is irrelevant
  };
  point(1, {1, 0, 5}, true);             // -> (320, 240)
  point(2, {-1.2, 0, 5}, true);          // -> (100, 240)
  point(3, {-1.185, 0, 5}, true);        // -> (101.5, 240): competes with 2
  point(4, {0.2, -0.6, -5}, true);       // behind: would be (400, 300)
  point(5, {4.21, 0, 5}, true);          // -> (641, 240): outside the image
  point(6, {1.5, 0, 5}, false);          // -> (370, 240) but no neighbour keyframe sees it
  b.keyframes.resize(1);
  AddKeypoint(&b.keyframes[0], 321, 240, 20);
  AddKeypoint(&b.keyframes[0], 100.6f, 240, 21);  // d1 0.6, d2 0.9
  AddKeypoint(&b.keyframes[0], 400, 300, 22);
  AddKeypoint(&b.keyframes[0], 639.5f, 240, 23);
  AddKeypoint(&b.keyframes[0], 370, 240, 24);
  AddKeypoint(&b.keyframes[0], 320, 241, -1);  // no map point
  const std::vector<FramePair> fp{{0, 0, 0, {0}}};
  auto c = FindCommonPoints(f, b, {}, fp, 3.0, 0.5);
  ASSERT_EQ(c.matches.size(), 1u);
  EXPECT_EQ(c.matches[0].front_point_id, 1);
  EXPECT_EQ(c.matches[0].back_point_id, 20);
  // A looser ratio lets the nearer of the competing projections through.
  c = FindCommonPoints(f, b, {}, fp, 3.0, 1.0);
  ASSERT_EQ(c.matches.size(), 2u);
  EXPECT_EQ(c.matches[1].front_point_id, 2);
  EXPECT_EQ(c.matches[1].back_point_id, 21);
  EXPECT_EQ(c.keypoint_matches, 2);
}

TEST(CommonPoints, ScenarioFramePairsMatchSameScenePoints) {
  const auto s = testing::MakeScenario(3, 1.0, 1200, true, /*back_on_odd_frames=*/true);
  const SearchSet every = BuildSearchSet({}, {&s.back.submap}, 0);
  const auto pairs = PairKeyframes(s.front_a.submap, s.back.submap, every, 100000);
  ASSERT_TRUE(pairs.empty());
  const auto fp = PairTrackedFrames(s.front_a.submap, s.back.submap, every, 100000, pairs, 3);
  ASSERT_EQ(fp.size(), 5u);  // back 31..39 against A's tracked frames
  const auto c = FindCommonPoints(s.front_a.submap, s.back.submap, pairs, fp, 3.0);
  std::unordered_map<int64_t, int> scene_of_front, scene_of_back;
  for (size_t i = 0; i < s.front_a.submap.points.size(); ++i)
    scene_of_front[s.front_a.submap.points[i].id] = s.front_a.scene_point[i];
  for (size_t i = 0; i < s.back.submap.points.size(); ++i)
    scene_of_back[s.back.submap.points[i].id] = s.back.scene_point[i];
  int correct = 0;
  for (const auto& m : c.matches) correct += scene_of_front.at(m.front_point_id) == scene_of_back.at(m.back_point_id);
  EXPECT_GT(c.matches.size(), 100u);
  EXPECT_GT(double(correct) / c.matches.size(), 0.85);
}

TEST(CommonPoints, VotingKeepsMostFrequent) {
  Submap f, b;
  f.keyframes.resize(3);
  b.keyframes.resize(3);
  // Front point 1 coincides with back point 10 on two pairs and 11 on one.
  AddKeypoint(&f.keyframes[0], 50, 50, 1);
  AddKeypoint(&b.keyframes[0], 50, 51, 11);
  AddKeypoint(&f.keyframes[1], 60, 60, 1);
  AddKeypoint(&b.keyframes[1], 61, 60, 10);
  AddKeypoint(&f.keyframes[2], 70, 70, 1);
  AddKeypoint(&b.keyframes[2], 70, 70, 10);
  // Back point 10 also hit once by front point 2: 1 keeps it (2 votes).
  AddKeypoint(&f.keyframes[2], 90, 90, 2);
  AddKeypoint(&b.keyframes[2], 90, 91, 10);
  const auto c = FindCommonPoints(f, b, {{0, 0, 0}, {1, 1, 0}, {2, 2, 0}}, 3.0);
  ASSERT_EQ(c.matches.size(), 1u);
  EXPECT_EQ(c.matches[0].front_point_id, 1);
  EXPECT_EQ(c.matches[0].back_point_id, 10);
  EXPECT_EQ(c.matches[0].votes, 2);
  EXPECT_EQ(c.keypoint_matches, 4);
  EXPECT_EQ(c.conflicts_dropped, 2);
}

TEST(CommonPoints, ScenarioMatchesSameScenePoints) {
  const auto s = testing::MakeScenario();
  const SearchSet every = BuildSearchSet({}, {&s.back.submap}, 0);
  const auto pairs = PairKeyframes(s.front_a.submap, s.back.submap, every, 100000);
  ASSERT_EQ(pairs.size(), 6u);
  const auto c = FindCommonPoints(s.front_a.submap, s.back.submap, pairs, 3.0);
  std::unordered_map<int64_t, int> scene_of_front, scene_of_back;
  for (size_t i = 0; i < s.front_a.submap.points.size(); ++i)
    scene_of_front[s.front_a.submap.points[i].id] = s.front_a.scene_point[i];
  for (size_t i = 0; i < s.back.submap.points.size(); ++i)
    scene_of_back[s.back.submap.points[i].id] = s.back.scene_point[i];
  int correct = 0;
  for (const auto& m : c.matches) {
    ASSERT_TRUE(scene_of_front.count(m.front_point_id));
    ASSERT_TRUE(scene_of_back.count(m.back_point_id));
    correct += scene_of_front[m.front_point_id] == scene_of_back[m.back_point_id];
    EXPECT_GE(m.votes, 1);
    EXPECT_LE(m.votes, 6);
  }
  EXPECT_GT(c.matches.size(), 100u);
  // 1 px noise, 3 px radius and clutter: most matches are right, not all.
  EXPECT_GT(double(correct) / c.matches.size(), 0.85);
  // Unique on both sides.
  std::unordered_map<int64_t, int> seen_b;
  for (const auto& m : c.matches) EXPECT_EQ(++seen_b[m.back_point_id], 1);
}

}  // namespace
}  // namespace rumi
