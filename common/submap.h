#pragma once
// The submap: the unit that front, back and manager exchange (over shared
// memory and in the map file). Each submap has its own world frame and, being
// monocular, its own scale; the manager stores its Sim(3) into the global frame.
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/timestamp.h"

namespace rumi {

enum class SubmapSource : uint8_t { kFront = 0, kBack = 1, kMerged = 2 };

enum class TrackingState : uint8_t {
  kInitializing = 0,  // no map yet (or re-initialising after a loss)
  kTracking = 1,
  kLost = 2,
  kCoarse = 3,  // hierarchical mode: vision suspended, pose from odometry
};
const char* ToString(TrackingState s);

struct Keyframe {
  int64_t id = -1;          // unique within its submap
  Timestamp timestamp = 0;  // capture time (frame identity across processes)
  Se3 T_cw;                 // world (submap frame) -> camera
  // Keypoints in UNDISTORTED pixel coordinates of the submap camera's K, so
  // that front (ORB) and back (COLMAP on undistorted images) agree.
  std::vector<Eigen::Vector2f> keypoints;
  std::vector<uint8_t> octaves;     // pyramid level per keypoint (0 for back)
  cv::Mat descriptors;              // one row per keypoint (ORB: 32 x CV_8U); may be empty
  std::vector<int64_t> point_ids;   // map point per keypoint, -1 for none
  Se3 T_wc() const { return T_cw.Inverse(); }
};

struct MapPoint {
  int64_t id = -1;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // submap frame
  cv::Mat descriptor;  // representative descriptor (1 row), may be empty
  struct Observation {
    int64_t keyframe_id;
    int32_t keypoint_index;
  };
  std::vector<Observation> observations;
};

// Per input frame as the front saw it (also frames that are not keyframes).
struct FrameRecord {
  Timestamp timestamp = 0;
  TrackingState state = TrackingState::kInitializing;
  int64_t submap_id = -1;
  Se3 T_wc;  // valid when state == kTracking (or kCoarse)
};

// A pose of the external pose source (wheel odometry, VIO, a motion-capture
// stand-in), body -> odometry world, at a frame's capture time. Metric and
// continuous across tracking losses, so it can join submaps vision cannot.
struct OdometryPose {
  Timestamp timestamp = 0;
  Se3 T_wb;
};

struct CameraIntrinsics {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;  // undistorted pinhole model
};

struct Submap {
  int64_t id = -1;  // unique per source within one rumi instance
  SubmapSource source = SubmapSource::kFront;
  CameraIntrinsics camera;
  std::vector<Keyframe> keyframes;     // sorted by timestamp
  std::vector<MapPoint> points;
  std::vector<FrameRecord> frames;     // front: every frame of this submap
  std::vector<OdometryPose> odometry;  // front: pose source at its frames (empty without one)
};

// Frames of the submap the front tracked (state kTracking).
size_t TrackedFrames(const Submap& s);

// Removes the points observed by fewer than min_observations keyframes and
// unlinks them from the keyframes (point_ids -1). The ORB-SLAM map-point rule
// applied to a back submap: SfM keeps two-view points that a keyframe-based
// map would have culled. Returns the number removed.
int DropWeakPoints(Submap* submap, int min_observations);

// The submap as it stood at time t: keyframes, frames and odometry up to t,
// the points those keyframes observe (with only their observations; a point
// left with none is dropped and unlinked). What a front resend of a submap
// still being built looks like (a real one also differs by the BA since).
Submap SubmapUntil(const Submap& s, Timestamp t);

// Track completion by reprojection: a point is also observed by a keyframe
// where it projects (in front of the camera, inside the image) within
// max_px of a keypoint that has no point yet, and the nearest such keypoint is
// closer than `ratio` times the second nearest within max_px (else it is
// ambiguous); the closest claim wins. Keypoints with a descriptor row (ORB
// corners of back keyframes) are not used. SfM leaves such observations out when
// the pairwise matcher missed them (dark, noisy frames), which makes every
// track short. Returns the observations added.
int CompleteTracks(Submap* submap, double max_px, double ratio = 0.7);

}  // namespace rumi
