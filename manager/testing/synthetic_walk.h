#pragma once
// A walk and what a drifting monocular front makes of it, for loop-closure
// tests and benchmarks: one front submap with a keyframe every 0.25 s, each
// seeing the scene points in its view (ORB-like descriptors, a few bits off
// per view); a point is mapped when first seen, from the drifted pose of the
// keyframe that first sees it, and mapped again (a new id) when it comes
// back into view after `forget_s` out of it (the front's local map has
// forgotten it). The drift accumulates per keyframe: what a loop corrects.
#include <cstdint>
#include <functional>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include "common/geometry.h"
#include "common/submap.h"

namespace rumi {

struct Walk {
  std::vector<Eigen::Vector3d> scene;
  std::vector<std::vector<uint8_t>> descriptor;  // per scene point, 32 bytes
  std::vector<Se3> T_wc_true;
  std::vector<Sim3> drift;  // per keyframe: true world -> the submap's frame
  std::map<std::pair<int, int>, int64_t> point_of;  // (scene point, visit) -> point id (= index)
  Submap submap;
};

struct WalkOptions {
  int keyframes = 150;
  double forget_s = 5.0;
  // Camera path: t in seconds -> pose (camera -> world).
  std::function<Se3(double)> pose;
  // Per keyframe drift: rotation about z (rad), translation (m along x), scale.
  double yaw_per_kf = 0.002, shift_per_kf = 0.003, scale_per_kf = 0.001;
  uint32_t seed = 1;
};

// Scene points' descriptors, drawn around 400 shared prototypes (real
// corners look alike from place to place).
std::vector<std::vector<uint8_t>> SceneDescriptors(size_t n, std::mt19937* rng);

Walk MakeWalk(const std::vector<Eigen::Vector3d>& scene, std::vector<std::vector<uint8_t>> descriptors,
              const WalkOptions& o);

// A room: 3,000 points on a cylinder's wall (radius 3.6-4.4 m); RoomPose
// walks a 1 m circle inside it looking out, a lap in 24 s.
std::vector<Eigen::Vector3d> Room(std::mt19937* rng);
Se3 RoomPose(double t);
// The room walked with `o` (its path RoomPose unless it has one), scene and
// descriptors drawn from `seed`.
Walk MakeRoomWalk(WalkOptions o = {}, uint32_t seed = 5);

// Keyframe centres of submap 0 of `map` against the walk's truth after a
// Sim(3) fit (the keyframe ATE).
class GlobalMap;
double KeyframeAte(const Walk& w, const GlobalMap& map);

}  // namespace rumi
