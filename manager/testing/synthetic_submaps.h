#pragma once
// Synthetic scenes and submaps for the manager's tests and benchmarks: a
// random 3D scene, a camera trajectory, and front/back submaps cut from it,
// each in its own random Sim(3) frame with keypoint noise. Ground truth
// (scene point per submap point) is kept so tests can check associations.
#include <cstdint>
#include <vector>

#include "common/geometry.h"
#include "common/submap.h"

namespace rumi {

struct SyntheticScene {
  CameraIntrinsics camera;
  std::vector<Eigen::Vector3d> points;  // world frame
  std::vector<Timestamp> timestamps;    // per frame
  std::vector<Se3> T_wc;                // per frame, camera -> world
};

struct SyntheticSceneOptions {
  int num_frames = 111;
  int num_points = 1500;
  uint32_t seed = 1;
  Timestamp first_timestamp = 1600000000000000000LL;
  Timestamp frame_period_ns = 33333333;
};

// Camera moves 0.1 m per frame along +x (with a small wobble) looking at a
// slab of points 4-9 m ahead.
SyntheticScene MakeSyntheticScene(const SyntheticSceneOptions& o);

struct SyntheticSubmapOptions {
  int64_t id = 0;
  SubmapSource source = SubmapSource::kFront;
  int first_frame = 0, last_frame = 0;  // inclusive
  int keyframe_step = 1;                // every k-th frame is a keyframe
  Sim3 S_lw;                            // world -> this submap's frame
  double pixel_noise = 1.0;             // keypoint noise sigma (px)
  double point_noise_m = 0.01;          // 3D point noise sigma (world metres)
  double pose_noise_m = 0.0;            // keyframe/frame centre noise sigma
  double pose_noise_rad = 0.0;          // keyframe/frame rotation noise sigma
  double detect_prob = 0.8;             // per (point, submap) detection
  double clutter_ratio = 0.2;           // extra keypoints without map point
  int max_octave = 0;                   // octaves drawn in [0, max_octave]
  int64_t point_id_offset = 0;          // ids are offset + shuffled index
  bool frame_records = true;            // FrameRecord for every frame
  uint32_t seed = 7;
};

struct SyntheticSubmap {
  Submap submap;
  std::vector<int> scene_point;  // per submap point: index in scene.points
};

SyntheticSubmap MakeSyntheticSubmap(const SyntheticScene& scene, const SyntheticSubmapOptions& o);

// A front submap of frames [first, last] in its own frame S (world ->
// submap): a keyframe every 2 frames, octaves 0-3, the pose noise of a
// tracked map (1 cm, 0.002 rad), point ids offset by 1e6 x (id + 1).
SyntheticSubmap MakeSyntheticFront(const SyntheticScene& scene, int64_t id, int first, int last, const Sim3& S,
                                   uint32_t seed);

// ORB-like point descriptors: scene point i has a random 256-bit descriptor
// drawn from scene_seed, and each submap point gets its scene point's with
// `flips` random bits flipped (another view of the same corner). Submaps
// given the same scene_seed can then be matched by descriptor.
void AttachPointDescriptors(SyntheticSubmap* s, size_t num_scene_points, uint32_t scene_seed, int flips,
                            uint32_t seed);

// The robot's pose source over a submap's frames (Submap::odometry): the
// ground-truth camera poses in an odometry frame of their own (T_ow), the
// displacement from the first scene frame stretched by `bias` and each
// position jittered by noise_m (per axis).
void AttachSyntheticOdometry(const SyntheticScene& scene, const Se3& T_ow, double bias, double noise_m,
                             uint32_t seed, Submap* s);

// A random similarity with scale in [0.3, 3] and a translation of a few units.
Sim3 RandomSim3(uint32_t seed);

}  // namespace rumi
