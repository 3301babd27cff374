#include "front/front.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "front/initializer.h"
#include "front/local_mapping.h"
#include "front/matcher.h"
#include "front/optimizer.h"
#include "common/orb_extractor.h"

namespace rumi {
namespace {

double ThreadCpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Frees a vector's buffer (`v = {}` only clears it: the capacity stays).
template <class T>
void Release(std::vector<T>* v) {
  std::vector<T>().swap(*v);
}

}  // namespace

Front::Front(const FrontOptions& options, const PinholeCamera& camera, int64_t first_submap_id)
    : options_(options), camera_(camera), hier_(options.hier) {
  first_submap_id_ = submap_id_ = first_submap_id;
  std::string why;
  if (!options_.Check(&why)) throw std::invalid_argument("front options: " + why);
  const PinholeCameraOptions& c = camera_.options();
  cam_.fx = c.fx; cam_.fy = c.fy; cam_.cx = c.cx; cam_.cy = c.cy;
  cam_.num_levels = options_.orb.num_levels;
  cam_.scale_factor = options_.orb.scale_factor;
  for (int l = 0; l < cam_.num_levels; ++l) {
    const double s = std::pow(cam_.scale_factor, l);
    cam_.scales.push_back(s);
    cam_.sigma2.push_back(s * s);
    cam_.inv_sigma2.push_back(1.0 / (s * s));
  }
  intrinsics_ = {c.width, c.height, c.fx, c.fy, c.cx, c.cy};
  if (options_.orb.num_features == 0)
    options_.orb.num_features = c.width * c.height > 640 * 480 ? 2000 : 1000;
  extractor_ = std::make_unique<OrbExtractor>(options_.orb);
  K_ = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  dist_ = (cv::Mat_<double>(1, 5) << c.k1, c.k2, c.p1, c.p2, c.k3);
  has_distortion_ = c.k1 != 0 || c.k2 != 0 || c.p1 != 0 || c.p2 != 0 || c.k3 != 0;
  min_x_ = 0; min_y_ = 0; max_x_ = c.width; max_y_ = c.height;
  if (has_distortion_) {  // bounds of the undistorted image
    std::vector<cv::Point2f> corners = {{0, 0}, {float(c.width), 0}, {0, float(c.height)}, {float(c.width), float(c.height)}}, und;
    cv::undistortPoints(corners, und, K_, dist_, cv::noArray(), K_);
    min_x_ = std::min(und[0].x, und[2].x); max_x_ = std::max(und[1].x, und[3].x);
    min_y_ = std::min(und[0].y, und[1].y); max_y_ = std::max(und[2].y, und[3].y);
  }
  map_ = std::make_unique<Map>();
  mapper_ = std::make_unique<LocalMapper>(map_.get(), cam_, options_);
  mapper_->Start();
}

Front::~Front() {
  if (mapper_) mapper_->Stop();
}

std::shared_ptr<Features> Front::Extract(const cv::Mat& image) {
  cv::Mat grey = image;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  else if (image.channels() == 4) cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  if (grey.depth() != CV_8U) grey.convertTo(grey, CV_8U);
  auto f = std::make_shared<Features>();
  f->width = grey.cols;
  f->height = grey.rows;
  extractor_->Extract(grey, &f->keypoints, &f->descriptors);
  f->un.resize(f->keypoints.size());
  if (has_distortion_ && !f->keypoints.empty()) {
    std::vector<cv::Point2f> pts(f->keypoints.size()), und;
    for (size_t i = 0; i < pts.size(); ++i) pts[i] = f->keypoints[i].pt;
    cv::undistortPoints(pts, und, K_, dist_, cv::noArray(), K_);
    for (size_t i = 0; i < pts.size(); ++i) f->un[i] = {und[i].x, und[i].y};
  } else {
    for (size_t i = 0; i < f->keypoints.size(); ++i) f->un[i] = {f->keypoints[i].pt.x, f->keypoints[i].pt.y};
  }
  f->min_x = min_x_; f->min_y = min_y_; f->max_x = max_x_; f->max_y = max_y_;
  f->BuildGrid(std::max(1, static_cast<int>((max_x_ - min_x_) / 10)), std::max(1, static_cast<int>((max_y_ - min_y_) / 10)));
  return f;
}

void Front::AddPosePrior(Timestamp t, const Se3& T_wb) {
  if (!poses_.empty() && t <= poses_.back().first) return;  // time order only
  poses_.push_back({t, T_wb * options_.odometry_T_bc});  // camera poses from here on
  while (poses_.size() > 100000) poses_.pop_front();
}

std::optional<Se3> Front::PoseAt(Timestamp t) const {
  if (poses_.empty() || t < poses_.front().first || t > poses_.back().first) return std::nullopt;
  auto it = std::lower_bound(poses_.begin(), poses_.end(), t,
                             [](const auto& a, Timestamp b) { return a.first < b; });
  if (it->first == t || it == poses_.begin()) return it->second;
  const auto& a = *(it - 1);
  const auto& b = *it;
  const double s = double(t - a.first) / double(b.first - a.first);
  const Eigen::Quaterniond q = a.second.rotation().slerp(s, b.second.rotation());
  return Se3(q, (1 - s) * a.second.translation() + s * b.second.translation());
}

void Front::TrimFinished(size_t n) {
  for (size_t i = trimmed_; i < std::min(n, finished_.size()); ++i) {
    Submap& s = finished_[i];
    for (Keyframe& kf : s.keyframes) {
      Release(&kf.keypoints);
      Release(&kf.octaves);
      Release(&kf.point_ids);
      kf.descriptors.release();
    }
    Release(&s.points);
    Release(&s.odometry);
    // The first with the most tracked frames, as the publisher picks front.txt's.
    const size_t tracked = TrackedFrames(s);
    if (largest_trimmed_ < 0 || tracked > largest_trimmed_tracked_) {
      if (largest_trimmed_ >= 0) Release(&finished_[largest_trimmed_].frames);
      largest_trimmed_ = static_cast<int>(i);
      largest_trimmed_tracked_ = tracked;
    } else {
      Release(&s.frames);
    }
  }
  trimmed_ = std::max(trimmed_, std::min(n, finished_.size()));
}

FrameRecord Front::Track(Timestamp t, const cv::Mat& image) {
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = ThreadCpuMs();
  FrameTiming timing;
  timing.timestamp = t;
  if (image.empty()) throw std::invalid_argument("Front::Track: empty image");
  auto f = Extract(image);
  {
    std::lock_guard<std::mutex> l(map_->mutex);
    ++map_->frame_counter;  // PurgeCulled's clock
  }
  timing.extract_ms = MsSince(t0);
  timing.keypoints = static_cast<int>(f->size());
  const auto t1 = std::chrono::steady_clock::now();
  const double density = f->size() / std::max(1.0, f->width * double(f->height) / 1e4);

  if (cur_.timestamp > 0 && t > cur_.timestamp) {  // frame rate estimate (EMA)
    const double dt = NsToSeconds(t - cur_.timestamp);
    frame_interval_s_ = frame_interval_s_ > 0 ? 0.9 * frame_interval_s_ + 0.1 * dt : dt;
  }
  last_ = std::move(cur_);
  cur_ = TrackFrame();
  cur_.id = ++frame_counter_;
  cur_.timestamp = t;
  cur_.f = f;
  cur_.Reset(f->size());
  kf_inserted_ = false;
  last_inliers_ = 0;
  lock_wait_ms_ = 0;

  if (options_.hierarchical && hier_.state() == MappingGrain::kCoarse) {
    hier_.Update(density, false, false);
    if (hier_.left_coarse()) {
      // The map was already handed over on entering coarse: just re-initialise.
      spdlog::info("front: features dense again, leaving coarse state; building submap {}", submap_id_);
      state_ = TrackingState::kInitializing;
      init_ref_.reset();
    }
  } else {
    switch (state_) {
      case TrackingState::kInitializing: Initialize(); break;
      case TrackingState::kTracking:
        // A gap of several frame intervals (dropped frames): the motion
        // model is meaningless, relocalise (descriptor matching + PnP) instead.
        if (frame_interval_s_ > 0 && NsToSeconds(t - last_.timestamp) > 4.0 * frame_interval_s_ &&
            NsToSeconds(t - last_.timestamp) > 0.2) {
          spdlog::info("front: {:.2f} s gap before {}, relocalising", NsToSeconds(t - last_.timestamp), FormatSeconds(t));
          state_ = TrackingState::kLost;
          lost_since_ = t;
          velocity_valid_ = false;
          if (!Relocalize() && !Relocalize()) {}  // two candidate pairs right away
          break;
        }
        if (!TrackCurrent()) {
          const int nkf = [&] { std::lock_guard<std::mutex> l(map_->mutex); return map_->NumGoodKeyFrames(); }();
          if (nkf <= 4) {
            spdlog::info("front: lost with only {} keyframes, restarting submap {}", nkf, submap_id_);
            StartNewSubmap(false);
          } else {
            spdlog::info("front: tracking lost at {} in submap {}", FormatSeconds(t), submap_id_);
            state_ = TrackingState::kLost;
            lost_since_ = t;
          }
        }
        break;
      case TrackingState::kLost:
        if (!Relocalize() && NsToSeconds(t - lost_since_) >= options_.reloc_time_s) {
          spdlog::info("front: relocalisation failed for {:.2f} s, new submap {}",
                       NsToSeconds(t - lost_since_), submap_id_ + 1);
          StartNewSubmap(true);
        }
        break;
      case TrackingState::kCoarse: break;
    }
    if (options_.hierarchical) {
      hier_.Update(density, kf_inserted_, state_ == TrackingState::kTracking);
      if (hier_.entered_coarse()) {
        spdlog::info("front: entering coarse state (density {:.2f}, C_t over lambda), finishing submap {}",
                     density, submap_id_);
        Timestamp t_last = t;
        Se3 T_wc_last;
        for (auto it = submap_frames_.rbegin(); it != submap_frames_.rend(); ++it)
          if (it->rec.state == TrackingState::kTracking) { t_last = it->rec.timestamp; T_wc_last = it->rec.T_wc; break; }
        coarse_T_wc0_ = T_wc_last;
        coarse_pose0_ = PoseAt(t_last);
        FinishSubmap(true);
        state_ = TrackingState::kCoarse;
      }
    }
  }
  if (options_.hierarchical && hier_.state() == MappingGrain::kCoarse) state_ = TrackingState::kCoarse;

  FrameRecord rec = MakeRecord();
  if (state_ == TrackingState::kTracking) {
    FrameRel fr{rec, ref_kf_, Se3()};
    if (ref_kf_) {
      std::lock_guard<std::mutex> l(map_->mutex);
      fr.T_c_ref = cur_.T_cw * ref_kf_->T_cw.Inverse();
    }
    submap_frames_.push_back(fr);
  } else if (state_ != TrackingState::kCoarse) {
    submap_frames_.push_back({rec, nullptr, Se3()});
  }
  if (history_limit_ > 0 && records_.size() >= 2 * history_limit_) {
    records_.erase(records_.begin(), records_.end() - history_limit_);
    timings_.erase(timings_.begin(), timings_.end() - std::min(timings_.size(), history_limit_));
  }
  records_.push_back(rec);
  timing.track_ms = MsSince(t1);
  timing.total_ms = MsSince(t0);
  timing.cpu_ms = ThreadCpuMs() - c0;
  timing.lock_wait_ms = lock_wait_ms_;
  timing.inliers = last_inliers_;
  timings_.push_back(timing);
  if (callback_) callback_(rec, image);
  return rec;
}

FrameRecord Front::MakeRecord() const {
  FrameRecord r;
  r.timestamp = cur_.timestamp;
  r.state = state_;
  r.submap_id = submap_id_;
  if (state_ == TrackingState::kTracking) {
    r.T_wc = cur_.T_cw.Inverse();
  } else if (state_ == TrackingState::kCoarse) {
    r.submap_id = submap_id_ - 1;  // the finished submap the pose is chained to
    const auto p = PoseAt(cur_.timestamp);
    r.T_wc = coarse_T_wc0_;
    if (p && coarse_pose0_) r.T_wc = coarse_T_wc0_ * (coarse_pose0_->Inverse() * *p);
  }
  return r;
}

void Front::Initialize() {
  const Features& f = *cur_.f;
  const double radius = options_.init_search_radius_frac * f.width;
  if (!init_ref_ || cur_.id - init_ref_frame_ > options_.init_max_frames) {
    init_ref_.reset();
    if (static_cast<int>(f.size()) >= options_.init_min_matches) {
      init_ref_ = cur_.f;
      init_ref_t_ = cur_.timestamp;
      init_ref_frame_ = cur_.id;
      init_prev_matched_ = f.un;
    }
    return;
  }
  std::vector<int> m12;
  const int n = SearchForInitialization(*init_ref_, f, &init_prev_matched_, radius, &m12);
  if (n < options_.init_min_matches) {
    init_ref_.reset();
    if (static_cast<int>(f.size()) >= options_.init_min_matches) {
      init_ref_ = cur_.f;
      init_ref_t_ = cur_.timestamp;
      init_ref_frame_ = cur_.id;
      init_prev_matched_ = f.un;
    }
    return;
  }
  std::vector<Eigen::Vector2d> p1, p2;
  std::vector<std::pair<int, int>> idx;
  for (size_t i = 0; i < m12.size(); ++i) {
    if (m12[i] < 0) continue;
    p1.push_back(init_ref_->un[i]);
    p2.push_back(f.un[m12[i]]);
    idx.push_back({static_cast<int>(i), m12[i]});
  }
  TwoViewOptions tvo;
  const bool reinit = submap_id_ > first_submap_id_;  // a first map of this process can wait; a re-init cannot
  const int min_points = reinit ? options_.reinit_min_triangulated : options_.init_min_triangulated;
  tvo.min_triangulated = min_points;
  tvo.min_parallax_deg = reinit ? options_.reinit_min_parallax_deg : options_.init_min_parallax_deg;
  TwoViewResult r;
  if (!ReconstructTwoView(p1, p2, cam_.K(), tvo, &r)) return;

  // Build the initial map: two keyframes and the triangulated points.
  std::lock_guard<std::mutex> lock(map_->mutex);
  auto k0 = std::make_unique<KeyFrame>();
  k0->timestamp = init_ref_t_;
  k0->frame_id = init_ref_frame_;
  k0->f = init_ref_;
  k0->points.assign(init_ref_->size(), nullptr);
  k0->fixed = true;
  KeyFrame* kf0 = map_->AddKeyFrame(std::move(k0));
  auto k1 = std::make_unique<KeyFrame>();
  k1->timestamp = cur_.timestamp;
  k1->frame_id = cur_.id;
  k1->f = cur_.f;
  k1->T_cw = r.T_21;
  k1->points.assign(f.size(), nullptr);
  KeyFrame* kf1 = map_->AddKeyFrame(std::move(k1));
  for (size_t m = 0; m < idx.size(); ++m) {
    if (!r.triangulated[m]) continue;
    Landmark* p = map_->NewPoint(r.points[m], kf0);
    Map::AddObservation(p, kf0, idx[m].first);
    Map::AddObservation(p, kf1, idx[m].second);
    Map::ComputeDescriptor(p);
    Map::UpdateNormalAndDepth(p, cam_);
  }
  Map::UpdateConnections(kf0);
  Map::UpdateConnections(kf1);
  GlobalBa(map_.get(), cam_, 20);
  const double median = kf0->MedianDepth();
  const int tracked = kf1->TrackedPoints(1);
  if (!(median > 0) || tracked < min_points) {
    spdlog::debug("front: initial map rejected (median depth {}, {} points)", median, tracked);
    for (auto& [id, p] : map_->points) Map::SetBad(p.get());
    map_->keyframes.clear();
    map_->points.clear();
    init_ref_.reset();
    return;
  }
  // Scale: median scene depth of the first keyframe = 1.
  const double s = 1.0 / median;
  kf1->T_cw.translation() *= s;
  for (auto& [id, p] : map_->points) {
    p->pos *= s;
    Map::UpdateNormalAndDepth(p.get(), cam_);
  }
  cur_.T_cw = kf1->T_cw;
  for (size_t i = 0; i < kf1->points.size(); ++i) cur_.points[i] = kf1->points[i];
  // Per-frame velocity from the motion spread over the initialisation gap.
  const double gap = std::max<int64_t>(1, cur_.id - init_ref_frame_);
  velocity_ = Se3::Exp(kf1->T_cw.Log() / gap);
  velocity_dt_s_ = NsToSeconds(cur_.timestamp - init_ref_t_) / gap;
  velocity_valid_ = true;
  ref_kf_ = kf1;
  last_kf_frame_ = cur_.id;
  last_reloc_frame_ = cur_.id;  // wider local search for the next frames
  state_ = TrackingState::kTracking;
  kf_inserted_ = true;
  last_inliers_ = tracked;
  kf_peak_inliers_ = tracked;
  // The reference frame now has a pose in the submap (it is keyframe 0):
  // its record in the submap says so (the per-frame log keeps what was known
  // live, initialising).
  for (FrameRel& fr : submap_frames_)
    if (fr.rec.timestamp == kf0->timestamp) {
      fr.rec.state = TrackingState::kTracking;
      fr.ref = kf0;
      fr.T_c_ref = Se3();
    }
  spdlog::info("front: submap {} initialised ({}), {} points, parallax {:.1f} deg, RH {:.2f}, gap {} frames",
               submap_id_, r.model, tracked, r.parallax_deg, r.score_ratio, static_cast<int>(gap));
  if (pending_link_) {
    pending_link_->to = submap_id_;
    pending_link_->t_to = kf0->timestamp;
    const auto a = PoseAt(pending_link_->t_from), b = PoseAt(kf0->timestamp);
    if (a && b) { pending_link_->T_from_to = a->Inverse() * *b; pending_link_->valid = true; }
    links_.push_back(*pending_link_);
    pending_link_.reset();
  }
  mapper_->Push(kf0);
  mapper_->Push(kf1);
  if (!options_.local_mapping_thread) {
    map_->mutex.unlock();
    mapper_->Drain();
    map_->mutex.lock();
  }
}

bool Front::TrackCurrent() {
  const auto w0 = std::chrono::steady_clock::now();
  std::unique_lock<std::mutex> lock(map_->mutex);
  lock_wait_ms_ += MsSince(w0);
  for (size_t i = 0; i < last_.points.size(); ++i)
    if (last_.points[i] && last_.points[i]->bad) last_.points[i] = nullptr;
  if (ref_kf_ && ref_kf_->bad) {
    ref_kf_ = nullptr;
    for (auto it = map_->keyframes.rbegin(); it != map_->keyframes.rend(); ++it)
      if (!it->second->bad) { ref_kf_ = it->second.get(); break; }
  }
  bool ok = false;
  if (velocity_valid_) ok = TrackWithMotionModel();
  if (!ok) ok = TrackReferenceKeyFrame();
  int inliers = 0;
  if (ok) {
    inliers = TrackLocalMap();
    const int need = cur_.id - last_reloc_frame_ < 10 ? std::max(options_.min_tracked_inliers, 50)
                                                       : options_.min_tracked_inliers;
    ok = inliers >= need;
  }
  last_inliers_ = inliers;
  if (!ok) {
    spdlog::debug("front: frame {} failed: {} matches, {} local-map inliers", cur_.id, cur_.NumMatches(), inliers);
    velocity_valid_ = false;
    return false;
  }
  velocity_ = cur_.T_cw * last_.T_cw.Inverse();
  velocity_dt_s_ = NsToSeconds(cur_.timestamp - last_.timestamp);
  velocity_valid_ = true;
  // Outliers do not propagate to the next frame.
  for (size_t i = 0; i < cur_.points.size(); ++i)
    if (cur_.outlier[i]) { cur_.points[i] = nullptr; cur_.outlier[i] = false; }
  kf_peak_inliers_ = std::max(kf_peak_inliers_, inliers);
  if (NeedNewKeyFrame(inliers)) {
    CreateKeyFrame();
    if (!options_.local_mapping_thread) {
      lock.unlock();
      mapper_->Drain();
    }
  }
  return true;
}

bool Front::TrackWithMotionModel() {
  // Constant velocity in time: a short drop (up to 3 intervals) scales the
  // predicted motion; over longer gaps extrapolation is worse than one
  // interval's motion (seen on the synthetic `drop` sequence).
  Se3 v = velocity_;
  const double dt = NsToSeconds(cur_.timestamp - last_.timestamp);
  if (velocity_dt_s_ > 0 && dt > 0 && std::abs(dt / velocity_dt_s_ - 1.0) > 0.2 && dt / velocity_dt_s_ <= 3.0)
    v = Se3::Exp(velocity_.Log() * (dt / velocity_dt_s_));
  cur_.T_cw = v * last_.T_cw;
  cur_.Reset(cur_.f->size());
  int n = SearchByProjection(&cur_, last_, cam_, options_.motion_search_radius, true);
  if (n < 20) {
    cur_.Reset(cur_.f->size());
    n = SearchByProjection(&cur_, last_, cam_, 2 * options_.motion_search_radius, true);
  }
  if (n < 20) return false;
  return OptimizePose(&cur_, cam_) >= 10;
}

bool Front::TrackReferenceKeyFrame() {
  if (!ref_kf_) return false;
  cur_.T_cw = last_.T_cw;
  cur_.Reset(cur_.f->size());
  // Without a vocabulary: wide projection windows with a ratio test, from the
  // last pose (the camera has not moved far when the motion model failed).
  int n = SearchKeyFramePoints(&cur_, *ref_kf_, cam_, 40.0, kDescHigh, 0.8);
  n += SearchByProjection(&cur_, last_, cam_, 40.0, true);
  if (n < 15) return false;
  return OptimizePose(&cur_, cam_) >= 10;
}

int Front::TrackLocalMap() {
  const int64_t tag = cur_.id;
  // Keyframes sharing points with the frame, by votes.
  std::map<KeyFrame*, int> votes;
  for (size_t i = 0; i < cur_.points.size(); ++i) {
    Landmark* p = cur_.points[i];
    if (!p || p->bad || cur_.outlier[i]) continue;
    for (auto& [k, idx] : p->obs) if (!k->bad) ++votes[k];
  }
  std::vector<std::pair<int, KeyFrame*>> ranked;
  for (auto& [k, v] : votes) ranked.push_back({v, k});
  std::sort(ranked.begin(), ranked.end(), [](auto& a, auto& b) { return a.first > b.first || (a.first == b.first && a.second->id > b.second->id); });
  std::vector<KeyFrame*> local;
  auto add = [&](KeyFrame* k) {
    if (k->bad || k->local_for_frame == tag) return;
    if (static_cast<int>(local.size()) >= options_.max_local_keyframes) return;
    k->local_for_frame = tag;
    local.push_back(k);
  };
  // The newest keyframes first: their young points are what keeps tracking
  // alive while the view changes (they have few votes yet).
  int newest = 0;
  for (auto it = map_->keyframes.rbegin(); it != map_->keyframes.rend() && newest < 8; ++it) {
    KeyFrame* k = it->second.get();
    if (k->bad || std::abs(NsToSeconds(cur_.timestamp - k->timestamp)) >= options_.short_term_s) continue;
    add(k);
    ++newest;
  }
  for (auto& [v, k] : ranked) add(k);
  // Short-term (|dt| < Th_t) and mid-term (|dp| < Th_p) subsets (paper 004, Formula 5).
  const Eigen::Vector3d centre = -(cur_.T_cw.R().transpose() * cur_.T_cw.translation());
  for (auto it = map_->keyframes.rbegin(); it != map_->keyframes.rend(); ++it) {
    KeyFrame* k = it->second.get();
    if (k->bad) continue;
    if (std::abs(NsToSeconds(cur_.timestamp - k->timestamp)) < options_.short_term_s ||
        (k->Centre() - centre).norm() < options_.mid_term_dist)
      add(k);
  }
  const size_t first_level = local.size();
  for (size_t i = 0; i < first_level; ++i)
    for (KeyFrame* n : local[i]->BestCovisibles(10)) add(n);
  if (!ranked.empty()) ref_kf_ = ranked.front().second;

  // Local points not already matched.
  for (size_t i = 0; i < cur_.points.size(); ++i) {
    Landmark* p = cur_.points[i];
    if (!p) continue;
    if (p->bad) { cur_.points[i] = nullptr; continue; }
    p->visible++;
    p->last_frame_seen = tag;
  }
  std::vector<Landmark*> pts;
  for (KeyFrame* k : local)
    for (Landmark* p : k->points)
      if (p && !p->bad && p->track_ref_frame != tag && p->last_frame_seen != tag) {
        p->track_ref_frame = tag;
        pts.push_back(p);
      }
  const double radius = options_.local_search_radius * (cur_.id - last_reloc_frame_ < 3 ? 3.0 : 1.0);
  SearchLocalPoints(&cur_, pts, cam_, radius);
  const int inliers = OptimizePose(&cur_, cam_);
  for (size_t i = 0; i < cur_.points.size(); ++i) {
    Landmark* p = cur_.points[i];
    if (p && !cur_.outlier[i]) p->found++;
  }
  return inliers;
}

bool Front::NeedNewKeyFrame(int inliers) {
  if (mapper_->QueueSize() > 2) return false;
  if (!ref_kf_) return true;
  const int nkf = map_->NumGoodKeyFrames();
  const int ref_tracked = ref_kf_->TrackedPoints(nkf <= 2 ? 2 : 3);
  const int64_t since = cur_.id - last_kf_frame_;
  const double fps = options_.fps > 0 ? options_.fps : (frame_interval_s_ > 0 ? 1.0 / frame_interval_s_ : 10.0);
  const bool c1a = since >= static_cast<int64_t>(std::round(fps));
  const bool c1b = mapper_->Idle();
  // The reference count only includes points seen by >= 3 keyframes, so a
  // young reference (just inserted, its points freshly triangulated) has few
  // and tracking could decay through a whole turn with no keyframe (seen on
  // `smooth`: inliers 309 -> 134 over 0.8 s, then a scale collapse). Hence
  // also: tracking has weakened against what the last keyframe tracked, and,
  // much weaker, a keyframe even while mapping is busy. The peak since the
  // last keyframe is the baseline: the keyframe's own frame sees few points,
  // the next ones also the points triangulated from it.
  const bool weak = inliers < options_.kf_weak_ratio * kf_peak_inliers_;
  const bool c1c = inliers < 0.5 * options_.kf_weak_ratio * kf_peak_inliers_;
  const bool c2 = (inliers < options_.kf_tracked_ratio * ref_tracked || weak) && inliers > 15;
  return (c1a || c1b || c1c) && c2;
}

void Front::CreateKeyFrame() {
  auto k = std::make_unique<KeyFrame>();
  k->timestamp = cur_.timestamp;
  k->frame_id = cur_.id;
  k->f = cur_.f;
  k->T_cw = cur_.T_cw;
  k->points.assign(cur_.f->size(), nullptr);
  KeyFrame* kf = map_->AddKeyFrame(std::move(k));
  for (size_t i = 0; i < cur_.points.size(); ++i) {
    Landmark* p = cur_.points[i];
    if (p && !p->bad && !p->obs.count(kf)) Map::AddObservation(p, kf, static_cast<int>(i));
  }
  ref_kf_ = kf;
  last_kf_frame_ = cur_.id;
  kf_peak_inliers_ = last_inliers_;
  kf_inserted_ = true;
  mapper_->Push(kf);
}

int64_t Front::current_submap_keyframes() const {
  std::lock_guard<std::mutex> lock(map_->mutex);
  return map_->NumGoodKeyFrames();
}

Front::MapCounts Front::current_map_counts() const {
  std::lock_guard<std::mutex> lock(map_->mutex);
  MapCounts c;
  c.keyframes = map_->keyframes.size();
  for (const auto& [id, kf] : map_->keyframes) c.good_keyframes += kf->bad ? 0 : 1;
  c.points = map_->points.size();
  for (const auto& [id, p] : map_->points) c.good_points += p->bad ? 0 : 1;
  return c;
}

bool Front::Relocalize() {
  std::unique_lock<std::mutex> lock(map_->mutex);
  // Candidates: the 6 newest keyframes of this submap, two per frame in turn
  // (bounded per-frame cost while lost).
  std::vector<KeyFrame*> recent;
  for (auto it = map_->keyframes.rbegin(); it != map_->keyframes.rend() && recent.size() < 6; ++it)
    if (!it->second->bad) recent.push_back(it->second.get());
  std::vector<KeyFrame*> cands;
  for (size_t k = 0; k < 2 && k < recent.size(); ++k) cands.push_back(recent[(reloc_cursor_ + k) % recent.size()]);
  reloc_cursor_ += 2;
  const Features& f = *cur_.f;
  for (KeyFrame* kf : cands) {
    std::vector<int> kidx;
    for (size_t i = 0; i < kf->points.size(); ++i)
      if (kf->points[i] && !kf->points[i]->bad) kidx.push_back(static_cast<int>(i));
    if (kidx.size() < 15) continue;
    cv::Mat kd(static_cast<int>(kidx.size()), 32, CV_8U);
    for (size_t i = 0; i < kidx.size(); ++i) kf->f->descriptors.row(kidx[i]).copyTo(kd.row(static_cast<int>(i)));
    const auto m = MatchBruteForce(f.descriptors, kd, 64, 0.8);
    if (m.size() < 15) continue;
    std::vector<cv::Point3f> obj;
    std::vector<cv::Point2f> img;
    for (auto [i, j] : m) {
      const Eigen::Vector3d X = kf->points[kidx[j]]->pos;
      obj.emplace_back(X.x(), X.y(), X.z());
      img.emplace_back(f.un[i].x(), f.un[i].y());
    }
    cv::Mat rvec, tvec;
    std::vector<int> inl;
    if (!cv::solvePnPRansac(obj, img, K_, cv::noArray(), rvec, tvec, false, 200, 4.0f, 0.99, inl, cv::SOLVEPNP_EPNP) ||
        inl.size() < 12)
      continue;
    cv::Mat Rcv;
    cv::Rodrigues(rvec, Rcv);
    Eigen::Matrix3d R;
    for (int r = 0; r < 3; ++r) for (int c = 0; c < 3; ++c) R(r, c) = Rcv.at<double>(r, c);
    cur_.T_cw = Se3(R, Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
    cur_.Reset(f.size());
    for (int k : inl) cur_.points[m[k].first] = kf->points[kidx[m[k].second]];
    int n = OptimizePose(&cur_, cam_);
    if (n < 10) continue;
    for (size_t i = 0; i < cur_.points.size(); ++i) if (cur_.outlier[i]) cur_.points[i] = nullptr;
    if (n < options_.reloc_min_inliers) {
      SearchKeyFramePoints(&cur_, *kf, cam_, 10.0, kDescHigh, 0.9);
      n = OptimizePose(&cur_, cam_);
    }
    if (n < options_.reloc_min_inliers / 2) continue;
    ref_kf_ = kf;
    last_reloc_frame_ = cur_.id;
    const int inliers = TrackLocalMap();
    last_inliers_ = inliers;
    kf_peak_inliers_ = inliers;
    if (inliers < options_.reloc_min_inliers) continue;
    for (size_t i = 0; i < cur_.points.size(); ++i)
      if (cur_.outlier[i]) { cur_.points[i] = nullptr; cur_.outlier[i] = false; }
    spdlog::info("front: relocalised at {} against keyframe {} ({} inliers)", FormatSeconds(cur_.timestamp), kf->id, inliers);
    state_ = TrackingState::kTracking;
    velocity_valid_ = false;
    return true;
  }
  cur_.Reset(f.size());
  return false;
}

void Front::FinishSubmap(bool keep) {
  mapper_->Stop();
  {
    std::lock_guard<std::mutex> l(map_->mutex);
    if (keep && map_->NumGoodKeyFrames() >= 2) {
      Submap s = map_->Export(submap_id_, intrinsics_);
      for (const FrameRel& fr : submap_frames_) {
        FrameRecord r = fr.rec;
        if (r.state == TrackingState::kTracking && fr.ref) r.T_wc = (fr.T_c_ref * fr.ref->PoseFollowingParents()).Inverse();
        s.frames.push_back(r);
      }
      AttachOdometry(&s);
      spdlog::info("front: submap {} finished: {} keyframes, {} points, {} frames", s.id, s.keyframes.size(),
                   s.points.size(), s.frames.size());
      // Link to the next submap (completed when it initialises).
      SubmapLink link;
      link.from = s.id;
      link.t_from = s.frames.empty() ? 0 : s.frames.back().timestamp;
      for (auto it = s.frames.rbegin(); it != s.frames.rend(); ++it)
        if (it->state == TrackingState::kTracking) { link.t_from = it->timestamp; break; }
      pending_link_ = link;
      finished_.push_back(std::move(s));
    }
  }
  submap_frames_.clear();
  ref_kf_ = nullptr;
  velocity_valid_ = false;
  last_.points.clear();
  last_.outlier.clear();
  init_ref_.reset();
  mapper_.reset();
  map_ = std::make_unique<Map>();
  mapper_ = std::make_unique<LocalMapper>(map_.get(), cam_, options_);
  mapper_->Start();
  ++submap_id_;
  cur_.points.assign(cur_.f ? cur_.f->size() : 0, nullptr);
  cur_.outlier.assign(cur_.points.size(), false);
}

void Front::StartNewSubmap(bool keep) {
  FinishSubmap(keep);
  state_ = TrackingState::kInitializing;
}

void Front::Finish() {
  if (finished_all_) return;
  finished_all_ = true;
  if (mapper_) mapper_->Stop();
  FinishSubmap(true);
}

Submap Front::CurrentSubmap() {
  std::lock_guard<std::mutex> l(map_->mutex);
  Submap s = map_->Export(submap_id_, intrinsics_);
  for (const FrameRel& fr : submap_frames_) {
    FrameRecord r = fr.rec;
    if (r.state == TrackingState::kTracking && fr.ref) r.T_wc = (fr.T_c_ref * fr.ref->PoseFollowingParents()).Inverse();
    s.frames.push_back(r);
  }
  AttachOdometry(&s);
  return s;
}

void Front::AttachOdometry(Submap* s) const {
  s->odometry.clear();
  if (poses_.empty()) return;
  for (const FrameRecord& r : s->frames)
    if (const auto T = PoseAt(r.timestamp)) s->odometry.push_back({r.timestamp, *T});
}

}  // namespace rumi
