#pragma once
// The realtime monocular front end: ORB tracking against a local map,
// local mapping in its own thread, one front submap per continuous track
// (tracking loss -> short relocalisation attempt -> new submap), and the
// optional hierarchical fine/coarse mode (paper 000).
//
// Front is the tracking state machine and the submaps' bookkeeping; the steps
// are modules (as stella_vslam's module/): FeatureExtractor (ORB, undistorted
// once), MapInitializer (two-view first map), frame_tracker.h (motion model,
// reference keyframe, local map), KeyframeInserter (policy and insertion),
// Relocalizer, LocalMapper (mapping thread).
//
// Realtime rule: Track() touches no disk and only the map mutex, which the
// mapping thread holds for short bounded steps (BA is solved unlocked).
#include <memory>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "common/camera.h"
#include "common/imu.h"
#include "common/pose_buffer.h"
#include "common/submap.h"
#include "front/feature_extractor.h"
#include "front/front_options.h"
#include "front/hierarchical.h"
#include "front/keyframe_inserter.h"
#include "front/map.h"
#include "front/map_initializer.h"
#include "front/relocalizer.h"

namespace rumi {

class LocalMapper;

struct FrameTiming {
  Timestamp timestamp = 0;
  double extract_ms = 0, track_ms = 0, total_ms = 0;  // wall clock
  double cpu_ms = 0;  // tracking thread CPU time (robust to a loaded machine)
  double lock_wait_ms = 0;  // time spent waiting for the map mutex
  int keypoints = 0, inliers = 0;
};

class Front {
 public:
  // Submap ids count from first_submap_id (rumid: unique across restarts).
  Front(const FrontOptions& options, const PinholeCamera& camera, int64_t first_submap_id = 0);
  ~Front();
  Front(const Front&) = delete;
  Front& operator=(const Front&) = delete;

  // One 8-bit grey (or BGR) image in capture order.
  FrameRecord Track(Timestamp t, const cv::Mat& image);

  // External pose source (odometry/IMU body poses in their own world frame,
  // turned into camera poses by options.odometry_T_bc), used to chain
  // submaps in the hierarchical mode and across losses; the
  // poses at a submap's frames travel with it (Submap::odometry). Call from
  // the tracking thread, in time order, before Track() of the frames it covers.
  void AddPosePrior(Timestamp t, const Se3& T_wb);
  // IMU gyro samples (rad/s, IMU frame) in time order, from the tracking
  // thread before Track() of the frames they cover. With options.gyro_prior
  // the motion model takes each frame's rotation from them, and a gap in the
  // frames (a lossy link) is bridged by the gyro before relocalising.
  void AddImu(Timestamp t, const Eigen::Vector3d& gyro);
  struct GyroStats {
    int64_t predicted = 0;  // tracked frames whose prediction the gyro turned
    int64_t bridged = 0;    // frame gaps tracked across with the gyro's rotation
    int64_t bias_updates = 0;
    Eigen::Vector3d bias = Eigen::Vector3d::Zero();  // rad/s, IMU frame
    bool disabled = false;  // switched off: it kept disagreeing with the tracked rotation
  };
  const GyroStats& gyro_stats() const { return gyro_stats_; }
  // "gyro prior: ..." for the log; "" when no IMU sample came.
  std::string GyroSummary() const;

  // Finishes the current submap (end of sequence); idempotent.
  void Finish();
  Submap CurrentSubmap();                                  // snapshot
  const std::vector<Submap>& FinishedSubmaps() const { return finished_; }
  // Drops the map of the first n finished submaps (keypoints, descriptors,
  // map points), keeping their keyframe poses, and the frame records of all
  // of them but the one with the most tracked frames (front.txt): a front
  // that runs for hours holds only what its final files need once the
  // publisher has copied them (rumid).
  void TrimFinished(size_t n);
  // Keeps at most the last 2 x frames per-frame records and timings (0: all).
  // The pipeline's front needs only the newest (the publisher logs each).
  void LimitHistory(size_t frames) { history_limit_ = frames; }
  const std::vector<FrameRecord>& records() const { return records_; }
  const std::vector<FrameTiming>& timings() const { return timings_; }
  int64_t current_submap_id() const { return submap_id_; }
  int64_t current_submap_keyframes() const;  // good keyframes of the current submap
  // Current submap's containers, culled entries included (memory checks).
  struct MapCounts { size_t keyframes = 0, good_keyframes = 0, points = 0, good_points = 0; };
  MapCounts current_map_counts() const;
  TrackingState state() const { return state_; }
  MappingGrain grain() const { return hier_.state(); }
  bool halt() const { return options_.hierarchical && hier_.halt(); }
  const FrontOptions& options() const { return options_; }

 private:
  void Initialize();
  // The frames seen while initialising, posed against the first map once it
  // exists (FrontOptions::init_backfill); map mutex held.
  void BackfillInitialFrames(const InitialMap& m);
  // across_gap: frames were missing since last_ (the gyro's rotation, last
  // position held, wide windows).
  bool TrackCurrent(bool across_gap = false);
  // The camera's rotation from the last frame to the current one, R_cur_last,
  // from the gyro; nullopt without samples covering the span.
  std::optional<Eigen::Quaterniond> GyroRotation() const;
  void UpdateGyroBias(const Eigen::Quaterniond& R_cur_last_gyro);
  // Tracking was lost (or frames went missing) after last_: keep it and the
  // velocity before the loss, so the gyro can bridge the loss from there.
  void SetAnchor(bool velocity_valid, const Se3& velocity, double velocity_dt_s);
  // Tracks cur_ from the anchor with the gyro's rotation since then, while
  // the loss is younger than options.gyro_bridge_s. True when tracked.
  bool BridgeWithGyro();
  bool BridgeOpen() const;  // the anchor is young enough
  bool Relocalize();
  void StartNewSubmap(bool keep);
  void FinishSubmap(bool keep);
  // The current submap with its frames, each posed against its reference
  // keyframe as it is now, and the pose source at them (caller holds the map mutex).
  Submap ExportCurrent() const;
  FrameRecord MakeRecord() const;
  const ScalePyramid& pyramid() const { return extractor_->pyramid(); }

  FrontOptions options_;
  PinholeCamera camera_;
  std::unique_ptr<FeatureExtractor> extractor_;
  MapInitializer initializer_;
  std::vector<TrackFrame> init_frames_;  // id, timestamp, features of the frames since the reference
  KeyframeInserter inserter_;
  Relocalizer relocalizer_;

  std::unique_ptr<Map> map_;
  std::unique_ptr<LocalMapper> mapper_;
  int64_t first_submap_id_ = 0;
  int64_t submap_id_ = 0;
  TrackingState state_ = TrackingState::kInitializing;
  HierarchicalState hier_;

  // Tracking state.
  int64_t frame_counter_ = 0;
  TrackFrame cur_, last_;
  bool velocity_valid_ = false;
  Se3 velocity_;  // T_cur_last
  double velocity_dt_s_ = 0;  // interval the velocity was measured over
  KeyFrame* ref_kf_ = nullptr;
  int64_t last_reloc_frame_ = -100;
  Timestamp lost_since_ = 0;
  int last_inliers_ = 0;
  bool kf_inserted_ = false;
  double frame_interval_s_ = 0;
  double lock_wait_ms_ = 0;

  // Frames of the current submap and their poses relative to a keyframe,
  // so the exported trajectory follows later BA corrections.
  struct FrameRel { FrameRecord rec; KeyFrame* ref = nullptr; Se3 T_c_ref; };
  std::vector<FrameRel> submap_frames_;

  std::vector<Submap> finished_;
  size_t trimmed_ = 0;  // finished_[0, trimmed_) hold poses only
  int largest_trimmed_ = -1;  // the trimmed submap that keeps its frame records
  size_t largest_trimmed_tracked_ = 0;
  std::vector<FrameRecord> records_;
  std::vector<FrameTiming> timings_;
  size_t history_limit_ = 0;
  PoseBuffer poses_{100000};  // the pose source, camera poses
  Se3 coarse_T_wc0_;
  std::optional<Se3> coarse_pose0_;
  GyroIntegrator gyro_;
  GyroStats gyro_stats_;
  uint32_t gyro_disagree_ = 0;  // the last 30 checks against vision: bit set = disagreed
  int64_t gyro_checks_ = 0;
  // The last tracked frame before a loss; its points by id (the mapper may
  // cull and free them while the front is lost).
  struct Anchor {
    bool valid = false;
    TrackFrame frame;
    std::vector<int64_t> point_ids;
    bool velocity_valid = false;
    Se3 velocity;
    double velocity_dt_s = 0;
  };
  Anchor anchor_;
  bool finished_all_ = false;
};

}  // namespace rumi
