#include "front/front.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "front/frame_tracker.h"
#include "front/local_mapping.h"
#include "front/matcher.h"
#include "front/optimizer.h"

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
    : options_(options), camera_(camera), initializer_(options_), inserter_(options_), hier_(options.hier) {
  first_submap_id_ = submap_id_ = first_submap_id;
  std::string why;
  if (!options_.Check(&why)) throw std::invalid_argument("front options: " + why);
  if (options_.orb.num_features == 0)
    options_.orb.num_features = camera.width() * camera.height() > 640 * 480 ? 2000 : 1000;
  extractor_ = std::make_unique<FeatureExtractor>(options_.orb, camera_);
  map_ = std::make_unique<Map>();
  mapper_ = std::make_unique<LocalMapper>(map_.get(), camera_, pyramid(), options_);
  mapper_->Start();
}

Front::~Front() {
  if (mapper_) mapper_->Stop();
}

void Front::AddPosePrior(Timestamp t, const Se3& T_wb) {
  poses_.Add(t, T_wb * options_.odometry_T_bc);  // camera poses from here on
}

void Front::AddImu(Timestamp t, const Eigen::Vector3d& gyro) {
  if (options_.gyro_prior) gyro_.Add(t, gyro);
}

std::optional<Eigen::Quaterniond> Front::GyroRotation() const {
  if (!options_.gyro_prior || gyro_stats_.disabled || gyro_.empty() || last_.timestamp <= 0) return std::nullopt;
  const auto R_b0_b1 = gyro_.Rotation(last_.timestamp, cur_.timestamp, gyro_stats_.bias);
  if (!R_b0_b1) return std::nullopt;
  // R_c0_c1 = R_bc^T R_b0_b1 R_bc; the motion model wants R_c1_c0.
  const Eigen::Quaterniond& R_bc = options_.imu_T_bc.rotation();
  return (R_bc.conjugate() * *R_b0_b1 * R_bc).conjugate();
}

std::string Front::GyroSummary() const {
  if (gyro_.empty()) return "";
  const GyroStats& g = gyro_stats_;
  return fmt::format("gyro prior: {} tracked frames predicted, {} losses or gaps bridged, bias [{:.4f}, {:.4f}, "
                     "{:.4f}] rad/s ({} updates){}",
                     g.predicted, g.bridged, g.bias.x(), g.bias.y(), g.bias.z(), g.bias_updates,
                     g.disabled ? ", switched off: it disagreed with vision" : "");
}

void Front::UpdateGyroBias(const Eigen::Quaterniond& R_cur_last_gyro) {
  // The tracked rotation is unbiased; what the gyro turned too far, per
  // second, is left-over bias. A slow average of it, outliers (a bad track)
  // ignored, keeps the prior good on an IMU nobody calibrated; the first
  // updates take larger steps and larger errors (an MPU6050 is off by up
  // to 20 deg/s before calibration).
  const double dt = NsToSeconds(cur_.timestamp - last_.timestamp);
  if (dt <= 0 || dt > 0.2) return;
  const Eigen::Quaterniond R_vis = cur_.T_cw.rotation() * last_.T_cw.rotation().conjugate();  // R_c1_c0
  const Eigen::Quaterniond& R_bc = options_.imu_T_bc.rotation();
  // Error of the gyro in the IMU frame: R_b0_b1(vis)^T R_b0_b1(gyro).
  const Eigen::Quaterniond e = R_bc * (R_vis * R_cur_last_gyro.conjugate()) * R_bc.conjugate();
  const Eigen::AngleAxisd aa(e.normalized());
  const Eigen::Vector3d rate = aa.axis() * aa.angle() / dt;
  if (!rate.allFinite()) return;
  const bool warming = ++gyro_checks_ <= 30;
  // A gyro that keeps disagreeing with vision (a wrong imu_T_bc, a broken
  // sensor) is switched off rather than trusted: 20 of the last 30 frames
  // off by more than 1 deg and 30 % of the tracked turn. (Per frame a small
  // image's tracked rotation is noisy, and a sideways step can pass for a
  // turn: a bound on the rate alone switched good gyros off at 320x240.)
  // Counted after the warm-up: until then the bias may not be learnt (at
  // 10 fps an 18 deg/s bias is 1.8 deg a frame).
  const double turn = Eigen::AngleAxisd(R_vis).angle();
  const bool off = !warming && aa.angle() > std::max(1.0 * M_PI / 180.0, 0.3 * turn);
  gyro_disagree_ = (gyro_disagree_ << 1 | (off ? 1u : 0u)) & ((1u << 30) - 1);
  if (__builtin_popcount(gyro_disagree_) >= 20) {
    spdlog::warn("front: the gyro disagrees with the tracked rotation on {} of the last 30 frames: gyro prior off "
                 "(check front.imu_T_bc, the camera's pose in the IMU frame)",
                 __builtin_popcount(gyro_disagree_));
    gyro_stats_.disabled = true;
    return;
  }
  // Outliers (a bad track) do not move the bias.
  const bool agrees = rate.norm() <= (warming ? 0.5 : 0.1);
  if (!agrees) return;
  gyro_stats_.bias += (warming ? 0.1 : 0.02) * rate;
  ++gyro_stats_.bias_updates;
}

void Front::SetAnchor(bool velocity_valid, const Se3& velocity, double velocity_dt_s) {
  anchor_ = Anchor();
  if (!options_.gyro_prior || gyro_stats_.disabled || gyro_.empty()) return;
  anchor_.valid = true;
  anchor_.frame = last_;
  anchor_.frame.points.clear();
  anchor_.point_ids.assign(last_.points.size(), -1);
  for (size_t i = 0; i < last_.points.size(); ++i)
    if (last_.points[i] && !last_.points[i]->bad) anchor_.point_ids[i] = last_.points[i]->id;
  anchor_.velocity_valid = velocity_valid;
  anchor_.velocity = velocity;
  anchor_.velocity_dt_s = velocity_dt_s;
}

bool Front::BridgeOpen() const {
  return anchor_.valid && NsToSeconds(cur_.timestamp - anchor_.frame.timestamp) <= options_.gyro_bridge_s;
}

bool Front::BridgeWithGyro() {
  if (!BridgeOpen()) return false;
  {
    std::lock_guard<std::mutex> l(map_->mutex);
    anchor_.frame.Reset(anchor_.point_ids.size());
    for (size_t i = 0; i < anchor_.point_ids.size(); ++i) {
      if (anchor_.point_ids[i] < 0) continue;
      const auto it = map_->points.find(anchor_.point_ids[i]);
      if (it != map_->points.end() && !it->second->bad) anchor_.frame.points[i] = it->second.get();
    }
  }
  std::swap(last_, anchor_.frame);
  velocity_valid_ = anchor_.velocity_valid;
  velocity_ = anchor_.velocity;
  velocity_dt_s_ = anchor_.velocity_dt_s;
  const bool ok = GyroRotation() && TrackCurrent(true);
  std::swap(last_, anchor_.frame);
  if (!ok) {
    velocity_valid_ = false;
    cur_.Reset(cur_.f->size());
    return false;
  }
  ++gyro_stats_.bridged;
  state_ = TrackingState::kTracking;
  anchor_.valid = false;
  return true;
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
  auto f = extractor_->Extract(image);
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
      initializer_.Reset();
    }
  } else {
    switch (state_) {
      case TrackingState::kInitializing: Initialize(); break;
      case TrackingState::kTracking: {
        const bool v_ok = velocity_valid_;
        const Se3 v = velocity_;
        const double v_dt = velocity_dt_s_;
        // A gap of several frame intervals (dropped frames): the motion
        // model is meaningless; the gyro bridges it when it saw the whole
        // gap, else relocalise (descriptor matching + PnP).
        if (frame_interval_s_ > 0 && NsToSeconds(t - last_.timestamp) > 4.0 * frame_interval_s_ &&
            NsToSeconds(t - last_.timestamp) > 0.2) {
          SetAnchor(v_ok, v, v_dt);
          state_ = TrackingState::kLost;
          lost_since_ = t;
          velocity_valid_ = false;
          if (BridgeWithGyro()) {
            spdlog::info("front: {:.2f} s gap before {} bridged by the gyro", NsToSeconds(t - last_.timestamp),
                         FormatSeconds(t));
            break;
          }
          spdlog::info("front: {:.2f} s gap before {}, relocalising", NsToSeconds(t - last_.timestamp), FormatSeconds(t));
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
            SetAnchor(v_ok, v, v_dt);
            state_ = TrackingState::kLost;
            lost_since_ = t;
          }
        }
        break;
      }
      case TrackingState::kLost:
        if (BridgeWithGyro()) {
          spdlog::info("front: tracking at {} again, bridged by the gyro from {} ({:.2f} s)", FormatSeconds(t),
                       FormatSeconds(anchor_.frame.timestamp), NsToSeconds(t - anchor_.frame.timestamp));
          break;
        }
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
        coarse_pose0_ = poses_.At(t_last);
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
    const auto p = poses_.At(cur_.timestamp);
    r.T_wc = coarse_T_wc0_;
    if (p && coarse_pose0_) r.T_wc = coarse_T_wc0_ * (coarse_pose0_->Inverse() * *p);
  }
  return r;
}

void Front::Initialize() {
  const bool reinit = submap_id_ > first_submap_id_;  // a first map of this process can wait; a re-init cannot
  {
    // Kept whether or not init_backfill is on, so that turning it off
    // changes nothing else (the front's results depend on its heap layout
    // through pointer-ordered containers). A frame older than the reference
    // can never be used: keep what one reference can span.
    TrackFrame kept;
    kept.id = cur_.id;
    kept.timestamp = cur_.timestamp;
    kept.f = cur_.f;
    while (!init_frames_.empty() && cur_.id - init_frames_.front().id > options_.init_max_frames + 1)
      init_frames_.erase(init_frames_.begin());
    init_frames_.push_back(std::move(kept));
  }
  if (!initializer_.Match(cur_, reinit, camera_)) return;
  std::lock_guard<std::mutex> lock(map_->mutex);
  InitialMap m;
  if (!initializer_.Build(cur_, reinit, map_.get(), camera_, pyramid(), &m)) return;
  cur_.T_cw = m.kf1->T_cw;
  for (size_t i = 0; i < m.kf1->points.size(); ++i) cur_.points[i] = m.kf1->points[i];
  // Per-frame velocity from the motion spread over the initialisation gap.
  velocity_ = Se3::Exp(m.kf1->T_cw.Log() / static_cast<double>(m.gap));
  velocity_dt_s_ = NsToSeconds(cur_.timestamp - m.kf0->timestamp) / static_cast<double>(m.gap);
  velocity_valid_ = true;
  ref_kf_ = m.kf1;
  inserter_.Reset(cur_.id, m.tracked);
  last_reloc_frame_ = cur_.id;  // wider local search for the next frames
  state_ = TrackingState::kTracking;
  kf_inserted_ = true;
  last_inliers_ = m.tracked;
  // The reference frame now has a pose in the submap (it is keyframe 0):
  // its record in the submap says so (the per-frame log keeps what was known
  // live, initialising).
  for (FrameRel& fr : submap_frames_)
    if (fr.rec.timestamp == m.kf0->timestamp) {
      fr.rec.state = TrackingState::kTracking;
      fr.ref = m.kf0;
      fr.T_c_ref = Se3();
    }
  spdlog::info("front: submap {} initialised ({}), {} points, parallax {:.1f} deg, RH {:.2f}, gap {} frames",
               submap_id_, m.two_view.model, m.tracked, m.two_view.parallax_deg, m.two_view.score_ratio,
               static_cast<int>(m.gap));
  if (!reinit) BackfillInitialFrames(m);
  init_frames_.clear();
  mapper_->Push(m.kf0);
  mapper_->Push(m.kf1);
  if (!options_.local_mapping_thread) {
    map_->mutex.unlock();
    mapper_->Drain();
    map_->mutex.lock();
  }
}

// Only the process's first map: a re-initialisation's frames are where the
// back's window pairs the front with a back submap by timestamp, and their
// backfilled poses (never refined by a BA) cost a merge there (generated
// drop seed 2: front#1 <-> back#0 kept 4 of 55 inliers, merged 100 -> 74.6 %).
void Front::BackfillInitialFrames(const InitialMap& m) {
  if (!options_.init_backfill || m.gap < 2) return;
  const int64_t id0 = m.kf0->frame_id, id1 = m.kf1->frame_id;
  const Eigen::Matrix<double, 6, 1> xi1 = m.kf1->T_cw.Log();  // kf0 is the identity
  int posed = 0, tried = 0;
  for (TrackFrame& f : init_frames_) {  // Initialize clears them afterwards
    if (f.id <= id0 || f.id >= id1) continue;
    ++tried;
    // From the motion spread evenly over the gap, as the velocity is.
    f.T_cw = Se3::Exp(xi1 * (static_cast<double>(f.id - id0) / static_cast<double>(id1 - id0)));
    f.Reset(f.f->size());
    int n = SearchKeyFramePoints(&f, *m.kf1, camera_, pyramid(), 15.0, kDescHigh, 0.8);
    if (n < options_.min_tracked_inliers) continue;
    if (OptimizePose(&f, camera_, pyramid()) < options_.min_tracked_inliers) continue;
    for (FrameRel& fr : submap_frames_)
      if (fr.rec.timestamp == f.timestamp && fr.rec.state != TrackingState::kTracking) {
        fr.rec.state = TrackingState::kTracking;
        fr.ref = m.kf0;
        fr.T_c_ref = f.T_cw;
        ++posed;
      }
  }
  if (tried) spdlog::debug("front: {} of the {} frames before initialisation posed on the first map", posed, tried);
}

bool Front::TrackCurrent(bool across_gap) {
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
  const std::optional<Eigen::Quaterniond> R_gyro = GyroRotation();
  // The prediction: constant velocity, the rotation the gyro measured when
  // there is one. Across a gap only the camera centre is extrapolated (the
  // gyro knows the turn; a turn extrapolated over a second would not be).
  Se3 predicted = last_.T_cw;
  if (velocity_valid_ && !across_gap) {
    predicted = PredictWithVelocity(last_.T_cw, last_.timestamp, cur_.timestamp, velocity_, velocity_dt_s_);
  } else if (velocity_valid_ && velocity_dt_s_ > 0) {
    const Eigen::Vector3d c0 = -(last_.T_cw.rotation().conjugate() * last_.T_cw.translation());
    const Se3 next = velocity_ * last_.T_cw;
    const Eigen::Vector3d c1 = -(next.rotation().conjugate() * next.translation());
    const Eigen::Vector3d c = c0 + (c1 - c0) * (NsToSeconds(cur_.timestamp - last_.timestamp) / velocity_dt_s_);
    predicted = Se3(last_.T_cw.rotation(), -(last_.T_cw.rotation() * c));
  }
  if (R_gyro) predicted = WithRotation(predicted, *R_gyro * last_.T_cw.rotation());
  const double radius = options_.motion_search_radius * (across_gap ? 3.0 : 1.0);
  bool ok = false;
  if (velocity_valid_ || R_gyro)
    ok = TrackWithMotionModel(&cur_, last_, predicted, radius, camera_, pyramid());
  if (!ok && R_gyro && velocity_valid_ && !across_gap)  // the gyro may be what is wrong
    ok = TrackWithMotionModel(&cur_, last_,
                              PredictWithVelocity(last_.T_cw, last_.timestamp, cur_.timestamp, velocity_, velocity_dt_s_),
                              radius, camera_, pyramid());
  if (!ok && ref_kf_)
    ok = TrackReferenceKeyFrame(&cur_, last_, *ref_kf_, R_gyro ? WithRotation(last_.T_cw, predicted.rotation()) : last_.T_cw,
                                camera_, pyramid());
  int inliers = 0;
  if (ok) {
    inliers = TrackLocalMap(&cur_, map_.get(), &ref_kf_, across_gap || cur_.id - last_reloc_frame_ < 3, options_,
                            camera_, pyramid());
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
  if (R_gyro) {
    ++gyro_stats_.predicted;
    if (!across_gap && inliers >= 2 * options_.min_tracked_inliers) UpdateGyroBias(*R_gyro);
  }
  // A velocity measured over a gap says little about the next interval.
  velocity_valid_ = !across_gap;
  velocity_ = cur_.T_cw * last_.T_cw.Inverse();
  velocity_dt_s_ = NsToSeconds(cur_.timestamp - last_.timestamp);
  // Outliers do not propagate to the next frame.
  for (size_t i = 0; i < cur_.points.size(); ++i)
    if (cur_.outlier[i]) { cur_.points[i] = nullptr; cur_.outlier[i] = false; }
  inserter_.Tracked(inliers);
  if (inserter_.Need(cur_, inliers, ref_kf_, *map_, *mapper_, frame_interval_s_)) {
    ref_kf_ = inserter_.Insert(cur_, last_inliers_, map_.get(), mapper_.get());
    kf_inserted_ = true;
    if (!options_.local_mapping_thread) {
      lock.unlock();
      mapper_->Drain();
    }
  }
  return true;
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
  for (KeyFrame* kf : relocalizer_.NextCandidates(*map_)) {
    if (!relocalizer_.Localize(&cur_, kf, options_.reloc_min_inliers, camera_, pyramid())) continue;
    ref_kf_ = kf;
    last_reloc_frame_ = cur_.id;
    const int inliers = TrackLocalMap(&cur_, map_.get(), &ref_kf_, true, options_, camera_, pyramid());
    last_inliers_ = inliers;
    inserter_.Relocalised(inliers);
    if (inliers < options_.reloc_min_inliers) continue;
    for (size_t i = 0; i < cur_.points.size(); ++i)
      if (cur_.outlier[i]) { cur_.points[i] = nullptr; cur_.outlier[i] = false; }
    spdlog::info("front: relocalised at {} against keyframe {} ({} inliers)", FormatSeconds(cur_.timestamp), kf->id, inliers);
    state_ = TrackingState::kTracking;
    velocity_valid_ = false;
    return true;
  }
  cur_.Reset(cur_.f->size());
  return false;
}

void Front::FinishSubmap(bool keep) {
  mapper_->Stop();
  {
    std::lock_guard<std::mutex> l(map_->mutex);
    if (keep && map_->NumGoodKeyFrames() >= 2) {
      Submap s = ExportCurrent();
      spdlog::info("front: submap {} finished: {} keyframes, {} points, {} frames", s.id, s.keyframes.size(),
                   s.points.size(), s.frames.size());
      finished_.push_back(std::move(s));
    }
  }
  submap_frames_.clear();
  ref_kf_ = nullptr;
  velocity_valid_ = false;
  anchor_ = Anchor();
  last_.points.clear();
  last_.outlier.clear();
  initializer_.Reset();
  mapper_.reset();
  map_ = std::make_unique<Map>();
  mapper_ = std::make_unique<LocalMapper>(map_.get(), camera_, pyramid(), options_);
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
  return ExportCurrent();
}

Submap Front::ExportCurrent() const {
  Submap s = map_->Export(submap_id_, camera_);
  for (const FrameRel& fr : submap_frames_) {
    FrameRecord r = fr.rec;
    if (r.state == TrackingState::kTracking && fr.ref) r.T_wc = (fr.T_c_ref * fr.ref->PoseFollowingParents()).Inverse();
    s.frames.push_back(r);
  }
  if (!poses_.empty())
    for (const FrameRecord& r : s.frames)
      if (const auto T = poses_.At(r.timestamp)) s.odometry.push_back({r.timestamp, *T});
  return s;
}

}  // namespace rumi
