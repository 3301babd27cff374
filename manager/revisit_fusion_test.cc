#include "manager/revisit_fusion.h"

#include <gtest/gtest.h>

#include <random>
#include <unordered_map>

#include "manager/post_culling.h"
#include "manager/submap_index.h"
#include "manager/testing/synthetic_submaps.h"

namespace rumi {
namespace {

constexpr uint32_t kSceneSeed = 11;

// ORB descriptors on every keypoint of every keyframe: a mapped corner gets
// its scene point's descriptor with 3 bits flipped (another view of the same
// corner), clutter a random one.
void AttachKeyframeDescriptors(SyntheticSubmap* s, size_t num_scene_points, uint32_t seed) {
  std::mt19937 scene_rng(kSceneSeed), rng(seed);
  cv::Mat scene(int(num_scene_points), 32, CV_8U);
  for (int i = 0; i < scene.rows; ++i)
    for (int j = 0; j < 32; ++j) scene.at<uint8_t>(i, j) = uint8_t(scene_rng() & 0xff);
  std::unordered_map<int64_t, int> scene_of;
  for (size_t i = 0; i < s->submap.points.size(); ++i) scene_of[s->submap.points[i].id] = s->scene_point[i];
  for (Keyframe& kf : s->submap.keyframes) {
    kf.descriptors = cv::Mat(int(kf.keypoints.size()), 32, CV_8U);
    for (size_t k = 0; k < kf.keypoints.size(); ++k) {
      cv::Mat row = kf.descriptors.row(int(k));
      if (kf.point_ids[k] >= 0) {
        scene.row(scene_of.at(kf.point_ids[k])).copyTo(row);
        for (int f = 0; f < 3; ++f) {
          const int bit = int(rng() % 256);
          row.at<uint8_t>(0, bit / 8) ^= uint8_t(1 << (bit % 8));
        }
      } else {
        for (int j = 0; j < 32; ++j) row.at<uint8_t>(0, j) = uint8_t(rng() & 0xff);
      }
    }
  }
}

// Two front submaps over the same frames (a second pass over one place), each
// in its own frame, joined in one component with the true Sim(3)s, as a place
// merge would leave them.
struct Revisit {
  SyntheticScene scene;
  SyntheticSubmap a, b;
  GlobalMap map;
  int ia = -1, ib = -1;
};

Revisit MakeRevisit(bool connect, const Eigen::Vector3d& b_error = Eigen::Vector3d::Zero()) {
  Revisit r;
  r.scene = MakeSyntheticScene(SyntheticSceneOptions());
  const Sim3 S_aw = RandomSim3(3), S_bw = RandomSim3(4);
  r.a = MakeSyntheticFront(r.scene, 0, 0, 40, S_aw, 21);
  r.b = MakeSyntheticFront(r.scene, 1, 0, 40, S_bw, 22);
  for (SyntheticSubmap* s : {&r.a, &r.b}) {
    AttachPointDescriptors(s, r.scene.points.size(), kSceneSeed, 3, 5);
    AttachKeyframeDescriptors(s, r.scene.points.size(), 6);
  }
  r.ia = r.map.AddSubmap(r.a.submap);
  r.ib = r.map.AddSubmap(r.b.submap);
  r.map.entry(r.ia).S_gl = S_aw.Inverse();
  r.map.entry(r.ib).S_gl = Sim3(1.0, Eigen::Quaterniond::Identity(), b_error) * S_bw.Inverse();
  if (connect) r.map.Union(r.ia, r.ib);
  return r;
}

int SceneOf(const SyntheticSubmap& s, int64_t point_id) {
  for (size_t i = 0; i < s.submap.points.size(); ++i)
    if (s.submap.points[i].id == point_id) return s.scene_point[i];
  return -1;
}

TEST(RevisitFusion, FusesTheSamePointsOfTwoPassesOverOnePlace) {
  Revisit r = MakeRevisit(true);
  // Scene points both passes mapped.
  std::unordered_map<int, int> in_a;
  for (int p : r.a.scene_point) in_a[p] = 1;
  int common = 0;
  for (int p : r.b.scene_point) common += in_a.count(p);
  ASSERT_GT(common, 200);

  const RevisitFusionReport rep = FuseRevisitPoints(&r.map, ManagerOptions());
  EXPECT_EQ(rep.keyframes_searched, int(r.b.submap.keyframes.size()));  // every later keyframe had neighbours
  EXPECT_GT(rep.fused, common / 2) << "of " << common;
  int right = 0;
  for (const FusedPoint& f : r.map.fused()) {
    ASSERT_EQ(f.dup, r.ib);  // the later submap's point is the duplicate
    ASSERT_EQ(f.kept, r.ia);
    right += SceneOf(r.b, f.dup_point) == SceneOf(r.a, f.kept_point);
  }
  EXPECT_GE(right, int(0.99 * r.map.fused().size()));

  // Once fused, a second run adds nothing.
  EXPECT_EQ(FuseRevisitPoints(&r.map, ManagerOptions()).fused, 0);

  // Only the searched submaps' keyframes are searched: the earlier pass
  // finds nothing (nothing precedes it), the later one all of the above.
  Revisit again = MakeRevisit(true);
  const std::vector<bool> earlier_only{true, false}, later_only{false, true};
  EXPECT_EQ(FuseRevisitPoints(&again.map, ManagerOptions(), &earlier_only).fused, 0);
  EXPECT_EQ(FuseRevisitPoints(&again.map, ManagerOptions(), &later_only).fused, rep.fused);
}

TEST(RevisitFusion, LetsCullingDropTheRepeatedPass) {
  const auto keyframes_after = [](bool fusion) {
    Revisit r = MakeRevisit(true);
    ManagerOptions o;
    o.revisit_fusion = fusion;
    const CullingReport c = CullRedundantKeyframes(&r.map, o);
    EXPECT_EQ(c.revisit_fused > 0, fusion);
    EXPECT_EQ(c.culled_revisit > 0, fusion);  // the later pass's keyframes, by the revisit rule
    return std::make_pair(c.keyframes_before, c.keyframes_after);
  };
  const auto [before, without] = keyframes_after(false);
  const auto [before2, with] = keyframes_after(true);
  ASSERT_EQ(before, before2);
  Revisit one = MakeRevisit(false);
  GlobalMap first_pass;
  first_pass.AddSubmap(one.a.submap);
  const int one_pass = CullRedundantKeyframes(&first_pass, ManagerOptions()).keyframes_after;
  // Two passes over one place keep about one pass's keyframes, not two.
  EXPECT_LE(with, one_pass + 2) << before << " keyframes: " << without << " kept without fusion, " << with
                                << " with, " << one_pass << " of one pass alone";
  EXPECT_GE(without, 2 * one_pass - 2);
}

// Two passes that drifted apart (the second 15 cm off: 8-19 px at this
// scene's depth, beyond the 3 px search) are placed against each other first
// (PnP on a wide search) and then fused as if aligned.
TEST(RevisitFusion, ADriftedPassIsPlacedBeforeItIsFused) {
  const auto fuse = [](double wide_px, int* right) {
    Revisit r = MakeRevisit(true, Eigen::Vector3d(0.15, 0.0, 0.0));
    ManagerOptions o;
    o.revisit_wide_px = wide_px;
    const RevisitFusionReport rep = FuseRevisitPoints(&r.map, o);
    *right = 0;
    for (const FusedPoint& f : r.map.fused()) *right += SceneOf(r.b, f.dup_point) == SceneOf(r.a, f.kept_point);
    EXPECT_EQ(rep.keyframes_corrected > 0, wide_px > 0);
    return rep.fused;
  };
  int right_without = 0, right_with = 0;
  const int without = fuse(0, &right_without);
  const int with = fuse(15, &right_with);
  EXPECT_LT(without, 100);
  EXPECT_GT(with, 400) << without << " fused without the placement";
  std::printf("drifted pass: %d fused without the placement, %d with\n", without, with);
  EXPECT_GE(right_with, int(0.99 * with));
}

// A pass that drifts away from the earlier one as it goes, its keyframes and
// the points they map alike (its last keyframe 3 m off, the scene 4-9 m
// away): each placed keyframe's correction is the next one's guess, so the
// placement follows the drift to the end of the pass, and the depth check
// compares each corner's point with the candidate moved by that correction.
TEST(RevisitFusion, APassThatDriftsAwayIsPlacedAlongItsKeyframes) {
  Revisit r = MakeRevisit(true);
  Submap& b = r.map.submap(r.ib);
  const double n = double(b.keyframes.size() - 1);
  const Sim3 S_bg = r.map.ToGlobal(r.ib).Inverse();
  std::unordered_map<int64_t, Eigen::Vector3d> shift_of;  // keyframe id -> shift in B's frame
  for (size_t k = 0; k < b.keyframes.size(); ++k) {
    // 0 -> 3 m along the global x axis, in B's frame and units.
    const Eigen::Vector3d shift = S_bg.scale() * (S_bg.R() * Eigen::Vector3d(3.0 * double(k) / n, 0, 0));
    shift_of[b.keyframes[k].id] = shift;
    Se3 T_wc = b.keyframes[k].T_wc();
    T_wc = Se3(T_wc.rotation(), T_wc.translation() + shift);
    b.keyframes[k].T_cw = T_wc.Inverse();
  }
  for (MapPoint& p : b.points) p.position += shift_of.at(p.observations.front().keyframe_id);
  const RevisitFusionReport rep = FuseRevisitPoints(&r.map, ManagerOptions());
  EXPECT_GE(rep.keyframes_corrected, int(0.9 * b.keyframes.size())) << "of " << b.keyframes.size();
  int right = 0;
  for (const FusedPoint& f : r.map.fused()) right += SceneOf(r.b, f.dup_point) == SceneOf(r.a, f.kept_point);
  EXPECT_GT(rep.fused, 400);
  EXPECT_GE(right, int(0.99 * rep.fused));
  std::printf("drifting pass: %d of %zu keyframes placed, %d fused (%d right)\n", rep.keyframes_corrected,
              b.keyframes.size(), rep.fused, right);
}

// A placement that moves the camera further from its guess than the depth
// check allows is refused (PnP agreeing on a wrong pose): with the
// tolerance at 0.005 x the depth (2-4.5 cm here), the drifted pass of the
// test above (15 cm off) is not placed.
TEST(RevisitFusion, APlacementFarFromItsGuessIsRefused) {
  for (const double offset : {0.3, 0.005}) {
    Revisit r = MakeRevisit(true, Eigen::Vector3d(0.15, 0.0, 0.0));
    ManagerOptions o;
    o.revisit_max_offset = offset;
    const RevisitFusionReport rep = FuseRevisitPoints(&r.map, o);
    if (offset > 0.1)
      EXPECT_GT(rep.keyframes_corrected, 10);
    else
      EXPECT_EQ(rep.keyframes_corrected, 0);
  }
}

// The memo replays a submap's links while it and the submaps before it are
// unchanged, and searches it again when one changes.
TEST(RevisitFusion, TheMemoReplaysUnchangedSubmaps) {
  RevisitMemo memo;
  Revisit first = MakeRevisit(true);
  const RevisitFusionReport searched = FuseRevisitPoints(&first.map, ManagerOptions(), nullptr, &memo);
  ASSERT_GT(searched.fused, 400);
  EXPECT_EQ(searched.submaps_replayed, 0);

  Revisit second = MakeRevisit(true);
  const RevisitFusionReport replayed = FuseRevisitPoints(&second.map, ManagerOptions(), nullptr, &memo);
  EXPECT_EQ(replayed.submaps_replayed, 2);  // both passes (the first one found nothing before it)
  EXPECT_EQ(replayed.keyframes_searched, 0);
  EXPECT_EQ(replayed.fused, searched.fused);
  ASSERT_EQ(second.map.fused().size(), first.map.fused().size());
  for (size_t i = 0; i < first.map.fused().size(); ++i) {
    EXPECT_EQ(second.map.fused()[i].dup_point, first.map.fused()[i].dup_point);
    EXPECT_EQ(second.map.fused()[i].kept_point, first.map.fused()[i].kept_point);
  }

  // The earlier pass lost a keyframe (culled and baked): searched again.
  Revisit third = MakeRevisit(true);
  third.map.submap(third.ia).keyframes.pop_back();
  const RevisitFusionReport again = FuseRevisitPoints(&third.map, ManagerOptions(), nullptr, &memo);
  EXPECT_EQ(again.submaps_replayed, 0);
  EXPECT_GT(again.keyframes_searched, 0);

  // The new search replaced the old links: the same layout replays its links.
  Revisit fourth = MakeRevisit(true);
  fourth.map.submap(fourth.ia).keyframes.pop_back();
  const RevisitFusionReport replayed_again = FuseRevisitPoints(&fourth.map, ManagerOptions(), nullptr, &memo);
  EXPECT_EQ(replayed_again.submaps_replayed, 2);
  EXPECT_EQ(replayed_again.fused, again.fused);

  // A merge's welding moved a keyframe: searched again.
  Revisit fifth = MakeRevisit(true);
  fifth.map.submap(fifth.ia).keyframes.pop_back();
  Keyframe& moved = fifth.map.submap(fifth.ib).keyframes.front();
  moved.T_cw = Se3(moved.T_cw.rotation(), moved.T_cw.translation() + Eigen::Vector3d(0.001, 0, 0));
  EXPECT_EQ(FuseRevisitPoints(&fifth.map, ManagerOptions(), nullptr, &memo).submaps_replayed, 1);  // the first pass

  // Entries of submaps no longer searched (baked) or gone from the map go.
  memo.Retain(third.map, {true, false});
  ASSERT_EQ(memo.entries().size(), 1u);
  EXPECT_EQ(memo.entries().begin()->first, third.map.Key(third.ia));
  memo.Retain(GlobalMap(), {});
  EXPECT_TRUE(memo.entries().empty());
}

TEST(RevisitFusion, NothingAcrossComponentsOrWhenOffOrMisplaced) {
  {
    Revisit r = MakeRevisit(false);
    EXPECT_EQ(FuseRevisitPoints(&r.map, ManagerOptions()).fused, 0);
  }
  {
    Revisit r = MakeRevisit(true);
    ManagerOptions o;
    o.revisit_fusion = false;
    EXPECT_EQ(FuseRevisitPoints(&r.map, o).fused, 0);
    o.revisit_fusion = true;
    o.front_search_px = 0;
    EXPECT_EQ(FuseRevisitPoints(&r.map, o).fused, 0);
  }
  for (const double off : {0.5, 3.0}) {
    // The second pass placed 0.5 m off (the scene is 4-9 m away): beyond the
    // 15 px search, within the 45 px one that follows it, so it is placed
    // and fused. 3 m off: its corners are nowhere near where the first
    // pass's points project, and nothing is placed.
    Revisit r = MakeRevisit(true, Eigen::Vector3d(off, 0.0, 0.0));
    const RevisitFusionReport rep = FuseRevisitPoints(&r.map, ManagerOptions());
    int right = 0;
    for (const FusedPoint& f : r.map.fused()) right += SceneOf(r.b, f.dup_point) == SceneOf(r.a, f.kept_point);
    EXPECT_EQ(right, rep.fused) << off << " m";  // what is fused is right
    if (off < 1) {
      EXPECT_GT(rep.fused, 400);
    } else {
      EXPECT_EQ(rep.keyframes_corrected, 0);
      EXPECT_LT(rep.fused, 20);
    }
  }
}

}  // namespace
}  // namespace rumi
