#pragma once
// Internal map of one front submap: keyframes, map points, covisibility.
// Everything here is guarded by Map::mutex (tracking and local mapping share
// it; the mapping thread holds it only for short, bounded steps). Objects are
// flagged bad instead of freed so raw pointers held by frames stay valid for
// the submap's lifetime.
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <vector>

#include "common/camera.h"
#include "common/geometry.h"
#include "common/submap.h"
#include "common/timestamp.h"

namespace rumi {

struct Landmark;
struct KeyFrame;

// Orders keyframe and point pointers by id (creation order), never by heap
// address: containers keyed by pointer then iterate the same way in every run
// and build, so the front's result does not depend on the allocator.
struct ById {
  template <class T>
  bool operator()(const T* a, const T* b) const { return a->id < b->id; }
};

// Immutable features of one image.
struct Features {
  int width = 0, height = 0;
  std::vector<cv::KeyPoint> keypoints;    // as detected (distorted)
  std::vector<Eigen::Vector2d> un;        // undistorted pixel coordinates
  cv::Mat descriptors;                    // N x 32 CV_8U
  // Grid over the undistorted image for window queries.
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;
  int grid_cols = 0, grid_rows = 0;
  double cell_w = 1, cell_h = 1;
  std::vector<std::vector<int>> grid;

  size_t size() const { return keypoints.size(); }
  void BuildGrid(int cols, int rows);
  // Features within radius r of (x, y) (square window), octave in [min_level, max_level]
  // (max_level < 0: no upper bound).
  std::vector<int> InArea(double x, double y, double r, int min_level = -1, int max_level = -1) const;
  bool InImage(double x, double y) const { return x >= min_x && x < max_x && y >= min_y && y < max_y; }
};

// The ORB pyramid's constants per level: scale s^l, s^2l and its inverse
// (projection windows, reprojection weights, scale-invariance ranges).
struct ScalePyramid {
  ScalePyramid() = default;
  ScalePyramid(int levels, double factor);
  int num_levels = 0;
  double scale_factor = 1.2;
  std::vector<double> scales, sigma2, inv_sigma2;
};

// The front's geometry is the camera's pinhole K alone: keypoints are
// undistorted once, at extraction (front/feature_extractor.h), so projections
// land on undistorted pixels. The caller checks z > 0.
inline Eigen::Vector2d ProjectUndistorted(const PinholeCamera& c, const Eigen::Vector3d& p) {
  return {c.fx() * p.x() / p.z() + c.cx(), c.fy() * p.y() / p.z() + c.cy()};
}
// Undistorted pixel -> unit-depth ray.
inline Eigen::Vector3d UndistortedRay(const PinholeCamera& c, const Eigen::Vector2d& u) {
  return {(u.x() - c.cx()) / c.fx(), (u.y() - c.cy()) / c.fy(), 1.0};
}
inline Eigen::Matrix3d PinholeMatrix(const PinholeCamera& c) {
  Eigen::Matrix3d k;
  k << c.fx(), 0, c.cx(), 0, c.fy(), c.cy(), 0, 0, 1;
  return k;
}

struct Landmark {
  int64_t id = -1;
  Eigen::Vector3d pos = Eigen::Vector3d::Zero();
  cv::Mat descriptor;                 // 1 x 32
  std::map<KeyFrame*, int, ById> obs;      // keyframe -> keypoint index
  KeyFrame* ref_kf = nullptr;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // mean viewing direction
  double min_dist = 0, max_dist = 0;  // scale-invariance range
  int visible = 1, found = 1;         // for culling: found / visible ratio
  int64_t first_kf_id = 0;
  bool bad = false;
  int64_t bad_seen_at = -1;  // Map::frame_counter when PurgeCulled first saw it bad
  // Tracking scratch (avoid duplicates within one frame).
  int64_t last_frame_seen = -1, track_ref_frame = -1;

  double FoundRatio() const { return static_cast<double>(found) / visible; }
  int PredictLevel(double dist, const ScalePyramid& pyr) const;
};

struct KeyFrame {
  int64_t id = -1;
  int64_t frame_id = -1;
  Timestamp timestamp = 0;
  Se3 T_cw;
  std::shared_ptr<const Features> f;
  std::vector<Landmark*> points;      // per keypoint, nullptr for none
  std::map<KeyFrame*, int, ById> covis;    // covisibility weights (shared points)
  std::vector<KeyFrame*> ordered_covis;
  bool bad = false;
  int64_t bad_seen_at = -1;           // Map::frame_counter when PurgeCulled first saw it bad
  bool fixed = false;                 // first keyframe: gauge
  // Set when culled: the keyframe it was expressed against, so frames that
  // referenced it still follow later corrections (T_cw = T_parent_rel * parent->T_cw).
  KeyFrame* parent = nullptr;
  Se3 T_rel_parent;
  // Current world->camera of a possibly culled keyframe (follows parents).
  Se3 PoseFollowingParents() const;
  int64_t ba_local_for = -1, ba_fixed_for = -1, local_for_frame = -1;

  Eigen::Vector3d Centre() const { return -(T_cw.R().transpose() * T_cw.translation()); }
  std::vector<KeyFrame*> BestCovisibles(int n) const;
  int TrackedPoints(int min_obs) const;
  double MedianDepth() const;
};

class Map {
 public:
  std::mutex mutex;
  std::map<int64_t, std::unique_ptr<KeyFrame>> keyframes;  // by id (= creation order)
  std::map<int64_t, std::unique_ptr<Landmark>> points;
  int64_t frame_counter = 0;  // frames the tracking thread started (it increments it)

  // Frees what culling left behind (call with `mutex` held, from the mapping
  // thread after its own lists dropped bad points): culled points are
  // deleted, culled keyframes lose their features and point slots (the
  // object stays: frames refer to it and follow its parent chain). Only
  // entries first seen bad at least 2 tracking frames ago are freed: the
  // tracking thread holds pointers of the previous frame only, and drops bad
  // ones when it starts a frame. Returns the number of entries freed.
  size_t PurgeCulled();

  // A keyframe of the frame's features at pose T_cw, observing no point yet.
  KeyFrame* NewKeyFrame(Timestamp t, int64_t frame_id, std::shared_ptr<const Features> f, const Se3& T_cw);
  Landmark* NewPoint(const Eigen::Vector3d& pos, KeyFrame* ref);
  int64_t NextKeyFrameId() const { return next_kf_id_; }
  int NumGoodKeyFrames() const;

  static void AddObservation(Landmark* p, KeyFrame* kf, int idx);
  static void EraseObservation(Landmark* p, KeyFrame* kf);
  static void SetBad(Landmark* p);
  static void SetBad(KeyFrame* kf);
  // Replace p by q in every keyframe that observes p.
  static void Replace(Landmark* p, Landmark* q);
  static void UpdateNormalAndDepth(Landmark* p, const ScalePyramid& pyr);
  static void ComputeDescriptor(Landmark* p);
  static void UpdateConnections(KeyFrame* kf);

  // Export (caller holds the mutex); the submap's camera is cam's pinhole K.
  Submap Export(int64_t submap_id, const PinholeCamera& cam) const;

 private:
  int64_t next_kf_id_ = 0, next_point_id_ = 0;
};

}  // namespace rumi

namespace rumi {

// A frame being tracked (not a keyframe).
struct TrackFrame {
  int64_t id = -1;
  Timestamp timestamp = 0;
  std::shared_ptr<const Features> f;
  Se3 T_cw;
  std::vector<Landmark*> points;  // per keypoint
  std::vector<bool> outlier;
  KeyFrame* ref_kf = nullptr;
  void Reset(size_t n) {
    points.assign(n, nullptr);
    outlier.assign(n, false);
  }
  int NumMatches() const;
};

}  // namespace rumi
