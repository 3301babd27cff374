#include "manager/front_point_search.h"

#include <gtest/gtest.h>

#include <random>

#include "common/orb_extractor.h"
#include "manager/post_culling.h"
#include "manager/testing/synthetic_submaps.h"

namespace rumi {
namespace {

// A front submap of `num_front_kfs` keyframes (0.1 m apart along x, looking
// along +z) that all observe `num_points` points 4-6 m ahead at octave 0,
// each point with a random ORB descriptor; and a back submap in another
// Sim(3) frame whose keyframes stand where the front ones do, holding
// `sift_points` points of their own (seen by every back keyframe) plus ORB
// keypoints where the front points project, with the point's descriptor
// after `flipped_bits` bit flips, at octave `orb_octave`.
struct Scene {
  GlobalMap map;
  int front = -1, back = -1;
  std::vector<int64_t> front_point_ids;
};

struct SceneOptions {
  int num_front_kfs = 3, num_back_kfs = 2, num_points = 120, sift_points = 10;
  int flipped_bits = 4;
  uint8_t orb_octave = 0;
  double keypoint_offset_px = 0.7;
  bool connect = true;
};

Scene MakeScene(const SceneOptions& o) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> byte(0, 255);
  Scene sc;
  CameraIntrinsics K;
  K.width = 640, K.height = 480, K.fx = K.fy = 500, K.cx = 319.5, K.cy = 239.5;
  auto project = [&](const Se3& T_cw, const Eigen::Vector3d& X) {
    const Eigen::Vector3d c = T_cw * X;
    return Eigen::Vector2f(float(K.fx * c.x() / c.z() + K.cx), float(K.fy * c.y() / c.z() + K.cy));
  };
  Submap F;
  F.id = 0;
  F.source = SubmapSource::kFront;
  F.camera = K;
  for (int k = 0; k < o.num_front_kfs; ++k) {
    Keyframe kf;
    kf.id = k;
    kf.timestamp = 1000000000LL * (k + 1);
    kf.T_cw = Se3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.1 * k, 0, 0));
    kf.descriptors = cv::Mat(0, 32, CV_8U);
    F.keyframes.push_back(kf);
  }
  for (int i = 0; i < o.num_points; ++i) {
    MapPoint p;
    p.id = 100 + i;
    p.position = Eigen::Vector3d(1.5 * u(rng), 1.0 * u(rng), 5.0 + u(rng));
    p.descriptor = cv::Mat(1, 32, CV_8U);
    for (int b = 0; b < 32; ++b) p.descriptor.at<uint8_t>(0, b) = uint8_t(byte(rng));
    for (Keyframe& kf : F.keyframes) {
      p.observations.push_back({kf.id, int32_t(kf.keypoints.size())});
      kf.keypoints.push_back(project(kf.T_cw, p.position));
      kf.octaves.push_back(0);
      kf.point_ids.push_back(p.id);
      cv::vconcat(kf.descriptors, p.descriptor, kf.descriptors);
    }
    sc.front_point_ids.push_back(p.id);
    F.points.push_back(p);
  }
  // The back frame: x_b = S_bf * x_f.
  const Sim3 S_bf = RandomSim3(11);
  Submap B;
  B.id = 0;
  B.source = SubmapSource::kBack;
  B.camera = K;
  for (int k = 0; k < o.num_back_kfs; ++k) {
    Keyframe kf;
    kf.id = k;
    kf.timestamp = 1000000000LL * (k + 1) + 500000000LL;
    const Se3 T_wc_f = Se3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1 * k + 0.05, 0, 0));
    kf.T_cw = S_bf.TransformPose(T_wc_f).Inverse();
    B.keyframes.push_back(kf);
  }
  // Own (SIFT) points: no descriptor rows of their own.
  for (int i = 0; i < o.sift_points; ++i) {
    MapPoint p;
    p.id = i;
    p.position = S_bf * Eigen::Vector3d(1.5 * u(rng), 1.0 * u(rng), 5.0 + u(rng));
    for (Keyframe& kf : B.keyframes) {
      p.observations.push_back({kf.id, int32_t(kf.keypoints.size())});
      kf.keypoints.push_back(project(kf.T_cw, p.position));
      kf.octaves.push_back(0);
      kf.point_ids.push_back(p.id);
    }
    B.points.push_back(p);
  }
  for (Keyframe& kf : B.keyframes) {
    kf.descriptors = cv::Mat::zeros(int(kf.keypoints.size()), 32, CV_8U);
    for (const MapPoint& p : F.points) {
      cv::Mat d = p.descriptor.clone();
      for (int b = 0; b < o.flipped_bits; ++b) {  // distinct bits: 97 is odd
        const int bit = (b * 97) % 256;
        d.at<uint8_t>(0, bit / 8) ^= uint8_t(1 << (bit % 8));
      }
      Eigen::Vector2f px = project(kf.T_cw, S_bf * p.position);
      px.x() += float(o.keypoint_offset_px);
      kf.keypoints.push_back(px);
      kf.octaves.push_back(o.orb_octave);
      kf.point_ids.push_back(-1);
      cv::vconcat(kf.descriptors, d, kf.descriptors);
    }
  }
  sc.front = sc.map.AddSubmap(F);
  sc.back = sc.map.AddSubmap(B);
  // Global frame = front frame.
  sc.map.entry(sc.back).S_gl = S_bf.Inverse();
  if (o.connect) sc.map.Union(sc.front, sc.back);
  return sc;
}

TEST(FrontPointSearch, FindsProjectedPointsByDescriptor) {
  SceneOptions so;
  Scene sc = MakeScene(so);
  const auto found = SearchFrontPoints(sc.map, ManagerOptions());
  ASSERT_EQ(found.size(), size_t(so.num_back_kfs * so.num_points));
  for (const CrossObservation& x : found) {
    EXPECT_EQ(x.back, sc.back);
    EXPECT_EQ(x.front, sc.front);
    // ORB keypoints follow the SIFT ones, in front point order.
    EXPECT_EQ(x.point_id, sc.front_point_ids[x.keypoint - so.sift_points]);
    EXPECT_EQ(x.octave, 0);
  }
}

TEST(FrontPointSearch, RejectsFarDescriptorsWrongLevelsAndUnmergedSubmaps) {
  SceneOptions far;
  far.flipped_bits = 60;  // > 50 bits apart
  EXPECT_TRUE(SearchFrontPoints(MakeScene(far).map, ManagerOptions()).empty());
  SceneOptions coarse;
  coarse.orb_octave = 3;  // predicted level 0 from the same distance
  EXPECT_TRUE(SearchFrontPoints(MakeScene(coarse).map, ManagerOptions()).empty());
  SceneOptions off;
  off.keypoint_offset_px = 4.0;  // outside 3 px
  EXPECT_TRUE(SearchFrontPoints(MakeScene(off).map, ManagerOptions()).empty());
  SceneOptions apart;
  apart.connect = false;  // not merged: no common frame
  EXPECT_TRUE(SearchFrontPoints(MakeScene(apart).map, ManagerOptions()).empty());
  ManagerOptions disabled;
  disabled.front_search_px = 0;
  EXPECT_TRUE(SearchFrontPoints(MakeScene(SceneOptions()).map, disabled).empty());
}

TEST(FrontPointSearch, KeyframesWithoutOctavesOrDescriptorsAreSafe) {
  // Both are optional in a valid submap: no octaves means level 0; descriptor
  // rows that do not describe every keypoint mean no ORB keypoints.
  Scene sc = MakeScene(SceneOptions());
  for (Keyframe& kf : sc.map.submap(sc.back).keyframes) kf.octaves.clear();
  for (Keyframe& kf : sc.map.submap(sc.front).keyframes) kf.octaves.clear();
  EXPECT_EQ(SearchFrontPoints(sc.map, ManagerOptions()).size(), 240u);
  for (Keyframe& kf : sc.map.submap(sc.back).keyframes) kf.descriptors = cv::Mat();
  EXPECT_TRUE(SearchFrontPoints(sc.map, ManagerOptions()).empty());
}

TEST(FrontPointSearch, MakesBackKeyframesThatRepeatTheFrontRedundant) {
  // Each back keyframe: 10 own points seen by the 2 back keyframes only, and
  // 120 front points seen by 3 front keyframes: 120/130 >= 90 % redundant once
  // the front points are found in it, 0 % otherwise.
  ManagerOptions with, without;
  without.front_search_px = 0;
  Scene a = MakeScene(SceneOptions());
  const CullingReport r = CullRedundantKeyframes(&a.map, with);
  EXPECT_EQ(r.front_points_found, 240);
  EXPECT_EQ(r.culled_back, 1);  // the second then keeps its own points alive
  EXPECT_EQ(a.map.submap(a.back).keyframes.size(), 1u);
  Scene b = MakeScene(SceneOptions());
  const CullingReport r0 = CullRedundantKeyframes(&b.map, without);
  EXPECT_EQ(r0.front_points_found, 0);
  EXPECT_EQ(r0.culled_back, 0);
}

}  // namespace
}  // namespace rumi
