#pragma once
// Variable-density sampler (RUMI-SLAM, Sec. IV-B, Fig. 4/6): decides, frame by
// frame, which images the back process should ruminate on.
//
//   S1  while tracked: one sample every `inter` tracked frames; the last `len`
//       are kept in a ring.
//   S2  while not tracked (lost, re-initialising, coarse): every frame.
//   S3  after tracking resumes: one sample every `inter` frames until the front
//       submap holds more than `th_s3` frames ("number of frames in the front
//       submap"). What a frame of a submap is, is `th_s3_unit`: keyframes
//       (default: a submap is made of keyframes, and S3 then spans enough
//       motion for the back to tie the new submap to the window) or every
//       frame the front assigned to it (the sampler_test's fr1_room figures;
//       re-initialisation frames alone often exceed 8, leaving S3 empty).
//   Pre-loss tail (rumi, not in the paper): on a loss, the up to `pre_loss`
//       tracked frames after the last sparse sample join the window as well
//       (labelled like that sample), so the back's model reaches the last
//       frame the front tracked: that is where the two submaps must overlap.
//   Then S = S1 u S2 u S3 is emitted as one ImageWindow and the back starts.
//   Nothing is emitted while tracking never fails.
//
// Stated policies (docs/ipc.md has the timeline):
//  - Not-tracked frames before the first tracked frame of the stream are not
//    a loss, but they are kept like S2 frames (same cap and thinning). If the
//    front needed more than `startup_frames` of them to start its first map
//    (texture-poor or motionless start), they are shipped: the first tracked
//    frame opens S3 as after a loss, so the back maps the start and the
//    manager ties it to the first front submap. Otherwise they are dropped
//    (a normal start: the first submap's reference frame covers them).
//  - Frame count for S3: the front's count of the submap it tracks in. When
//    tracking resumes in the SAME submap as before the loss (relocalisation),
//    the frames tracked (keyframes added) since the resume are counted instead.
//  - A second loss during S3 extends the same window: the S3 samples so far
//    stay (labelled S3), dense S2 sampling continues, S3 restarts on resume.
//  - Long losses: S2 holds at most max_s2 frames. When full, every second S2
//    sample is dropped and the S2 stride doubles (1, 2, 4, ...), so the window
//    keeps covering the whole loss at decreasing density with bounded memory.
//    Positions are counted over all not-tracked frames of the window, so the
//    kept frames are exactly those whose position is a multiple of the stride.
//  - Flush() (end of stream) emits the pending window when it holds S2 frames
//    (start-up frames only when more than `startup_frames`: a front that
//    never started still leaves the back a window).
//  - Sparse cadence is continuous: tracked frames are numbered from the start
//    of tracking (stream start or resume); a frame is sampled when its number
//    is a multiple of `inter`. After a window is emitted its S3 samples seed
//    the S1 ring of the next window.
//
// Cost per frame: a few comparisons; a sampled image is cloned (clone_images)
// or kept as a reference-counted shallow copy. No disk, no locks.
#include <opencv2/core.hpp>

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "common/option_spec.h"
#include "common/window.h"

namespace rumi {

enum class S3Unit { kKeyframes, kFrames };

struct SamplerOptions {
  int inter = 5;      // sparse stride (frames), S1 and S3
  int len = 10;       // S1 samples kept before a loss
  int th_s3 = 20;     // S3 ends when the front submap holds more frames than this
  S3Unit th_s3_unit = S3Unit::kKeyframes;  // what th_s3 counts
  int max_s2 = 100;   // cap on S2 samples per window (then thinned, stride doubles)
  // A first map that took more than this many frames to start: the frames
  // before it go to the back (1 s at 30 fps; a normal start takes 3-15).
  // 0: start-up frames are never shipped.
  int startup_frames = 30;
  // Tracked frames after the last sparse sample shipped on a loss (at most
  // inter - 1 exist). With every 5th frame only, COLMAP registered none of a
  // 0.5 s first submap (generated `weak` seed 3). 0: off.
  int pre_loss = 4;
  bool clone_images = true;  // false: keep shallow refs (frame source must not reuse buffers)
  static const OptionSpec<SamplerOptions>& Spec();  // section `sampler:`
  bool Check(std::string* why = nullptr) const;
};
// Keys: inter, len, th_s3, th_s3_unit (keyframes | frames), max_s2, startup_frames,
// pre_loss, clone_images.

struct SamplerFrame {
  Timestamp timestamp = 0;
  cv::Mat image;  // shallow; cloned only when sampled (clone_images)
  TrackingState state = TrackingState::kTracking;
  int64_t submap_id = -1;      // current front submap
  int64_t submap_frames = 0;   // frames in that submap, this one included
  int64_t submap_keyframes = 0;  // keyframes in that submap so far
};

class Sampler {
 public:
  enum class Phase { kIdle, kS1, kS2, kS3 };  // kIdle: not yet tracked once

  // Window ids count from first_window_id (rumid: unique across restarts).
  Sampler(const SamplerOptions& options, const PinholeCameraOptions& camera, int64_t first_window_id = 0);

  // Feeds one frame. True when a window completed with this frame (the frame
  // itself then belongs to the next window's cadence, not to *window).
  bool AddFrame(const SamplerFrame& frame, ImageWindow* window);
  // End of stream: true when a pending window with S2 frames was emitted.
  bool Flush(ImageWindow* window);

  Phase phase() const { return phase_; }
  // Samples held for the pending window (S1 ring + S2 + S3).
  size_t pending() const { return s1_.size() + body_.size(); }
  // Tracked frames held since the last sparse sample (pre-loss tail).
  size_t tail() const { return tail_.size(); }
  int s2_stride() const { return s2_stride_; }
  int64_t windows_emitted() const { return next_window_id_ - first_window_id_; }

 private:
  void Take(const SamplerFrame& f, SampleSet set, std::vector<WindowFrame>* into);
  void ThinS2();
  const char* SampleDense(const SamplerFrame& f);  // S2 (and start-up) sampling
  void DropPending();
  void StartS3(const SamplerFrame& f);
  bool StartupIsLong() const { return o_.startup_frames > 0 && lost_k_ > o_.startup_frames; }
  void Emit(ImageWindow* window);
  void HoldTail(const SamplerFrame& f);
  void Recycle(cv::Mat* image);
  void ShipTail(SampleSet set);

  SamplerOptions o_;
  PinholeCameraOptions camera_;
  Phase phase_ = Phase::kIdle;
  std::deque<WindowFrame> s1_;     // last `len` sparse samples
  std::vector<WindowFrame> body_;  // S2 and S3 samples of the pending window, time order
  std::deque<WindowFrame> tail_;   // tracked frames since the last sparse sample
  std::vector<cv::Mat> spare_;     // recycled tail buffers: no allocation per frame
  std::vector<int64_t> s2_pos_;    // position among lost frames, per S2 entry of body_
  int64_t sparse_k_ = 0;           // tracked frames since tracking (re)started
  int64_t lost_k_ = 0;             // not-tracked frames in the pending window
  int s2_stride_ = 1;
  int s2_count_ = 0;
  int64_t submap_before_loss_ = -1;
  int64_t resume_submap_ = -1;
  int64_t tracked_since_resume_ = 0;
  int64_t keyframes_at_resume_ = 0;
  int64_t first_window_id_ = 0;
  int64_t next_window_id_ = 0;
};

const char* ToString(Sampler::Phase p);

}  // namespace rumi
