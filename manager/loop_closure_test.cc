#include "manager/loop_closure.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>
#include <map>
#include <random>
#include <string>

#include "common/geometry.h"
#include "manager/global_map.h"
#include "manager/testing/synthetic_walk.h"

namespace rumi {
namespace {

// Each test below under each rule the graph can decide loops by
// (ManagerOptions::loop_consistency), the chi2 one also with sigmas 5x wider.
struct Rule {
  std::string consistency;
  double variance_factor;
};

ManagerOptions WithRule(const Rule& r) {
  ManagerOptions mo;
  mo.loop_consistency = r.consistency;
  mo.loop_variance_factor = r.variance_factor;
  return mo;
}

class LoopClosureRule : public ::testing::TestWithParam<Rule> {};

INSTANTIATE_TEST_SUITE_P(Rules, LoopClosureRule,
                         ::testing::Values(Rule{"edges", 1.0}, Rule{"chi2", 1.0}, Rule{"chi2", 25.0}),
                         [](const ::testing::TestParamInfo<Rule>& i) {
                           return i.param.consistency + "_" + std::to_string(int(i.param.variance_factor));
                         });

TEST_P(LoopClosureRule, ARoomWalkedAgainIsClosedAndTheDriftCorrected) {
  const WalkOptions o;
  const Walk w = MakeRoomWalk(o);
  GlobalMap map;
  map.AddSubmap(w.submap);
  const double before = KeyframeAte(w, map);
  const ManagerOptions mo = WithRule(GetParam());
  LoopClosureState state;
  const LoopClosureReport r = CloseLoops(&map, mo, &state);
  const double after = KeyframeAte(w, map);
  for (const LoopReport& l : r.loops)
    std::cout << "loop kf " << l.edge.query_keyframe << " -> " << l.edge.match_keyframe << " support " << l.support
              << " inliers " << l.edge.inliers << " closed " << l.closed << " shift " << l.shift << " (" << l.reason
              << ")\n";
  std::cout << "keyframe ATE " << before << " -> " << after << " m\n";
  EXPECT_EQ(r.keyframes_queried, o.keyframes);
  EXPECT_GE(r.detections, 10);
  ASSERT_GE(r.closed, 1);
  EXPECT_GT(r.keyframes_moved, 0);
  for (const LoopReport& l : r.loops) {
    // Every loop joins the second lap to the first, about a lap apart.
    EXPECT_NEAR(NsToSeconds(l.edge.query_time - l.edge.match_time), 24.0, 1.5);
  }
  // 1.5 laps of drift (0.3 m, 13 deg, 12 % scale at the end) is mostly taken out.
  EXPECT_GT(before, 0.1);
  EXPECT_LT(after, 0.5 * before) << before << " -> " << after;
  // The points moved with their keyframes: a second-lap point and its
  // first-lap twin (the same scene point) are closer now.
  std::vector<double> twins_before, twins_after;
  for (const auto& [key, id] : w.point_of) {
    if (key.second != 1) continue;
    const auto first = w.point_of.find({key.first, 0});
    if (first == w.point_of.end()) continue;
    twins_before.push_back((w.submap.points[size_t(id)].position - w.submap.points[size_t(first->second)].position).norm());
    twins_after.push_back(
        (map.submap(0).points[size_t(id)].position - map.submap(0).points[size_t(first->second)].position).norm());
  }
  ASSERT_GT(twins_before.size(), 100u);
  std::sort(twins_before.begin(), twins_before.end());
  std::sort(twins_after.begin(), twins_after.end());
  EXPECT_LT(twins_after[twins_after.size() / 2], 0.5 * twins_before[twins_before.size() / 2]);
  // And the tracked frames with theirs.
  for (size_t k = 0; k < w.submap.frames.size(); ++k) {
    const Se3 f = map.submap(0).frames[k].T_wc, kf = map.submap(0).keyframes[k].T_wc();
    EXPECT_LT((f.translation() - kf.translation()).norm(), 1e-9);
  }
  // A second pass over the same map finds the same and moves nothing more
  // than millimetres (of a 0.45 m correction): the loops go back in, solved
  // together instead of one by one.
  const Submap corrected = map.submap(0);
  const std::vector<bool> fresh(1, false);  // as the manager's base is
  const LoopClosureReport again = CloseLoops(&map, mo, &state, &fresh);
  EXPECT_EQ(again.keyframes_queried, 0);  // searched once
  for (size_t k = 0; k < corrected.keyframes.size(); ++k)
    EXPECT_LT((map.submap(0).keyframes[k].T_wc().translation() - corrected.keyframes[k].T_wc().translation()).norm(),
              5e-3);
}

TEST(LoopClosure, OffDoesNothing) {
  const WalkOptions o;
  const Walk w = MakeRoomWalk(o);
  GlobalMap map;
  map.AddSubmap(w.submap);
  ManagerOptions mo;
  mo.loop_closure = false;
  LoopClosureState state;
  const LoopClosureReport r = CloseLoops(&map, mo, &state);
  EXPECT_EQ(r.keyframes_queried, 0);
  EXPECT_EQ(state.index.size(), 0u);
  EXPECT_EQ(map.submap(0).keyframes[100].T_cw.translation(), w.submap.keyframes[100].T_cw.translation());
}

// loop_skip_first_keyframes: a loop at one of a front's first keyframes is
// reported, not closed; past them the room's loops close as before.
TEST(LoopClosure, NoNewLoopAtAFrontsFirstKeyframes) {
  const WalkOptions o;
  const Walk w = MakeRoomWalk(o);
  for (int skip : {o.keyframes, 10}) {
    GlobalMap map;
    map.AddSubmap(w.submap);
    ManagerOptions mo;
    mo.loop_skip_first_keyframes = skip;
    LoopClosureState state;
    const LoopClosureReport r = CloseLoops(&map, mo, &state);
    ASSERT_FALSE(r.loops.empty());
    if (skip == o.keyframes) {
      EXPECT_EQ(r.closed, 0);
      EXPECT_EQ(r.keyframes_moved, 0);
      for (const LoopReport& l : r.loops)
        EXPECT_NE(l.reason.find("first " + std::to_string(skip) + " keyframes"), std::string::npos) << l.reason;
    } else {
      // The room's loops join the second lap to the first, far past its
      // first 10 keyframes.
      EXPECT_GE(r.closed, 1);
    }
  }
}

TEST_P(LoopClosureRule, TwoIdenticalPostersInDifferentRoomsCloseNoLoop) {
  // A corridor walked once, 0.4 m/s along x, past two identical posters
  // (the same points, the same descriptors) 8 m apart: the second looks
  // exactly like the first, a perfect false loop for appearance and for
  // the RANSAC alike. The graph must refuse it.
  std::mt19937 rng(9);
  std::vector<Eigen::Vector3d> scene;
  std::vector<std::vector<uint8_t>> desc = SceneDescriptors(2400, &rng);
  std::uniform_real_distribution<double> x(-2, 22), y(-1.2, 1.2), zwall(2.8, 3.2);
  for (int i = 0; i < 2000; ++i) scene.emplace_back(x(rng), y(rng), zwall(rng));
  // Poster: 200 points on a 1.5 m patch at x in [4, 5.5], copied at x + 8.
  std::uniform_real_distribution<double> px(4, 5.5), py(-0.7, 0.7);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(px(rng), py(rng), 2.9);
    scene.push_back(p);
    scene.push_back(p + Eigen::Vector3d(8, 0, 0));
    desc[2000 + size_t(2 * i) + 1] = desc[2000 + size_t(2 * i)];
  }
  WalkOptions o;
  o.keyframes = 180;  // 45 s: 18 m
  o.pose = [](double t) { return Se3(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.4 * t, 0, 0)); };
  o.yaw_per_kf = 0.0005;
  Walk w = MakeWalk(scene, desc, o);
  // The walk passes each poster in ~4 s: far less than the 10 s gap, so a
  // detection can only be the twin.
  // As the manager runs (3 agreeing keyframes), and with a single
  // detection enough: either way the graph refuses the loop.
  for (int consistent : {3, 1}) {
    GlobalMap map;
    map.AddSubmap(w.submap);
    ManagerOptions mo = WithRule(GetParam());
    mo.loop_min_consistent = consistent;
    LoopClosureState state;
    const LoopClosureReport r = CloseLoops(&map, mo, &state);
    EXPECT_EQ(r.closed, 0);
    for (const LoopReport& l : r.loops) EXPECT_FALSE(l.closed) << l.reason;
    if (consistent == 1) {
      EXPECT_GE(r.loops.size(), 1u);  // the twin poster was found, and refused
    }
    EXPECT_EQ(r.keyframes_moved, 0);
    for (size_t k = 0; k < w.submap.keyframes.size(); ++k)
      EXPECT_EQ(map.submap(0).keyframes[k].T_cw.translation(), w.submap.keyframes[k].T_cw.translation());
    std::cout << "poster corridor, " << consistent << " agreeing: " << r.detections << " detections, "
              << r.loops.size() << " loop(s) refused";
    if (!r.loops.empty()) std::cout << " (" << r.loops.front().reason << ")";
    std::cout << "\n";
  }
}

}  // namespace
}  // namespace rumi
