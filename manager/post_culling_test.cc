#include "manager/post_culling.h"

#include <gtest/gtest.h>

#include "manager/global_trajectory.h"
#include "manager/merge.h"
#include "manager/submap_index.h"
#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {

// Keyframe k observes points [first, first + n) at the given octave.
void Observe(Submap* s, int k, int64_t first, int n, uint8_t octave) {
  Keyframe& kf = s->keyframes[k];
  for (int64_t p = first; p < first + n; ++p) {
    auto it = std::find_if(s->points.begin(), s->points.end(), [&](const MapPoint& m) { return m.id == p; });
    if (it == s->points.end()) {
      s->points.emplace_back();
      it = s->points.end() - 1;
      it->id = p;
    }
    it->observations.push_back({kf.id, int32_t(kf.keypoints.size())});
    kf.keypoints.emplace_back(float(p % 600), float(p % 400));
    kf.octaves.push_back(octave);
    kf.point_ids.push_back(p);
  }
}

Submap Keyframes(SubmapSource src, int n) {
  Submap s;
  s.source = src;
  s.id = 5;
  for (int i = 0; i < n; ++i) {
    Keyframe kf;
    kf.id = i;
    kf.timestamp = 1000000000LL * (i + 1);
    s.keyframes.push_back(kf);
  }
  return s;
}

TEST(PostCulling, DuplicatesGoUniqueStay) {
  Submap s = Keyframes(SubmapSource::kBack, 7);
  for (int k = 0; k < 5; ++k) Observe(&s, k, 0, 100, 0);  // five duplicates
  Observe(&s, 5, 1000, 100, 0);                            // unique view ...
  Observe(&s, 6, 1000, 100, 0);                            // ... seen twice
  GlobalMap map;
  map.AddSubmap(s);
  const auto r = CullRedundantKeyframes(&map, ManagerOptions());
  // kf 0 and 1 have >= 3 other observers; then only 2 are left for 2, 3, 4.
  EXPECT_EQ(r.keyframes_before, 7);
  EXPECT_EQ(r.keyframes_after, 5);
  EXPECT_EQ(r.culled_back, 2);
  const Submap& m = map.submap(0);
  std::vector<int64_t> ids;
  for (const auto& kf : m.keyframes) ids.push_back(kf.id);
  EXPECT_EQ(ids, (std::vector<int64_t>{2, 3, 4, 5, 6}));
  // Culled poses stay as frame records; observations of culled keyframes go.
  EXPECT_EQ(m.frames.size(), 2u);
  for (const auto& p : m.points)
    for (const auto& o : p.observations) EXPECT_GE(o.keyframe_id, 2);
  EXPECT_EQ(r.points_after, 200);
}

TEST(PostCulling, PointsOnlyCulledKeyframesSupportedAreRemoved) {
  Submap s = Keyframes(SubmapSource::kBack, 5);
  for (int k = 0; k < 5; ++k) Observe(&s, k, 0, 100, 0);
  Observe(&s, 0, 500, 5, 0);  // 5 % private points: kf 0 is still >= 90 % redundant
  GlobalMap map;
  map.AddSubmap(s);
  const auto r = CullRedundantKeyframes(&map, ManagerOptions());
  EXPECT_EQ(r.culled_back, 2);  // 0 and 1
  EXPECT_EQ(r.points_before, 105);
  EXPECT_EQ(r.points_after, 100);
}

// Keyframe ids left after culling five keyframes that see the same 50 points:
// kf 0 at octave 0, kf 1-3 at octave 1, kf 4 at octave 2.
std::vector<int64_t> OctaveScenario(int tolerance) {
  Submap s = Keyframes(SubmapSource::kBack, 5);
  Observe(&s, 0, 0, 50, 0);
  for (int k = 1; k < 4; ++k) Observe(&s, k, 0, 50, 1);
  Observe(&s, 4, 0, 50, 2);
  GlobalMap map;
  map.AddSubmap(s);
  ManagerOptions o;
  o.culling_octave_tolerance = tolerance;
  CullRedundantKeyframes(&map, o);
  std::vector<int64_t> ids;
  for (const auto& kf : map.submap(0).keyframes) ids.push_back(kf.id);
  return ids;
}

TEST(PostCulling, OctaveRule) {
  // Strict: 0 kept (finer than all); 1 culled (0, 2, 3 at <= 1); then 2, 3
  // lack a third observer at <= 1; 4 sees 0, 2, 3 at <= 2: culled.
  EXPECT_EQ(OctaveScenario(0), (std::vector<int64_t>{0, 2, 3}));
  // One level of tolerance (ORB-SLAM's code, the default): 0 sees 1, 2, 3 at
  // <= 1: culled; 1 sees 2, 3, 4 at <= 2: culled; 2, 3 and 4 are left with
  // two others each.
  EXPECT_EQ(ManagerOptions().culling_octave_tolerance, 1);
  EXPECT_EQ(OctaveScenario(1), (std::vector<int64_t>{2, 3, 4}));
}

TEST(PostCulling, MergedScenarioCullsBackFirstAndKeepsTrajectory) {
  const auto s = testing::MakeScenario();
  GlobalMap map;
  const int a = map.AddSubmap(s.front_a.submap);
  map.AddSubmap(s.front_b.submap);
  const int k = map.AddSubmap(s.back.submap);
  MergeAll(&map, ManagerOptions());
  const size_t back_before = map.submap(k).keyframes.size();
  size_t front_before = 0;
  for (size_t i = 0; i < map.size(); ++i)
    if (int(i) != k) front_before += map.submap(int(i)).keyframes.size();
  const auto traj_before = ComputeGlobalTrajectory(map);
  const auto r = CullRedundantKeyframes(&map, ManagerOptions());
  EXPECT_GT(r.culled_back, int(back_before) / 2);  // dense back keyframes are duplicates
  EXPECT_LT(r.keyframes_after, r.keyframes_before);
  EXPECT_LT(r.culled_front, r.culled_back);
  // Back first: a larger share of the back goes than of the fronts.
  EXPECT_GT(double(r.culled_back) / back_before, double(r.culled_front) / front_before);
  EXPECT_GE(map.submap(a).keyframes.size(), 1u);
  // Every remaining keyframe observation points to an existing point.
  for (size_t i = 0; i < map.size(); ++i) {
    const SubmapIndex idx(map.submap(int(i)));
    for (const auto& kf : map.submap(int(i)).keyframes)
      for (int64_t pid : kf.point_ids)
        if (pid >= 0) {
          EXPECT_GE(idx.Point(pid), 0);
        }
  }
  // Culled keyframes keep their poses: the trajectory is unchanged.
  const auto traj_after = ComputeGlobalTrajectory(map);
  ASSERT_EQ(traj_after.size(), traj_before.size());
  for (size_t i = 0; i < traj_after.size(); ++i) {
    EXPECT_EQ(traj_after[i].timestamp, traj_before[i].timestamp);
    EXPECT_LT((traj_after[i].T_wc.translation() - traj_before[i].T_wc.translation()).norm(), 1e-9);
  }
}

// A second pass over a room whose keyframes the loop search verified against
// the first pass (loop_closure.h): a keyframe whose verified inliers are at
// least culling_revisit_ratio of its points goes, without fused points (its
// pose need not be placed first); fewer inliers, a match where the earlier
// pass has no keyframe left, in a later pass or in another component keep it.
TEST(PostCulling, ARevisitTheLoopSearchVerifiedIsCulled) {
  const auto pass = [](int64_t id, double t0, int64_t first_point) {
    Submap s = Keyframes(SubmapSource::kFront, 6);
    s.id = id;
    for (int k = 0; k < 6; ++k) {
      s.keyframes[size_t(k)].id = k;
      s.keyframes[size_t(k)].timestamp = int64_t((t0 + k) * 1e9);
      Observe(&s, k, first_point + 100 * k, 100, 0);  // no point seen twice: the ORB rule keeps all
    }
    return s;
  };
  // reversed: the map lists the passes newest first (as a loaded map lists
  // its raw submaps before the baked ones): "earlier" is time, not the order.
  const auto run = [&](bool connected, const ManagerOptions& o, bool reversed = false) {
    GlobalMap map;
    const std::vector<int64_t> order = reversed ? std::vector<int64_t>{3, 2, 1} : std::vector<int64_t>{1, 2, 3};
    for (int64_t id : order) map.AddSubmap(pass(id, 100.0 * double(id), 10000 * (id - 1)));
    const auto at = [&](int64_t id) { return map.Find({SubmapSource::kFront, id}); };
    map.Union(at(1), at(2));
    if (connected) map.Union(at(1), at(3));
    const auto detection = [&](int64_t q_submap, int64_t q_kf, int64_t m_submap, int64_t m_kf, int inliers) {
      LoopDetection d;
      d.query_submap = {SubmapSource::kFront, q_submap};
      d.match_submap = {SubmapSource::kFront, m_submap};
      d.query_keyframe = q_kf;
      d.match_keyframe = m_kf;
      d.query_time = int64_t((q_submap * 100 + q_kf) * 1e9);
      d.match_time = int64_t((m_submap * 100 + m_kf) * 1e9);
      d.inliers = inliers;
      map.loops().searched[{d.query_submap, q_kf}].push_back(d);
    };
    detection(2, 0, 1, 0, 30);   // 30 of its 100 points: a revisit (culling_loop_ratio 0.15)
    detection(2, 1, 1, 1, 10);   // 10: not enough
    detection(2, 2, 1, 2, 100);  // a revisit
    detection(2, 5, 1, 50, 100);  // matched at 150 s, where the first pass has no keyframe left: kept
    detection(1, 3, 2, 3, 100);  // the first pass matched in the later one: kept
    detection(3, 4, 1, 4, 90);   // the third pass: a revisit if it is in the same component
    const CullingReport r = CullRedundantKeyframes(&map, o);
    std::vector<std::vector<int64_t>> ids(3);  // by pass
    for (int64_t id = 1; id <= 3; ++id)
      for (const Keyframe& kf : map.submap(at(id)).keyframes) ids[size_t(id - 1)].push_back(kf.id);
    return std::pair(r, ids);
  };
  const ManagerOptions o;
  auto [r, ids] = run(true, o);
  EXPECT_EQ(r.culled_revisit_detected, 3);
  EXPECT_EQ(ids[0], (std::vector<int64_t>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(ids[1], (std::vector<int64_t>{1, 3, 4, 5}));
  EXPECT_EQ(ids[2], (std::vector<int64_t>{0, 1, 2, 3, 5}));
  const auto [r_reversed, ids_reversed] = run(true, o, /*reversed=*/true);
  EXPECT_EQ(r_reversed.culled_revisit_detected, 3);
  EXPECT_EQ(ids_reversed, ids);
  std::tie(r, ids) = run(false, o);
  EXPECT_EQ(r.culled_revisit_detected, 2);
  EXPECT_EQ(ids[2].size(), 6u);
  ManagerOptions off = o;
  off.culling_loop_ratio = 0;
  std::tie(r, ids) = run(true, off);
  EXPECT_EQ(r.culled_revisit_detected, 0);
  EXPECT_EQ(ids[1].size(), 6u);
}

}  // namespace
}  // namespace rumi
