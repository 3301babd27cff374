#include "common/pose_jumps.h"

#include <gtest/gtest.h>

#include <cmath>

namespace rumi {
namespace {

// A walk along a curve at 30 fps with a sparse stretch (every 5th frame, as
// S1/S3 samples) and a dense one (S2); points seen by every keyframe.
Submap Walk(int n) {
  Submap s;
  s.source = SubmapSource::kBack;
  Timestamp t = SecondsToNs(1000.0);
  for (int i = 0; i < n; ++i) {
    t += (i < n / 3 || i > 2 * n / 3) ? SecondsToNs(5.0 / 30) : SecondsToNs(1.0 / 30);
    Keyframe k;
    k.id = 100 + i;
    k.timestamp = t;
    const double x = 0.5 * NsToSeconds(t - SecondsToNs(1000.0));  // 0.5 units/s
    k.T_cw = Se3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x, 0.2 * std::sin(x), 0)).Inverse();
    k.point_ids = {7, 8};
    s.keyframes.push_back(k);
  }
  for (int64_t id : {7, 8}) {
    MapPoint p;
    p.id = id;
    p.position = Eigen::Vector3d(0, 0, 5);
    for (const Keyframe& k : s.keyframes) p.observations.push_back({k.id, int(id - 7)});
    s.points.push_back(p);
  }
  return s;
}

void Teleport(Submap* s, size_t i, const Eigen::Vector3d& offset) {
  s->keyframes[i].T_cw = Se3(s->keyframes[i].T_wc().rotation(), s->keyframes[i].T_wc().translation() + offset).Inverse();
}

TEST(PoseJumps, ASmoothPathWithSparseAndDenseStretchesHasNone) {
  const Submap s = Walk(60);
  EXPECT_TRUE(PoseJumps(s, 10.0).empty());
  // A stop (the camera still for a while) and a fast stretch are not jumps either.
  Submap still = Walk(60);
  for (size_t i = 10; i < 30; ++i) still.keyframes[i].T_cw = still.keyframes[10].T_cw;
  EXPECT_TRUE(PoseJumps(still, 10.0).empty());
}

TEST(PoseJumps, AFrameOffThePathIsFoundAndDropped) {
  // corridor seed 5: neighbours 0.1 apart, the frame 70 away.
  for (size_t i : {size_t(0), size_t(25), size_t(59)}) {
    Submap s = Walk(60);
    Teleport(&s, i, Eigen::Vector3d(-36, -25, 66));
    const auto jumps = PoseJumps(s, 10.0);
    ASSERT_EQ(jumps.size(), 1u) << i;
    EXPECT_EQ(jumps[0], i);
    EXPECT_TRUE(PoseJumps(s, 0.0).empty());  // off
    const int64_t id = s.keyframes[i].id;
    EXPECT_EQ(DropKeyframesAt(&s, jumps), 1);
    ASSERT_EQ(s.keyframes.size(), 59u);
    for (const Keyframe& k : s.keyframes) EXPECT_NE(k.id, id);
    for (const MapPoint& p : s.points) {
      EXPECT_EQ(p.observations.size(), 59u);
      for (const auto& o : p.observations) EXPECT_NE(o.keyframe_id, id);
    }
    EXPECT_TRUE(PoseJumps(s, 10.0).empty());
  }
}

TEST(PoseJumps, AShiftedStretchIsNotAJumpOfOneFrame) {
  // Half the path moved: the break is between two groups, no single frame
  // is out of reach of two neighbours that agree.
  Submap s = Walk(40);
  for (size_t i = 20; i < 40; ++i) Teleport(&s, i, Eigen::Vector3d(30, 0, 0));
  EXPECT_TRUE(PoseJumps(s, 10.0).empty());
}

TEST(PoseJumps, PointsLeftWithoutObservationsGoToo) {
  Submap s = Walk(10);
  MapPoint only;
  only.id = 9;
  only.observations = {{s.keyframes[4].id, 2}};
  s.keyframes[4].point_ids.push_back(9);
  s.points.push_back(only);
  s.keyframes[5].point_ids.push_back(9);  // a stale link the drop must clear
  EXPECT_EQ(DropKeyframesAt(&s, {4}), 1);
  EXPECT_EQ(s.points.size(), 2u);
  EXPECT_EQ(s.keyframes[4].point_ids.back(), -1);
  EXPECT_EQ(DropKeyframesAt(&s, {}), 0);
  EXPECT_EQ(DropKeyframesAt(&s, {99}), 0);
}

}  // namespace
}  // namespace rumi
