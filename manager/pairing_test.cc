#include "manager/pairing.h"

#include <gtest/gtest.h>

#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {

Submap WithKeyframesAt(const std::vector<Timestamp>& ts, SubmapSource src) {
  Submap s;
  s.source = src;
  for (size_t i = 0; i < ts.size(); ++i) {
    Keyframe kf;
    kf.id = int64_t(i);
    kf.timestamp = ts[i];
    s.keyframes.push_back(kf);
  }
  return s;
}

TEST(Pairing, ThresholdIsStrictlyBelow100us) {
  const Timestamp t = 1000000000000LL;
  const Submap front = WithKeyframesAt({t, t + 10000000, t + 20000000, t + 30000000}, SubmapSource::kFront);
  // 99999 ns pairs, 100000 ns does not, negative dt too.
  const Submap back = WithKeyframesAt({t + 99999, t + 10000000 + 100000, t + 20000000 - 99999,
                                       t + 30000000 - 100000},
                                      SubmapSource::kBack);
  SearchSet all;
  all.set_all(true);
  const auto pairs = PairKeyframes(front, back, all, 100000);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0].front_keyframe, 0);
  EXPECT_EQ(pairs[0].back_keyframe, 0);
  EXPECT_EQ(pairs[0].dt_ns, 99999);
  EXPECT_EQ(pairs[1].front_keyframe, 2);
  EXPECT_EQ(pairs[1].back_keyframe, 2);
  EXPECT_EQ(pairs[1].dt_ns, -99999);
}

TEST(Pairing, TrackedFramesWhereNoKeyframePair) {
  const Timestamp t = 1000000000000LL, d = 33333333;
  Submap front = WithKeyframesAt({t, t + 3 * d, t + 6 * d, t + 9 * d, t + 12 * d}, SubmapSource::kFront);
  front.id = 7;
  for (int i = 0; i <= 12; ++i) {
    FrameRecord r;
    r.timestamp = t + i * d;
    r.state = i == 4 ? TrackingState::kLost : TrackingState::kTracking;
    r.submap_id = i == 8 ? 9 : 7;  // frame 8 belongs to another submap
    front.frames.push_back(r);
  }
  const Submap back = WithKeyframesAt({t + d, t + 3 * d, t + 4 * d, t + 5 * d + 99999, t + 8 * d,
                                       t + 7 * d - 100000},
                                      SubmapSource::kBack);
  SearchSet all;
  all.set_all(true);
  const auto kf_pairs = PairKeyframes(front, back, all, 100000);
  ASSERT_EQ(kf_pairs.size(), 1u);
  EXPECT_EQ(kf_pairs[0].back_keyframe, 1);
  const auto fp = PairTrackedFrames(front, back, all, 100000, kf_pairs, 2);
  ASSERT_EQ(fp.size(), 2u);
  EXPECT_EQ(fp[0].back_keyframe, 0);
  EXPECT_EQ(fp[0].front_frame, 1);
  EXPECT_EQ(fp[0].dt_ns, 0);
  EXPECT_EQ(fp[0].front_keyframes, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(fp[1].back_keyframe, 3);
  EXPECT_EQ(fp[1].front_frame, 5);
  EXPECT_EQ(fp[1].dt_ns, 99999);
  EXPECT_EQ(fp[1].front_keyframes, (std::vector<int>{0, 1, 2, 3}));
  // Without the keyframe pair, back keyframe 1 pairs with frame 3 instead.
  EXPECT_EQ(PairTrackedFrames(front, back, all, 100000, {}, 2).size(), 3u);
  // Only members of F^search.
  SearchSet some;
  some.Add(t + 5 * d);
  const auto fs = PairTrackedFrames(front, back, some, 100000, kf_pairs, 1);
  ASSERT_EQ(fs.size(), 1u);
  EXPECT_EQ(fs[0].back_keyframe, 3);
  EXPECT_EQ(fs[0].front_keyframes, (std::vector<int>{1, 2}));
}

TEST(Pairing, OneToOneNearest) {
  const Timestamp t = 5000000000LL;
  // Two back keyframes near one front keyframe: only the nearer pairs.
  const Submap front = WithKeyframesAt({t + 50, t + 300000}, SubmapSource::kFront);
  const Submap back = WithKeyframesAt({t + 60, t}, SubmapSource::kBack);
  SearchSet all;
  all.set_all(true);
  const auto pairs = PairKeyframes(front, back, all, 100000);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].front_keyframe, 0);
  EXPECT_EQ(pairs[0].back_keyframe, 0);  // |dt| 10 beats 50 (first come, nearer)
}

TEST(Pairing, SearchSetEndsOfBackAndFailedFrames) {
  const auto s = testing::MakeScenario();
  const auto& ts = s.scene.timestamps;
  const SearchSet set = BuildSearchSet({&s.front_a.submap, &s.front_b.submap}, {&s.back.submap}, 10);
  for (int f : {30, 39, 45, 55, 69, 71, 80}) EXPECT_TRUE(set.Contains(ts[f], 100000)) << f;
  for (int f : {20, 29, 40, 70, 81, 100}) EXPECT_FALSE(set.Contains(ts[f], 100000)) << f;
  // Tolerance is the pairing one.
  EXPECT_TRUE(set.Contains(ts[30] + 99999, 100000));
  EXPECT_FALSE(set.Contains(ts[30] - 100000, 100000));
}

TEST(Pairing, ScenarioPairsOnlyAtBackEnds) {
  const auto s = testing::MakeScenario();
  const SearchSet set = BuildSearchSet({&s.front_a.submap, &s.front_b.submap}, {&s.back.submap}, 10);
  const auto pa = PairKeyframes(s.front_a.submap, s.back.submap, set, 100000);
  // A has keyframes on even frames; back's first 10 keyframes are frames 30-39.
  ASSERT_EQ(pa.size(), 5u);
  for (const auto& p : pa) {
    EXPECT_EQ(s.front_a.submap.keyframes[p.front_keyframe].timestamp, s.back.submap.keyframes[p.back_keyframe].timestamp);
    EXPECT_EQ(p.dt_ns, 0);
  }
  const auto pb = PairKeyframes(s.front_b.submap, s.back.submap, set, 100000);
  EXPECT_EQ(pb.size(), 5u);  // 72..80 even
  // n = 0: every back keyframe; A shares frames 30..40 even.
  const SearchSet every = BuildSearchSet({}, {&s.back.submap}, 0);
  EXPECT_EQ(PairKeyframes(s.front_a.submap, s.back.submap, every, 100000).size(), 6u);
  // Submaps without common frames do not pair.
  EXPECT_TRUE(PairKeyframes(s.front_a.submap, s.front_b.submap, every, 100000).empty());
}

}  // namespace
}  // namespace rumi
