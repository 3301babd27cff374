#include "manager/merge_memo.h"

#include <gtest/gtest.h>

#include "manager/place_merge.h"
#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {

GlobalMap Inputs(const testing::Scenario& s, const Submap& front_b) {
  GlobalMap map;
  map.AddSubmap(s.front_a.submap);
  map.AddSubmap(front_b);
  map.AddSubmap(s.back.submap);
  return map;
}

int Merged(const std::vector<MergeReport>& reports) {
  int n = 0;
  for (const MergeReport& r : reports) n += r.merged;
  return n;
}

// Same submaps, same Sim(3)s, same components and fused links, bit for bit.
void ExpectSameMap(const GlobalMap& x, const GlobalMap& y) {
  ASSERT_EQ(x.size(), y.size());
  for (size_t i = 0; i < x.size(); ++i) {
    EXPECT_EQ(SubmapFingerprint(x.submap(int(i))), SubmapFingerprint(y.submap(int(i)))) << "submap " << i;
    EXPECT_EQ(x.ToGlobal(int(i)).Matrix(), y.ToGlobal(int(i)).Matrix()) << "submap " << i;
    EXPECT_EQ(x.Component(int(i)), y.Component(int(i)));
  }
  ASSERT_EQ(x.fused().size(), y.fused().size());
  for (size_t k = 0; k < x.fused().size(); ++k) {
    EXPECT_EQ(x.fused()[k].dup_point, y.fused()[k].dup_point);
    EXPECT_EQ(x.fused()[k].kept_point, y.fused()[k].kept_point);
  }
}

TEST(MergeMemo, FingerprintSeesEveryKindOfChange) {
  const auto s = testing::MakeScenario();
  const Submap& a = s.front_a.submap;
  const uint64_t fp = SubmapFingerprint(a);
  EXPECT_EQ(fp, SubmapFingerprint(Submap(a)));
  auto changed = [&](auto edit) {
    Submap c = a;
    edit(&c);
    return SubmapFingerprint(c) != fp;
  };
  EXPECT_TRUE(changed([](Submap* c) { c->keyframes[3].T_cw.translation().x() += 1e-9; }));
  EXPECT_TRUE(changed([](Submap* c) { c->keyframes[3].keypoints[5].y() += 0.5f; }));
  EXPECT_TRUE(changed([](Submap* c) { c->keyframes[3].point_ids[5] = -1; }));
  EXPECT_TRUE(changed([](Submap* c) { c->points[7].position.z() += 1e-9; }));
  EXPECT_TRUE(changed([](Submap* c) { c->points[7].observations.pop_back(); }));
  EXPECT_TRUE(changed([](Submap* c) { c->frames.back().state = TrackingState::kTracking; }));
  EXPECT_TRUE(changed([](Submap* c) { c->keyframes.pop_back(); }));
  EXPECT_TRUE(changed([](Submap* c) { c->id = 9; }));
}

TEST(MergeMemo, ReplaysUnchangedMergesAndComputesTheGrownSubmapsOnly) {
  const auto s = testing::MakeScenario();
  MergeMemo memo;
  const ManagerOptions o;

  // First rebuild: everything computed; the result is MergeAll's.
  GlobalMap plain = Inputs(s, s.front_b.submap);
  const auto plain_reports = MergeAll(&plain, o);
  GlobalMap first = Inputs(s, s.front_b.submap);
  const auto first_reports = MergeAll(&first, o, &memo);
  ASSERT_EQ(Merged(first_reports), 2);
  EXPECT_EQ(memo.hits(), 0);
  EXPECT_EQ(memo.misses(), 2);
  ExpectSameMap(plain, first);

  // Same inputs again: both merges replayed, the same map.
  GlobalMap second = Inputs(s, s.front_b.submap);
  const auto second_reports = MergeAll(&second, o, &memo);
  EXPECT_EQ(Merged(second_reports), 2);
  EXPECT_EQ(memo.hits(), 2);
  EXPECT_EQ(memo.misses(), 0);
  for (const MergeReport& r : second_reports) EXPECT_TRUE(r.replayed);
  ExpectSameMap(first, second);

  // Front B was resent (it grew and its last keyframe moved): A <-> back is
  // replayed, B <-> back computed, and the map equals a plain MergeAll of
  // the new inputs.
  Submap grown = s.front_b.submap;
  grown.keyframes.back().T_cw.translation().x() += 0.002;
  GlobalMap plain_grown = Inputs(s, grown);
  MergeAll(&plain_grown, o);
  GlobalMap third = Inputs(s, grown);
  EXPECT_EQ(Merged(MergeAll(&third, o, &memo)), 2);
  EXPECT_EQ(memo.hits(), 1);
  EXPECT_EQ(memo.misses(), 1);
  ExpectSameMap(plain_grown, third);
  // The old B <-> back attempt was not used in that run and is gone.
  EXPECT_EQ(memo.size(), 2u);
}

TEST(MergeMemo, ReplaysWeldedMergesBitForBit) {
  // With the welding BA the merge also moves front keyframes: the replay
  // (an edit of the changed poses and positions) must still give the
  // computed map exactly.
  const auto s = testing::MakeScenario();
  ManagerOptions o;
  o.welding_ba = true;
  MergeMemo memo;
  GlobalMap first = Inputs(s, s.front_b.submap);
  ASSERT_EQ(Merged(MergeAll(&first, o, &memo)), 2);
  GlobalMap second = Inputs(s, s.front_b.submap);
  ASSERT_EQ(Merged(MergeAll(&second, o, &memo)), 2);
  EXPECT_EQ(memo.hits(), 2);
  ExpectSameMap(first, second);
  // The welding did move keyframes (else this test would not test it).
  const int f = first.Find({SubmapSource::kFront, s.front_a.submap.id});
  ASSERT_GE(f, 0);
  int moved = 0;
  for (size_t k = 0; k < s.front_a.submap.keyframes.size(); ++k)
    moved += first.submap(f).keyframes[k].T_cw.translation() != s.front_a.submap.keyframes[k].T_cw.translation();
  EXPECT_GT(moved, 0);
}

TEST(SubmapEdit, KeepsOnlyWhatChangedAndRefusesAnotherShape) {
  const auto s = testing::MakeScenario();
  const Submap before = s.front_a.submap;
  Submap after = before;
  after.keyframes[2].T_cw.translation().x() += 0.01;
  after.points[5].position.y() -= 0.02;
  after.points[9].position.z() += 0.03;
  after.frames.back().T_wc.translation().z() += 0.04;
  SubmapEdit edit;
  edit.Begin(before);
  ASSERT_TRUE(edit.Finish(after));
  EXPECT_EQ(edit.keyframe_poses.size(), 1u);
  EXPECT_EQ(edit.point_positions.size(), 2u);
  EXPECT_EQ(edit.frame_poses.size(), 1u);
  Submap replayed = before;
  edit.Apply(&replayed);
  EXPECT_EQ(SubmapFingerprint(replayed), SubmapFingerprint(after));

  Submap fewer = before;
  fewer.points.pop_back();
  edit.Begin(before);
  EXPECT_FALSE(edit.Finish(fewer));
}

TEST(MergeMemo, AChangedBackOrSearchSetRecomputes) {
  const auto s = testing::MakeScenario();
  MergeMemo memo;
  ManagerOptions o;
  GlobalMap first = Inputs(s, s.front_b.submap);
  MergeAll(&first, o, &memo);

  // Another F^search (every back keyframe instead of the first/last 10):
  // the same submaps, but pairing may differ, so nothing is replayed.
  o.search_n = 0;
  GlobalMap other_search = Inputs(s, s.front_b.submap);
  EXPECT_EQ(Merged(MergeAll(&other_search, o, &memo)), 2);
  EXPECT_EQ(memo.hits(), 0);
  o.search_n = ManagerOptions().search_n;

  // A back submap resent with one point moved: both merges computed again.
  GlobalMap changed;
  changed.AddSubmap(s.front_a.submap);
  changed.AddSubmap(s.front_b.submap);
  Submap back = s.back.submap;
  back.points[0].position.x() += 0.01;
  changed.AddSubmap(back);
  EXPECT_EQ(Merged(MergeAll(&changed, o, &memo)), 2);
  EXPECT_EQ(memo.hits(), 0);
  EXPECT_EQ(memo.misses(), 2);
}

TEST(MergeMemo, ReplaysRejectionsWithoutMerging) {
  auto s = testing::MakeScenario();
  // A back submap of another scene: rejected, and rejected again from the memo.
  const auto other = testing::MakeScenario(/*seed=*/9);
  GlobalMap map;
  map.AddSubmap(s.front_a.submap);
  map.AddSubmap(other.back.submap);
  MergeMemo memo;
  EXPECT_EQ(Merged(MergeAll(&map, ManagerOptions(), &memo)), 0);
  EXPECT_EQ(memo.misses(), 1);
  GlobalMap again;
  again.AddSubmap(s.front_a.submap);
  again.AddSubmap(other.back.submap);
  const auto reports = MergeAll(&again, ManagerOptions(), &memo);
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_FALSE(reports[0].merged);
  EXPECT_TRUE(reports[0].replayed);
  EXPECT_FALSE(reports[0].reason.empty());
  EXPECT_FALSE(again.Connected(0, 1));
}

TEST(MergeMemo, ReplaysPlaceMergesOfUnchangedFronts) {
  // Three fronts of one place, no back: only the place merge joins them.
  SyntheticSceneOptions so;
  so.num_points = 1200;
  const SyntheticScene scene = MakeSyntheticScene(so);
  std::vector<Submap> fronts;
  for (int k = 0; k < 3; ++k) {
    SyntheticSubmap f = MakeSyntheticFront(scene, k + 1, 36 * k, 36 * k + 30, RandomSim3(20 + k), 30 + k);
    AttachPointDescriptors(&f, scene.points.size(), 100, 20, 40 + k);
    fronts.push_back(f.submap);
  }
  auto inputs = [&] {
    GlobalMap map;
    for (const Submap& f : fronts) map.AddSubmap(f);
    return map;
  };
  const ManagerOptions o;
  GlobalMap plain = inputs();
  ASSERT_EQ(Merged(PlaceMergeAll(&plain, o)), 2);
  MergeMemo memo;
  GlobalMap first = inputs();
  EXPECT_EQ(Merged(PlaceMergeAll(&first, o, nullptr, &memo)), 2);
  EXPECT_EQ(memo.hits(), 0);
  ExpectSameMap(plain, first);
  GlobalMap second = inputs();
  EXPECT_EQ(Merged(PlaceMergeAll(&second, o, nullptr, &memo)), 2);
  EXPECT_EQ(memo.hits(), 2);
  ExpectSameMap(first, second);

  // The newest front grew: its merge is computed again, the other replayed.
  fronts[2].keyframes.back().T_cw.translation().y() += 0.002;
  GlobalMap plain_grown = inputs();
  PlaceMergeAll(&plain_grown, o);
  GlobalMap third = inputs();
  const int hits_before = memo.hits();
  EXPECT_EQ(Merged(PlaceMergeAll(&third, o, nullptr, &memo)), 2);
  EXPECT_EQ(memo.hits() - hits_before, 1);
  ExpectSameMap(plain_grown, third);
}

}  // namespace
}  // namespace rumi
