#include "back/back_submap_builder.h"

#include <chrono>
#include <opencv2/core.hpp>
#include <unordered_map>

#include "back/attempt_policy.h"
#include "back/colmap_database.h"
#include "back/colmap_runner.h"
#include "back/colmap_workspace.h"
#include "back/keyframe_orb.h"
#include "back/window_layout.h"
#include "common/camera.h"
#include "common/logging.h"

namespace rumi {
namespace {

using Clock = std::chrono::steady_clock;

// Checks what COLMAP and the conversion rely on; "" when fine.
std::string ValidateWindow(const ImageWindow& w, int min_frames) {
  const PinholeCameraOptions& c = w.camera;
  std::string why;
  if (!c.Check(&why)) return "camera: " + why;
  if (!(c.fx > 0 && c.fy > 0))
    return "camera focal lengths must be positive for COLMAP (fx=" + ColmapNumber(c.fx) +
           ", fy=" + ColmapNumber(c.fy) + ")";
  if (static_cast<int>(w.frames.size()) < min_frames)
    return "window has " + std::to_string(w.frames.size()) + " frames, fewer than " +
           std::to_string(min_frames);
  for (size_t i = 0; i < w.frames.size(); ++i) {
    const WindowFrame& f = w.frames[i];
    if (f.timestamp < 0) return "frame " + std::to_string(i) + " has a negative timestamp";
    if (i > 0 && f.timestamp <= w.frames[i - 1].timestamp)
      return "timestamps not strictly increasing at frame " + std::to_string(i);
    if (f.image.empty()) return "frame " + std::to_string(i) + " has no image";
    if (f.image.depth() != CV_8U || (f.image.channels() != 1 && f.image.channels() != 3))
      return "frame " + std::to_string(i) + " is not an 8-bit grey or BGR image";
    if (f.image.cols != c.width || f.image.rows != c.height)
      return "frame " + std::to_string(i) + " is " + std::to_string(f.image.cols) + "x" +
             std::to_string(f.image.rows) + ", camera is " + std::to_string(c.width) + "x" +
             std::to_string(c.height);
  }
  return "";
}

// The end of every Build: status, message, total time and its log line.
BackResult Finish(BackResult res, BackStatus s, std::string msg, Clock::time_point t_start) {
  res.status = s;
  res.message = std::move(msg);
  res.times.total_s = SecondsSince(t_start);
  if (s == BackStatus::kOk)
    spdlog::info("window {}: {} submap(s), {}/{} frames registered in {:.1f} s", res.window_id,
                 res.submaps.size(), res.num_registered, res.num_frames, res.times.total_s);
  else
    spdlog::warn("window {}: {}: {}", res.window_id, ToString(s), res.message);
  return res;
}

// The attempts of one window: the first; then, while a part of the window
// is short of frames (ShortOfFrames), the fill (the pairs the selection
// left out) and the retry (a lower SIFT threshold), in the order the frames
// left out call for (RetryGoesFirst). A further attempt is adopted when its
// largest model is larger.
class AttemptSequence {
 public:
  AttemptSequence(const BackOptions& o, const ImageWindow& w, const WindowLayout& l, const ColmapWorkspace& ws,
                  ColmapRunner* runner, BackResult* res)
      : o_(o), w_(w), l_(l), ws_(ws), runner_(runner), res_(res) {}

  // False when the build ends here (the first attempt failed, or one was
  // cancelled) with its status and message.
  bool Run(BackStatus* status, std::string* message);
  ColmapAttempt& adopted() { return at_; }
  // With blank stretches: every attempt that built, in order (each side picks one).
  std::vector<ColmapAttempt>& tried() { return tried_; }

 private:
  bool Short() const { return ShortOfFrames(w_, l_, at_, o_.retry_below_registered); }
  int Frames() const { return int(w_.frames.size()) - l_.num_blank; }  // that COLMAP saw
  bool RetryFirst() const;
  bool Fill(const std::string& tag, double peak_threshold, std::string* cancelled);
  bool Retry(std::string* fill_tag, std::string* cancelled);
  void KeepFeaturesForRetry() const;
  void Adopt(ColmapAttempt next, const std::string& failed, const std::string& before, bool* kept);

  const BackOptions& o_;
  const ImageWindow& w_;
  const WindowLayout& l_;
  const ColmapWorkspace& ws_;
  ColmapRunner* runner_;
  BackResult* res_;
  ColmapAttempt at_;  // the adopted attempt
  std::vector<ColmapAttempt> tried_;
};

bool AttemptSequence::Run(BackStatus* status, std::string* message) {
  at_ = runner_->Run({o_.sift_peak_threshold, ""});
  if (at_.status != BackStatus::kOk) {
    *status = at_.status;
    *message = at_.message;
    return false;
  }
  at_.name = "first attempt";
  if (!l_.stretches.empty()) tried_.push_back(at_);
  const bool can_fill = o_.matcher == "pairs" && o_.retry_below_registered > 0;
  const bool can_retry = o_.retry_peak_threshold > 0 && o_.retry_peak_threshold != o_.sift_peak_threshold;
  const bool retry_first = can_fill && can_retry && RetryFirst();
  std::string fill_tag;  // the attempt whose database a later fill matches
  *status = BackStatus::kCancelled;
  if (can_fill && !retry_first && Short() && !Fill("", o_.sift_peak_threshold, message)) return false;
  if (can_retry && Short() && !Retry(&fill_tag, message)) return false;
  if (can_fill && retry_first && Short() &&
      !Fill(fill_tag, fill_tag.empty() ? o_.sift_peak_threshold : o_.retry_peak_threshold, message))
    return false;
  *status = BackStatus::kOk;
  return true;
}

// What the first attempt left out decides what comes next (RetryGoesFirst):
// its SIFT features and verified pairs, from its database.
bool AttemptSequence::RetryFirst() const {
  if (o_.retry_first_below_features <= 0 || !Short()) return false;
  const std::string db = ws_.database("").string();
  std::unordered_map<std::string, int> features;
  std::vector<std::pair<std::string, std::string>> verified;
  std::string why;
  if (!ReadColmapKeypointCounts(db, &features, &why) ||
      !ReadColmapVerifiedPairs(db, kColmapMinInliers, &verified, &why)) {
    spdlog::debug("window {}: {}", w_.id, why);
    return false;
  }
  const std::vector<std::string> missing = LeftOutFrames(w_, l_, at_, 0);
  const LeftOutCauses causes = ClassifyLeftOut(missing, features, verified, o_.retry_first_below_features);
  const bool first = RetryGoesFirst(causes, missing.size());
  if (first)
    spdlog::info("window {}: of the {} frames left out of the largest models, {} have fewer than {} SIFT "
                 "features and {} no verified pair with a frame in one: the retry goes before the fill",
                 w_.id, missing.size(), causes.poor, o_.retry_first_below_features, causes.unlinked);
  return first;
}

// Selected pairs that leave frames out: every other pair, matched on the
// features of attempt `tag` (a 53-frame blur window: 28 frames with the
// selected pairs, 51 after). Only the pairs of the frames left out were
// not enough: the pairs between frames the model holds give the longer
// tracks, and so the 3D points, that the others register on (2026-11-28:
// blur seed 2 38 frames instead of 51, kidnap seed 5 42 instead of 52).
// False when cancelled.
bool AttemptSequence::Fill(const std::string& tag, double peak_threshold, std::string* cancelled) {
  spdlog::info("window {}: {}/{} frames in the largest model; matching the remaining image pairs", w_.id,
               at_.largest(), Frames());
  ColmapAttempt all = runner_->Run({peak_threshold, tag, /*fill=*/true});
  all.name = tag.empty() ? "fill" : "fill of the retry";
  res_->filled = true;
  if (all.status == BackStatus::kCancelled) {
    *cancelled = all.message;
    return false;
  }
  Adopt(std::move(all), "matching the remaining pairs failed: ", "selected pairs: ", &res_->fill_kept);
  return true;
}

// Texture-poor windows (a plain corridor wall) give SIFT too few features at
// the usual threshold: when the largest model misses too many frames, the
// whole window is tried again with a lower one and the larger model kept.
// False when cancelled.
bool AttemptSequence::Retry(std::string* fill_tag, std::string* cancelled) {
  spdlog::info("window {}: {}/{} frames in the largest model; retrying with SIFT peak threshold {}", w_.id,
               at_.largest(), Frames(), o_.retry_peak_threshold);
  if (o_.retry_reuses_features) KeepFeaturesForRetry();
  ColmapAttempt retry = runner_->Run({o_.retry_peak_threshold, "_retry"});
  retry.name = "retry";
  res_->retried = true;
  if (retry.status == BackStatus::kCancelled) {
    *cancelled = retry.message;
    return false;
  }
  // A fill after it matches the retry's features (more of them) unless the retry failed or is smaller.
  if (retry.status == BackStatus::kOk && retry.largest() >= at_.largest()) *fill_tag = "_retry";
  Adopt(std::move(retry), "retry with a lower SIFT threshold failed: ", "first attempt: ", &res_->retry_kept);
  return true;
}

// Frames the largest models hold keep their features and their matches
// with each other; those left out are extracted again at the lower
// threshold and only their pairs are matched (COLMAP skips what the copy
// holds). So are the kept frames up to pairs.overlap from one left out: where
// a model ends against a plain stretch its last frames are poor at the
// first threshold too (generated corridor seed 2, a first model of frames
// 0-19: 42-172 features on 15-19; without them the retry held 53 or 56
// of 73 frames, with them 73).
void AttemptSequence::KeepFeaturesForRetry() const {
  const std::vector<std::string> again = LeftOutFrames(w_, l_, at_, o_.pairs.overlap);
  int forgotten = 0;
  std::string why;
  if (CopyColmapDatabase(ws_.database("").string(), ws_.database("_retry").string(), again, &forgotten, &why))
    spdlog::info("window {}: the retry keeps the features of {} frames of the largest models and extracts {} "
                 "again",
                 w_.id, Frames() - forgotten, forgotten);
  else
    spdlog::warn("window {}: the retry extracts every frame again: {}", w_.id, why);
}

// A further attempt replaces the adopted one when its largest model is larger.
void AttemptSequence::Adopt(ColmapAttempt next, const std::string& failed, const std::string& before, bool* kept) {
  if (next.status != BackStatus::kOk) {
    res_->warnings.push_back(failed + next.message);
    return;
  }
  if (!l_.stretches.empty()) tried_.push_back(next);
  if (next.largest() > at_.largest()) {
    res_->warnings.push_back(before + std::to_string(at_.largest()) + " frames in the largest model");
    at_ = std::move(next);
    *kept = true;
  }
}

// ORB corners on every keyframe, detected on the image COLMAP saw (keyframe_orb.h).
void AddOrbCorners(int num_features, const std::unordered_map<Timestamp, cv::Mat>& images, int64_t window_id,
                   std::vector<BuiltModel>* built) {
  OrbExtractorOptions oo;
  oo.num_features = num_features;
  OrbExtractor orb(oo);
  for (BuiltModel& b : *built) {
    int added = 0;
    for (Keyframe& kf : b.submap.keyframes) {
      const auto it = images.find(kf.timestamp);
      if (it != images.end()) added += AddOrbKeypoints(it->second, &orb, &kf);
    }
    spdlog::debug("window {}: {} ORB keypoints on {} keyframes", window_id, added, b.submap.keyframes.size());
  }
}

}  // namespace

BackSubmapBuilder::BackSubmapBuilder(const BackOptions& options, int64_t first_submap_id)
    : options_(options), next_submap_id_(first_submap_id) {}

BackResult BackSubmapBuilder::Build(const ImageWindow& window, const std::atomic<bool>* cancel) {
  const auto t_start = Clock::now();
  BackResult res;
  res.window_id = window.id;
  res.num_frames = static_cast<int>(window.frames.size());
  const auto finish = [&](BackStatus s, std::string msg) { return Finish(std::move(res), s, std::move(msg), t_start); };
  std::string why;
  if (!options_.Check(&why)) return finish(BackStatus::kInvalidWindow, "back options: " + why);
  why = ValidateWindow(window, options_.min_registered_images);
  if (!why.empty()) return finish(BackStatus::kInvalidWindow, why);

  // Per-window workspace: unique per process and call, removed on every exit path.
  ColmapWorkspace ws(options_.WorkspaceRoot(), window.id, workspace_counter_++);
  if (!ws.Create(options_.keep_workspaces, &why)) return finish(BackStatus::kIoError, why);
  if (options_.keep_workspaces) res.workspace = ws.dir().string();

  // Blank frames (a covered lens) show only noise: COLMAP gets none of them
  // (contrast-stretched noise gave SIFT ~330 keypoints per frame to match,
  // for nothing), a model is not short of them, and they cut models.
  const WindowLayout layout = LayOutWindow(window, options_);
  if (res.num_frames - layout.num_blank < options_.min_registered_images)
    return finish(BackStatus::kNoModel, std::to_string(layout.num_blank) + " of the window's " +
                                            std::to_string(res.num_frames) +
                                            " frames are blank (the camera saw nothing): too few left to map");
  if (layout.num_blank > 0) spdlog::info("window {}: {} blank frames left out", window.id, layout.num_blank);

  const auto t_write = Clock::now();
  std::unordered_map<Timestamp, cv::Mat> images;  // as written, for the ORB keypoints
  if (!WriteColmapImages(window, layout.blank, options_.normalize_contrast, ws,
                         options_.orb_features > 0 ? &images : nullptr, &why))
    return finish(BackStatus::kIoError, why);
  res.times.undistort_write_s = SecondsSince(t_write);
  if (!WritePairLists(options_.matcher, window, layout, options_.pairs, ws, &res.matched_pairs, &why))
    return finish(BackStatus::kIoError, why);

  ColmapRunner runner(options_, window, ws, !layout.stretches.empty(), cancel, on_stage_, &res.times);
  AttemptSequence attempts(options_, window, layout, ws, &runner, &res);
  BackStatus status;
  if (!attempts.Run(&status, &why)) return finish(status, why);
  ColmapAttempt& at = attempts.adopted();
  res.warnings.insert(res.warnings.end(), at.warnings.begin(), at.warnings.end());
  if (!layout.stretches.empty())
    KeepBestSides(std::move(attempts.tried()), layout.stretches, options_.min_registered_images,
                  options_.min_point_observations, &at, &res.warnings);
  if (options_.orb_features > 0) AddOrbCorners(options_.orb_features, images, window.id, &at.built);
  for (BuiltModel& b : at.built) {
    b.submap.id = next_submap_id_++;
    res.num_registered += b.stats.registered_images;
    res.submaps.push_back(std::move(b.submap));
    res.stats.push_back(b.stats);
  }
  for (const std::string& w : res.warnings) spdlog::info("window {}: {}", window.id, w);
  if (res.submaps.empty())
    return finish(BackStatus::kNoModel, at.models == 0 ? "mapper produced no model (no initial pair?)"
                                                       : "all models smaller than min_registered_images");
  return finish(BackStatus::kOk, "");
}

}  // namespace rumi
