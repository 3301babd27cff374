#include "manager/place_merge.h"

#include <gtest/gtest.h>

#include <random>
#include <set>

#include "manager/testing/synthetic_submaps.h"

namespace rumi {
namespace {

struct Fixture {
  SyntheticScene scene;
  Sim3 S_aw, S_bw;
  SyntheticSubmap a, b;
};

// Two front submaps of one scene in their own Sim(3) frames; no shared
// timestamp (A: frames 0-40, B: 44-80), but B sees much of what A saw.
Fixture Make(uint32_t seed) {
  Fixture f;
  SyntheticSceneOptions so;
  so.num_points = 1200;
  so.seed = seed;
  f.scene = MakeSyntheticScene(so);
  f.S_aw = RandomSim3(seed * 7 + 1);
  f.S_bw = RandomSim3(seed * 7 + 2);
  f.a = MakeSyntheticFront(f.scene, 1, 0, 40, f.S_aw, seed * 7 + 3);
  f.b = MakeSyntheticFront(f.scene, 2, 44, 80, f.S_bw, seed * 7 + 4);
  AttachPointDescriptors(&f.a, f.scene.points.size(), seed + 100, 20, seed * 7 + 5);
  AttachPointDescriptors(&f.b, f.scene.points.size(), seed + 100, 20, seed * 7 + 6);
  return f;
}

TEST(PlaceMerge, MatchesMapPointsOneToOneByDescriptor) {
  const Fixture f = Make(5);
  const auto m = MatchMapPoints(f.a.submap, f.b.submap, 50, 0.8);
  ASSERT_GT(m.size(), 100u);
  std::unordered_map<int64_t, int> scene_a, scene_b;
  for (size_t i = 0; i < f.a.submap.points.size(); ++i) scene_a[f.a.submap.points[i].id] = f.a.scene_point[i];
  for (size_t i = 0; i < f.b.submap.points.size(); ++i) scene_b[f.b.submap.points[i].id] = f.b.scene_point[i];
  std::set<int64_t> used_b;
  int right = 0;
  for (const PointMatch& p : m) {
    EXPECT_TRUE(used_b.insert(p.back_point_id).second);
    right += scene_a.at(p.front_point_id) == scene_b.at(p.back_point_id);
  }
  EXPECT_EQ(right, int(m.size()));  // random 256-bit descriptors: no confusions
}

TEST(PlaceMerge, JoinsTwoFrontSubmapsOfOnePlace) {
  const Fixture f = Make(5);
  GlobalMap map;
  const int a = map.AddSubmap(f.a.submap);
  const int b = map.AddSubmap(f.b.submap);
  const auto reports = PlaceMergeAll(&map, ManagerOptions());
  ASSERT_EQ(reports.size(), 1u);
  const MergeReport& r = reports[0];
  ASSERT_TRUE(r.merged) << r.reason;
  EXPECT_TRUE(map.Connected(a, b));
  EXPECT_GT(r.inlier_ratio, 0.9);
  EXPECT_LT(r.refine_final_rmse_px, 3.0);
  // A's frame and B's frame, as the map now relates them, against the truth:
  // S_gb^-1 * S_ga must be S_bw * S_aw^-1.
  const Sim3 est = map.ToGlobal(b).Inverse() * map.ToGlobal(a);
  const Sim3 truth = f.S_bw * f.S_aw.Inverse();
  EXPECT_NEAR(est.scale() / truth.scale(), 1.0, 0.01);
  EXPECT_LT(RotationAngle(est.rotation() * truth.rotation().conjugate()), 0.005);
  // A's keyframe centres land on B's frame within ~1 % of the scene (slab 4-9 m).
  for (const Keyframe& kf : f.a.submap.keyframes) {
    const Eigen::Vector3d c = kf.T_wc().translation();
    EXPECT_LT((est * c - truth * c).norm() / truth.scale(), 0.1);
  }
}

// Same descriptors, wrong geometry: B's points are shuffled among its own
// scene points, so every descriptor match is a lie about where the point is.
TEST(PlaceMerge, RejectsMatchesWithoutOneSim3) {
  Fixture f = Make(6);
  std::mt19937 rng(3);
  std::vector<Eigen::Vector3d> pos;
  for (const MapPoint& p : f.b.submap.points) pos.push_back(p.position);
  std::shuffle(pos.begin(), pos.end(), rng);
  for (size_t i = 0; i < pos.size(); ++i) f.b.submap.points[i].position = pos[i];
  GlobalMap map;
  const int a = map.AddSubmap(f.a.submap);
  const int b = map.AddSubmap(f.b.submap);
  const auto reports = PlaceMergeAll(&map, ManagerOptions());
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_FALSE(reports[0].merged);
  EXPECT_GT(reports[0].common_points, 100);  // the descriptors did match
  EXPECT_NE(reports[0].reason.find("inlier"), std::string::npos) << reports[0].reason;
  EXPECT_FALSE(map.Connected(a, b));
  EXPECT_TRUE(map.ToGlobal(a).Matrix().isApprox(Eigen::Matrix4d::Identity()));
}

TEST(PlaceMerge, MemoSkipsPairsRejectedBeforeUntilOneGrows) {
  Fixture f = Make(6);
  AttachPointDescriptors(&f.b, f.scene.points.size(), 999, 20, 1);  // another scene's: B cannot match A
  PlaceMergeMemo memo;
  GlobalMap map;
  map.AddSubmap(f.a.submap);
  map.AddSubmap(f.b.submap);
  ASSERT_EQ(PlaceMergeAll(&map, ManagerOptions(), &memo).size(), 1u);
  EXPECT_EQ(memo.size(), 1u);
  GlobalMap again;  // the next rebuild: same submaps
  again.AddSubmap(f.a.submap);
  again.AddSubmap(f.b.submap);
  EXPECT_TRUE(PlaceMergeAll(&again, ManagerOptions(), &memo).empty());
  // B resent with matching descriptors and one more keyframe: below
  // place_retry_growth, not tried (a resend of a growing front); with
  // growth 0 any change is tried.
  Fixture g = Make(6);
  auto grow = [&](size_t n) {
    for (size_t k = 0; k < n; ++k) {
      g.b.submap.keyframes.push_back(g.b.submap.keyframes.back());
      g.b.submap.keyframes.back().id += 100000;
    }
    GlobalMap m;
    m.AddSubmap(g.a.submap);
    m.AddSubmap(g.b.submap);
    return m;
  };
  const size_t kfs = f.b.submap.keyframes.size();
  ASSERT_GE(kfs, 8u);  // one keyframe is less than a quarter
  GlobalMap one_more = grow(1);
  EXPECT_TRUE(PlaceMergeAll(&one_more, ManagerOptions(), &memo).empty());
  ManagerOptions every_change;
  every_change.place_retry_growth = 0;
  PlaceMergeMemo copy = memo;
  GlobalMap one_more_again = one_more;
  auto reports = PlaceMergeAll(&one_more_again, every_change, &copy);
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_TRUE(reports[0].merged) << reports[0].reason;
  // Grown by a quarter of its keyframes: tried again, merged.
  GlobalMap grown = grow(kfs / 4);
  reports = PlaceMergeAll(&grown, ManagerOptions(), &memo);
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_TRUE(reports[0].merged) << reports[0].reason;
}

TEST(PlaceMerge, OffOrUnrelatedDescriptorsDoNothing) {
  Fixture f = Make(7);
  ManagerOptions off;
  off.place_merge = false;
  GlobalMap map;
  map.AddSubmap(f.a.submap);
  map.AddSubmap(f.b.submap);
  EXPECT_TRUE(PlaceMergeAll(&map, off).empty());
  // Another scene's descriptors on B: nothing to match.
  AttachPointDescriptors(&f.b, f.scene.points.size(), 999, 20, 1);
  GlobalMap map2;
  map2.AddSubmap(f.a.submap);
  map2.AddSubmap(f.b.submap);
  const auto reports = PlaceMergeAll(&map2, ManagerOptions());
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_FALSE(reports[0].merged);
  EXPECT_NE(reports[0].reason.find("too few descriptor matches"), std::string::npos) << reports[0].reason;
}

// Fronts 1 and 2 see one part of the scene, 2 and 3 another, 1 and 3 share
// nothing. Front 3 is resent while it grows: each version is tried against
// front 2, which it joined last time, first; front 1 is then in the same
// component and costs no matching (in index order it was matched first,
// and rejected, at every resend).
TEST(PlaceMerge, AGrowingFrontIsTriedFirstAgainstItsLastPartner) {
  SyntheticSceneOptions so;
  so.num_points = 1500;
  so.seed = 11;
  const SyntheticScene scene = MakeSyntheticScene(so);
  std::vector<SyntheticSubmap> f;
  const int range[3][2] = {{0, 30}, {0, 100}, {70, 100}};
  for (int k = 0; k < 3; ++k) {
    f.push_back(MakeSyntheticFront(scene, k + 1, range[k][0], range[k][1], RandomSim3(50 + k), 60 + k));
    AttachPointDescriptors(&f.back(), scene.points.size(), 100, 20, 70 + k);
  }
  // What fronts 1 and 3 both see looks different in front 1 (descriptor bits
  // inverted): only front 2 matches both.
  const std::set<int> seen_by_3(f[2].scene_point.begin(), f[2].scene_point.end());
  for (size_t i = 0; i < f[0].submap.points.size(); ++i)
    if (seen_by_3.count(f[0].scene_point[i])) cv::bitwise_not(f[0].submap.points[i].descriptor, f[0].submap.points[i].descriptor);
  ASSERT_LT(MatchMapPoints(f[0].submap, f[2].submap, 50, 0.8).size(), 40u) << "fronts 1 and 3 must not match";
  const Submap grown = f[2].submap;
  f[2].submap = SubmapUntil(grown, grown.keyframes[grown.keyframes.size() - 3].timestamp);
  const auto run = [&](PlaceMergeMemo* memo) {
    GlobalMap map;
    for (const SyntheticSubmap& s : f) map.AddSubmap(s.submap);
    const auto reports = PlaceMergeAll(&map, ManagerOptions(), memo);
    EXPECT_EQ(map.ComponentsBySize().size(), 1u);
    std::vector<std::string> pairs;
    for (const MergeReport& r : reports) pairs.push_back(ToString(r.front) + "+" + ToString(r.back));
    return pairs;
  };
  PlaceMergeMemo memo;
  EXPECT_EQ(run(&memo), (std::vector<std::string>{"front#1+front#2", "front#1+front#3", "front#2+front#3"}));
  f[2].submap = grown;  // resent, two keyframes more
  // 1+2 is computed again (this memo keeps rejections), 1+3 is not tried.
  EXPECT_EQ(run(&memo), (std::vector<std::string>{"front#1+front#2", "front#2+front#3"}));
  EXPECT_EQ(run(nullptr), (std::vector<std::string>{"front#1+front#2", "front#1+front#3", "front#2+front#3"}));
}

}  // namespace
}  // namespace rumi
