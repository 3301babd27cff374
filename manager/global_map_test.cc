#include "manager/global_map.h"

#include <gtest/gtest.h>

namespace rumi {
namespace {

Submap Make(SubmapSource src, int64_t id, int keyframes) {
  Submap s;
  s.source = src;
  s.id = id;
  s.keyframes.resize(keyframes);
  return s;
}

TEST(GlobalMap, AddFindAndDuplicateKey) {
  GlobalMap m;
  EXPECT_EQ(m.AddSubmap(Make(SubmapSource::kFront, 1, 1)), 0);
  EXPECT_EQ(m.AddSubmap(Make(SubmapSource::kBack, 1, 1)), 1);  // same id, other source
  std::string why;
  EXPECT_EQ(m.AddSubmap(Make(SubmapSource::kFront, 1, 1), &why), -1);
  EXPECT_NE(why.find("front#1"), std::string::npos);
  EXPECT_EQ(m.Find({SubmapSource::kBack, 1}), 1);
  EXPECT_EQ(m.Find({SubmapSource::kBack, 2}), -1);
}

TEST(GlobalMap, UnionFindAndMoveComponent) {
  GlobalMap m;
  for (int i = 0; i < 4; ++i) m.AddSubmap(Make(SubmapSource::kFront, i, i + 1));
  EXPECT_FALSE(m.Connected(0, 1));
  m.Union(0, 1);
  m.Union(2, 3);
  EXPECT_TRUE(m.Connected(0, 1));
  EXPECT_FALSE(m.Connected(1, 2));
  EXPECT_EQ(m.LargestComponent(), m.Component(3));  // 3 + 4 keyframes
  const Sim3 S(2.0, Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ())), Eigen::Vector3d(1, 2, 3));
  m.MoveComponent(1, S);
  EXPECT_TRUE(m.ToGlobal(0).Matrix().isApprox(S.Matrix()));
  EXPECT_TRUE(m.ToGlobal(1).Matrix().isApprox(S.Matrix()));
  EXPECT_TRUE(m.ToGlobal(2).Matrix().isApprox(Eigen::Matrix4d::Identity()));
  m.MoveComponent(0, S);  // composes on the left
  EXPECT_TRUE(m.ToGlobal(1).Matrix().isApprox((S * S).Matrix()));
  m.Union(1, 3);
  EXPECT_TRUE(m.Connected(0, 2));
  EXPECT_EQ(m.Members(m.Component(0)).size(), 4u);
}

// The main component is the one covering the most frames, not the one with the
// most keyframes: a long merged map beats a dense short one (a front submap
// that keyframed every frame through a slow start).
TEST(GlobalMap, MainComponentCoversTheMostFrames) {
  GlobalMap m;
  Submap dense = Make(SubmapSource::kFront, 0, 6);
  for (int i = 0; i < 6; ++i) dense.keyframes[i].timestamp = 1000 + i;
  Submap sparse = Make(SubmapSource::kFront, 1, 2);
  sparse.keyframes[0].timestamp = 2000;
  sparse.keyframes[1].timestamp = 2009;
  for (int i = 0; i < 10; ++i) {
    FrameRecord f;
    f.timestamp = 2000 + i;  // two of them are the keyframes: counted once
    f.state = i == 5 ? TrackingState::kLost : TrackingState::kTracking;
    sparse.frames.push_back(f);
  }
  Submap back = Make(SubmapSource::kBack, 0, 3);
  for (int i = 0; i < 3; ++i) back.keyframes[i].timestamp = 2005 + 10 * i;  // 2005 (lost in front), 2015, 2025
  m.AddSubmap(dense);
  m.AddSubmap(sparse);
  m.AddSubmap(back);
  EXPECT_EQ(m.NumPosedFrames(m.Component(0)), 6);
  EXPECT_EQ(m.NumPosedFrames(m.Component(1)), 9);
  EXPECT_EQ(m.LargestComponent(), m.Component(1));  // 9 posed frames vs 6, though 2 keyframes vs 6
  m.Union(1, 2);
  EXPECT_EQ(m.NumPosedFrames(m.Component(1)), 12);  // + 2005, 2015, 2025
  EXPECT_EQ(m.ComponentsBySize(), (std::vector<int>{m.Component(1), m.Component(0)}));
}

}  // namespace
}  // namespace rumi
