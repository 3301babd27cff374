#include "manager/revisit_fusion.h"

#include <gtest/gtest.h>

#include <random>
#include <unordered_map>

#include "manager/post_culling.h"
#include "manager/submap_index.h"
#include "manager/synthetic_submaps.h"

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
  {
    // The second pass placed 0.5 m off (the scene is 4-9 m away): its
    // corners are not where the first pass's points project.
    Revisit r = MakeRevisit(true, Eigen::Vector3d(0.5, 0.0, 0.0));
    const int fused = FuseRevisitPoints(&r.map, ManagerOptions()).fused;
    int right = 0;
    for (const FusedPoint& f : r.map.fused()) right += SceneOf(r.b, f.dup_point) == SceneOf(r.a, f.kept_point);
    EXPECT_EQ(right, fused);  // what little is fused is still right
    EXPECT_LT(fused, 20);
  }
}

}  // namespace
}  // namespace rumi
