#pragma once
// The realtime monocular front end: ORB tracking against a local map,
// local mapping in its own thread, one front submap per continuous track
// (tracking loss -> short relocalisation attempt -> new submap), and the
// optional hierarchical fine/coarse mode (paper 000).
//
// Realtime rule: Track() touches no disk and only the map mutex, which the
// mapping thread holds for short bounded steps (BA is solved unlocked).
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "common/camera.h"
#include "common/submap.h"
#include "front/front_options.h"
#include "front/hierarchical.h"
#include "front/map.h"

namespace rumi {

class OrbExtractor;
class LocalMapper;

struct FrameTiming {
  Timestamp timestamp = 0;
  double extract_ms = 0, track_ms = 0, total_ms = 0;  // wall clock
  double cpu_ms = 0;  // tracking thread CPU time (robust to a loaded machine)
  double lock_wait_ms = 0;  // time spent waiting for the map mutex
  int keypoints = 0, inliers = 0;
};

// Relative pose between consecutive submaps from the external pose source:
// the camera motion (the body's through odometry_T_bc) from the last tracked
// frame of `from` to the first keyframe of `to` (metric, pose-source frame).
// valid=false without poses.
struct SubmapLink {
  int64_t from = -1, to = -1;
  Timestamp t_from = 0, t_to = 0;
  Se3 T_from_to;
  bool valid = false;
};

class Front {
 public:
  // Sampler integration point (front/sampler.h): called at the end of every
  // Track() with the record and the input image, in the tracking thread;
  // must be cheap and non-blocking.
  using FrameCallback = std::function<void(const FrameRecord&, const cv::Mat&)>;

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
  void SetFrameCallback(FrameCallback cb) { callback_ = std::move(cb); }

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
  const std::vector<SubmapLink>& links() const { return links_; }
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
  std::shared_ptr<Features> Extract(const cv::Mat& grey);
  void Initialize();
  bool TrackCurrent();
  bool TrackWithMotionModel();
  bool TrackReferenceKeyFrame();
  int TrackLocalMap();
  bool Relocalize();
  bool NeedNewKeyFrame(int inliers);
  void CreateKeyFrame();
  void StartNewSubmap(bool keep);
  void FinishSubmap(bool keep);
  std::optional<Se3> PoseAt(Timestamp t) const;
  // The pose source at the submap's frames (the manager's odometry merge).
  void AttachOdometry(Submap* s) const;
  FrameRecord MakeRecord() const;

  FrontOptions options_;
  PinholeCamera camera_;
  FrontCamera cam_;
  CameraIntrinsics intrinsics_;
  std::unique_ptr<OrbExtractor> extractor_;
  cv::Mat K_, dist_;
  bool has_distortion_ = false;
  double min_x_ = 0, min_y_ = 0, max_x_ = 0, max_y_ = 0;

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
  int64_t last_kf_frame_ = 0, last_reloc_frame_ = -100;
  Timestamp lost_since_ = 0;
  int last_inliers_ = 0;
  int kf_peak_inliers_ = 0;  // most inliers of a frame since the last keyframe
  bool kf_inserted_ = false;
  size_t reloc_cursor_ = 0;
  double frame_interval_s_ = 0;
  double lock_wait_ms_ = 0;

  // Initialisation.
  std::shared_ptr<const Features> init_ref_;
  Timestamp init_ref_t_ = 0;
  int64_t init_ref_frame_ = 0;
  std::vector<Eigen::Vector2d> init_prev_matched_;

  // Frames of the current submap and their poses relative to a keyframe,
  // so the exported trajectory follows later BA corrections.
  struct FrameRel { FrameRecord rec; KeyFrame* ref = nullptr; Se3 T_c_ref; };
  std::vector<FrameRel> submap_frames_;

  std::vector<Submap> finished_;
  size_t trimmed_ = 0;  // finished_[0, trimmed_) hold poses only
  int largest_trimmed_ = -1;  // the trimmed submap that keeps its frame records
  size_t largest_trimmed_tracked_ = 0;
  std::vector<SubmapLink> links_;
  std::optional<SubmapLink> pending_link_;
  std::vector<FrameRecord> records_;
  std::vector<FrameTiming> timings_;
  size_t history_limit_ = 0;
  std::deque<std::pair<Timestamp, Se3>> poses_;
  Se3 coarse_T_wc0_;
  std::optional<Se3> coarse_pose0_;
  FrameCallback callback_;
  bool finished_all_ = false;
};

}  // namespace rumi
