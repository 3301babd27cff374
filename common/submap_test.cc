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

}  // namespace
}  // namespace rumi
