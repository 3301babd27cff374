#include "common/submap.h"

#include <gtest/gtest.h>

namespace rumi {
namespace {

// Three keyframes; point 10 seen by all three, 11 by two, 12 by one.
Submap ThreeKeyframes() {
  Submap s;
  for (int k = 0; k < 3; ++k) {
    Keyframe kf;
    kf.id = k;
    kf.timestamp = k + 1;
    kf.keypoints.assign(3, Eigen::Vector2f::Zero());
    kf.octaves.assign(3, 0);
    kf.point_ids = {10, k < 2 ? 11 : -1, k == 0 ? 12 : -1};
    s.keyframes.push_back(kf);
  }
  for (int64_t id : {10, 11, 12}) {
    MapPoint p;
    p.id = id;
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < 3; ++i)
        if (s.keyframes[k].point_ids[i] == id) p.observations.push_back({k, i});
    s.points.push_back(p);
  }
  return s;
}

TEST(Submap, DropWeakPointsRemovesPointsAndTheirLinks) {
  Submap s = ThreeKeyframes();
  EXPECT_EQ(DropWeakPoints(&s, 2), 1);  // 12
  ASSERT_EQ(s.points.size(), 2u);
  EXPECT_EQ(s.keyframes[0].point_ids, (std::vector<int64_t>{10, 11, -1}));

  s = ThreeKeyframes();
  EXPECT_EQ(DropWeakPoints(&s, 3), 2);  // 11 and 12
  ASSERT_EQ(s.points.size(), 1u);
  EXPECT_EQ(s.points[0].id, 10);
  for (const Keyframe& kf : s.keyframes) {
    EXPECT_EQ(kf.point_ids[0], 10);
    EXPECT_EQ(kf.point_ids[1], -1);
    EXPECT_EQ(kf.point_ids[2], -1);
    EXPECT_EQ(kf.keypoints.size(), 3u);  // keypoints stay (image positions for pairing)
  }
  s = ThreeKeyframes();
  EXPECT_EQ(DropWeakPoints(&s, 1), 0);
  EXPECT_EQ(s.points.size(), 3u);
}

TEST(Submap, SubmapUntilKeepsWhatTheFirstKeyframesSaw) {
  Submap s = ThreeKeyframes();
  s.id = 7;
  s.keyframes[2].point_ids[2] = 13;  // seen by the last keyframe only
  MapPoint p13;
  p13.id = 13;
  p13.observations.push_back({2, 2});
  s.points.push_back(p13);
  for (int k = 0; k < 3; ++k) s.frames.push_back({Timestamp(k + 1), TrackingState::kTracking, 7, Se3()});

  const Submap u = SubmapUntil(s, 2);
  EXPECT_EQ(u.id, 7);
  ASSERT_EQ(u.keyframes.size(), 2u);
  EXPECT_EQ(u.frames.size(), 2u);
  ASSERT_EQ(u.points.size(), 3u);  // 10, 11, 12; 13 had no observation left
  EXPECT_EQ(u.points[0].observations.size(), 2u);  // 10 lost kf 2's
  EXPECT_EQ(u.points[1].observations.size(), 2u);
  EXPECT_EQ(u.points[2].id, 12);
  EXPECT_EQ(SubmapUntil(s, 3).points.size(), 4u);
  EXPECT_TRUE(SubmapUntil(s, 0).keyframes.empty());
  EXPECT_TRUE(SubmapUntil(s, 0).points.empty());
}

// Two points in front of three cameras along x; each keyframe has a free
// keypoint where the points project (plus offsets), point 0 observed by
// keyframe 0 only, point 1 by keyframes 0 and 1.
TEST(Submap, CompleteTracksAddsObservationsAtFreeKeypoints) {
  Submap s;
  s.camera = {640, 480, 500, 500, 320, 240};
  const std::vector<Eigen::Vector3d> X = {{0.1, 0.2, 4.0}, {-0.5, -0.3, 6.0}};
  for (int k = 0; k < 3; ++k) {
    Keyframe kf;
    kf.id = 10 + k;
    kf.T_cw = Se3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.3 * k, 0, 0));
    for (const Eigen::Vector3d& x : X) {
      const Eigen::Vector3d c = kf.T_cw * x;
      kf.keypoints.emplace_back(500 * c.x() / c.z() + 320, 500 * c.y() / c.z() + 240);
    }
    kf.keypoints[0] += Eigen::Vector2f(0.8f, -0.6f);  // 1 px off: within 2 px
    kf.keypoints[1] += Eigen::Vector2f(k == 2 ? 2.5f : 0.f, 0.f);  // keyframe 2: too far
    kf.keypoints.emplace_back(kf.keypoints[0] + Eigen::Vector2f(1.9f, 0.f));  // a farther rival
    kf.point_ids = {-1, -1, -1};
    kf.octaves.assign(3, 0);
    s.keyframes.push_back(kf);
  }
  for (int p = 0; p < 2; ++p) {
    MapPoint mp;
    mp.id = 100 + p;
    mp.position = X[p];
    s.points.push_back(mp);
  }
  auto observe = [&](int p, int k) {
    s.keyframes[k].point_ids[p] = s.points[p].id;
    s.points[p].observations.push_back({s.keyframes[k].id, p});
  };
  observe(0, 0);
  observe(1, 0);
  observe(1, 1);
  // Keyframe 2 sees point 1 only 2.5 px off: not within 2 px.
  EXPECT_EQ(CompleteTracks(&s, 2.0), 2);
  ASSERT_EQ(s.points[0].observations.size(), 3u);
  EXPECT_EQ(s.keyframes[1].point_ids, (std::vector<int64_t>{100, 101, -1}));  // the nearer keypoint wins
  EXPECT_EQ(s.keyframes[2].point_ids, (std::vector<int64_t>{100, -1, -1}));
  EXPECT_EQ(s.points[1].observations.size(), 2u);
  EXPECT_EQ(s.points[0].observations[2].keyframe_id, 12);
  EXPECT_EQ(s.points[0].observations[2].keypoint_index, 0);
  EXPECT_EQ(CompleteTracks(&s, 2.0), 0);  // nothing left to add
  EXPECT_EQ(CompleteTracks(&s, 3.0), 1);  // now keyframe 2's keypoint for point 1 is in reach

  // A point behind a camera is never claimed.
  Submap b = s;
  for (Keyframe& kf : b.keyframes) std::fill(kf.point_ids.begin(), kf.point_ids.end(), -1);
  for (MapPoint& p : b.points) p.observations.clear(), p.position.z() = -p.position.z();
  EXPECT_EQ(CompleteTracks(&b, 5.0), 0);
}

// One point seen by keyframe 0; keyframe 1 has two free keypoints near its
// projection at `d1` and `d2` px.
Submap TwoCandidates(float d1, float d2) {
  Submap s;
  s.camera = {640, 480, 500, 500, 320, 240};
  MapPoint mp;
  mp.id = 7;
  mp.position = Eigen::Vector3d(0.2, -0.1, 5.0);
  mp.observations.push_back({0, 0});
  s.points.push_back(mp);
  for (int k = 0; k < 2; ++k) {
    Keyframe kf;
    kf.id = k;
    kf.T_cw = Se3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.2 * k, 0, 0));
    const Eigen::Vector3d c = kf.T_cw * mp.position;
    const Eigen::Vector2f px(500 * c.x() / c.z() + 320, 500 * c.y() / c.z() + 240);
    kf.keypoints = {px + Eigen::Vector2f(d1, 0.f), px + Eigen::Vector2f(0.f, d2)};
    kf.point_ids = {k == 0 ? 7 : -1, -1};
    kf.octaves.assign(2, 0);
    s.keyframes.push_back(kf);
  }
  return s;
}

TEST(Submap, CompleteTracksSkipsAmbiguousKeypoints) {
  Submap s = TwoCandidates(1.0f, 1.2f);
  EXPECT_EQ(CompleteTracks(&s, 3.0), 0);
  EXPECT_EQ(s.keyframes[1].point_ids, (std::vector<int64_t>{-1, -1}));
  s = TwoCandidates(1.0f, 2.0f);  // 1.0 < 0.7 * 2.0: clearly nearer
  EXPECT_EQ(CompleteTracks(&s, 3.0), 1);
  EXPECT_EQ(s.keyframes[1].point_ids, (std::vector<int64_t>{7, -1}));
  s = TwoCandidates(1.0f, 1.2f);  // the rival out of reach does not count
  EXPECT_EQ(CompleteTracks(&s, 1.1), 1);
  s = TwoCandidates(1.2f, 1.0f);
  EXPECT_EQ(CompleteTracks(&s, 3.0, 0.9), 1);  // a looser ratio accepts the nearer one
  EXPECT_EQ(s.keyframes[1].point_ids, (std::vector<int64_t>{-1, 7}));
}

TEST(Submap, CompleteTracksIgnoresOrbKeypoints) {
  // Keyframe 1's keypoints both carry ORB descriptors (added for the
  // manager): neither is a SIFT feature of the track, so nothing is claimed.
  Submap s = TwoCandidates(1.0f, 2.0f);
  s.keyframes[0].descriptors = cv::Mat::zeros(2, 32, CV_8U);
  s.keyframes[1].descriptors = cv::Mat::zeros(2, 32, CV_8U);
  s.keyframes[1].descriptors.at<uint8_t>(0, 3) = 0x10;
  s.keyframes[1].descriptors.at<uint8_t>(1, 9) = 0x01;
  EXPECT_EQ(CompleteTracks(&s, 3.0), 0);
  // All-zero rows mean "no descriptor": the SIFT keypoint is used again.
  s.keyframes[1].descriptors.at<uint8_t>(0, 3) = 0;
  EXPECT_EQ(CompleteTracks(&s, 3.0), 1);
  EXPECT_EQ(s.keyframes[1].point_ids, (std::vector<int64_t>{7, -1}));
}

}  // namespace
}  // namespace rumi
