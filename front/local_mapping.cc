#include "front/local_mapping.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <spdlog/spdlog.h>

#include "front/initializer.h"
#include "front/matcher.h"
#include "front/optimizer.h"

namespace rumi {
namespace {
double CpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}
}  // namespace

LocalMapper::LocalMapper(Map* map, const PinholeCamera& cam, const ScalePyramid& pyr, const FrontOptions& o)
    : map_(map), cam_(cam), pyr_(pyr), o_(o) {}

LocalMapper::~LocalMapper() { Stop(); }

void LocalMapper::Start() {
  if (o_.local_mapping_thread && !thread_.joinable()) thread_ = std::thread([this] { Run(); });
}

void LocalMapper::Stop() {
  {
    std::lock_guard<std::mutex> l(qm_);
    stop_ = true;
    abort_ba_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void LocalMapper::Push(KeyFrame* kf) {
  {
    std::lock_guard<std::mutex> l(qm_);
    queue_.push_back(kf);
    abort_ba_ = true;  // a new keyframe preempts a running BA
  }
  cv_.notify_one();
}

size_t LocalMapper::QueueSize() const {
  std::lock_guard<std::mutex> l(qm_);
  return queue_.size();
}

void LocalMapper::Drain() {
  while (true) {
    KeyFrame* kf = nullptr;
    {
      std::lock_guard<std::mutex> l(qm_);
      if (queue_.empty()) return;
      kf = queue_.front();
      queue_.pop_front();
      abort_ba_ = false;
    }
    Process(kf);
  }
}

void LocalMapper::Run() {
  while (true) {
    KeyFrame* kf = nullptr;
    {
      std::unique_lock<std::mutex> l(qm_);
      idle_ = true;
      cv_.wait(l, [&] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      kf = queue_.front();
      queue_.pop_front();
      idle_ = false;
      abort_ba_ = false;
    }
    Process(kf);
  }
}

void LocalMapper::Process(KeyFrame* kf) {
  const double c0 = CpuMs();
  double c_tri = 0, c_fuse = 0, c_ba = 0;
  {
    std::lock_guard<std::mutex> l(map_->mutex);
    if (kf->bad) return;
    for (size_t i = 0; i < kf->points.size(); ++i) {
      Landmark* p = kf->points[i];
      if (!p || p->bad) continue;
      Map::UpdateNormalAndDepth(p, pyr_);
      Map::ComputeDescriptor(p);
    }
    Map::UpdateConnections(kf);
    CullPoints(kf);
  }
  if (stop_) return;
  const size_t before = map_->points.size();
  c_tri = CpuMs();
  Triangulate(kf);
  c_tri = CpuMs() - c_tri;
  if (stop_) return;
  c_fuse = CpuMs();
  if (QueueSize() == 0) FuseNeighbours(kf);
  c_fuse = CpuMs() - c_fuse;
  // Behind (keyframes queued): skip BA to catch up, but never for more than
  // o_.max_ba_skips keyframes in a row. Without BA the young keyframes keep
  // their tracking poses and the low-parallax points of a turn, and the
  // scale drifts away (seen on `smooth` in realtime on a loaded machine).
  if (stop_) return;
  if (QueueSize() > 0 && ba_skipped_ < o_.max_ba_skips) {
    ++ba_skipped_;
    ++processed_;
    spdlog::debug("mapping: kf {} t {} q {} {:+d} points, behind: BA skipped", kf->id, FormatSeconds(kf->timestamp),
                  QueueSize(), static_cast<int64_t>(map_->points.size()) - static_cast<int64_t>(before));
    return;
  }
  // A forced BA (queue not empty) is not preempted by new keyframes, only
  // bounded by local_ba_iterations / local_ba_max_time_s.
  const bool forced = QueueSize() > 0;
  ba_skipped_ = 0;
  // Local BA: collect under the lock, solve on the copy, write back.
  LocalBaProblem pb;
  {
    std::lock_guard<std::mutex> l(map_->mutex);
    if (map_->NumGoodKeyFrames() > 2) CollectLocalBa(kf, o_.local_ba_max_keyframes, o_.local_ba_max_fixed, &pb);
  }
  c_ba = CpuMs();
  if (!pb.obs.empty()) {
    if (SolveLocalBa(&pb, cam_, pyr_, o_.local_ba_iterations, o_.local_ba_max_time_s, forced ? &stop_ : &abort_ba_)) {
      std::lock_guard<std::mutex> l(map_->mutex);
      ApplyLocalBa(pb, cam_, pyr_);
    }
  }
  c_ba = CpuMs() - c_ba;
  {
    std::lock_guard<std::mutex> l(map_->mutex);
    CullKeyFrames(kf);
    // Fusion, BA and keyframe culling may have culled young points: drop
    // them from recent_ before they are freed.
    recent_.erase(std::remove_if(recent_.begin(), recent_.end(), [](const Landmark* p) { return p->bad; }),
                  recent_.end());
    map_->PurgeCulled();
  }
  ++processed_;
  spdlog::debug("mapping: kf {} t {} q {} {:+d} points{}, cpu {:.1f} ms (triangulate {:.1f}, fuse {:.1f}, BA {:.1f} with {} kfs {} fixed {} obs)",
                kf->id, FormatSeconds(kf->timestamp), QueueSize(),
                static_cast<int64_t>(map_->points.size()) - static_cast<int64_t>(before), forced ? " (forced BA)" : "", CpuMs() - c0, c_tri, c_fuse, c_ba, pb.local.size(), pb.fixed.size(), pb.obs.size());
}

void LocalMapper::CullPoints(KeyFrame* kf) {
  // Young points must be found where predicted and be seen by a few keyframes.
  const int64_t cur = kf->id;
  std::vector<Landmark*> keep;
  for (Landmark* p : recent_) {
    if (p->bad) continue;
    if (p->FoundRatio() < 0.25) { Map::SetBad(p); continue; }
    if (cur - p->first_kf_id >= 2 && p->obs.size() <= 2) { Map::SetBad(p); continue; }
    if (cur - p->first_kf_id >= 3) continue;  // mature
    keep.push_back(p);
  }
  recent_ = std::move(keep);
}

void LocalMapper::Triangulate(KeyFrame* kf) {
  std::vector<KeyFrame*> neigh;
  {
    std::lock_guard<std::mutex> l(map_->mutex);
    neigh = kf->BestCovisibles(o_.triangulation_neighbours);
    // Few covisible keyframes (young map): add the most recent ones.
    for (auto it = map_->keyframes.rbegin(); it != map_->keyframes.rend() &&
                                             static_cast<int>(neigh.size()) < o_.triangulation_neighbours; ++it) {
      KeyFrame* k = it->second.get();
      if (k != kf && !k->bad && std::find(neigh.begin(), neigh.end(), k) == neigh.end()) neigh.push_back(k);
    }
  }
  const double ratio_factor = 1.5 * pyr_.scale_factor;
  int done = 0;
  for (KeyFrame* k2 : neigh) {
    // Behind (keyframes queued): stop early, but not before a few neighbours,
    // since the best covisible one often has the smallest baseline and points
    // from it alone are poorly conditioned.
    if (stop_ || (QueueSize() > 0 && done >= 4)) break;
    ++done;
    std::lock_guard<std::mutex> l(map_->mutex);  // one neighbour per lock
    if (k2->bad || kf->bad) continue;
    const Eigen::Vector3d O1 = kf->Centre(), O2 = k2->Centre();
    const double baseline = (O2 - O1).norm();
    if (baseline / k2->MedianDepth() < 0.01) continue;
    const auto pairs = SearchForTriangulation(*kf, *k2, cam_, pyr_);
    const Eigen::Matrix3d R1 = kf->T_cw.R(), R2 = k2->T_cw.R();
    const Eigen::Vector3d t1 = kf->T_cw.translation(), t2 = k2->T_cw.translation();
    Eigen::Matrix<double, 3, 4> P1, P2;
    P1 << R1, t1;
    P2 << R2, t2;
    for (auto [i1, i2] : pairs) {
      if (kf->points[i1] || k2->points[i2]) continue;
      const Eigen::Vector3d r1 = UndistortedRay(cam_, kf->f->un[i1]), r2 = UndistortedRay(cam_, k2->f->un[i2]);
      const double cos_par = (R1.transpose() * r1).normalized().dot((R2.transpose() * r2).normalized());
      if (cos_par <= 0 || cos_par > 0.9998) continue;
      const Eigen::Vector3d X = TriangulateDlt(P1, P2, r1.head<2>(), r2.head<2>());
      if (!X.allFinite()) continue;
      const Eigen::Vector3d x1 = R1 * X + t1, x2 = R2 * X + t2;
      if (x1.z() <= 0 || x2.z() <= 0) continue;
      const int l1 = kf->f->keypoints[i1].octave, l2 = k2->f->keypoints[i2].octave;
      if ((ProjectUndistorted(cam_, x1) - kf->f->un[i1]).squaredNorm() * pyr_.inv_sigma2[l1] > 5.991) continue;
      if ((ProjectUndistorted(cam_, x2) - k2->f->un[i2]).squaredNorm() * pyr_.inv_sigma2[l2] > 5.991) continue;
      const double d1 = (X - O1).norm(), d2 = (X - O2).norm();
      const double ratio_dist = d2 / d1, ratio_oct = pyr_.scales[l1] / pyr_.scales[l2];
      if (ratio_dist * ratio_factor < ratio_oct || ratio_dist > ratio_oct * ratio_factor) continue;
      Landmark* p = map_->NewPoint(X, kf);
      Map::AddObservation(p, kf, i1);
      Map::AddObservation(p, k2, i2);
      Map::ComputeDescriptor(p);
      Map::UpdateNormalAndDepth(p, pyr_);
      recent_.push_back(p);
    }
  }
}

void LocalMapper::FuseNeighbours(KeyFrame* kf) {
  std::lock_guard<std::mutex> l(map_->mutex);
  if (kf->bad) return;
  std::vector<KeyFrame*> targets = kf->BestCovisibles(o_.triangulation_neighbours);
  std::vector<KeyFrame*> second;
  for (KeyFrame* k : targets)
    for (KeyFrame* k2 : k->BestCovisibles(5))
      if (k2 != kf && !k2->bad && std::find(targets.begin(), targets.end(), k2) == targets.end() &&
          std::find(second.begin(), second.end(), k2) == second.end())
        second.push_back(k2);
  targets.insert(targets.end(), second.begin(), second.end());
  std::vector<Landmark*> own;
  for (Landmark* p : kf->points) if (p && !p->bad) own.push_back(p);
  for (KeyFrame* k : targets) if (!k->bad) Fuse(k, own, cam_, pyr_, 3.0);
  std::vector<Landmark*> theirs;
  for (KeyFrame* k : targets)
    for (Landmark* p : k->points)
      if (p && !p->bad && !p->obs.count(kf)) theirs.push_back(p);
  std::sort(theirs.begin(), theirs.end(), ById());
  theirs.erase(std::unique(theirs.begin(), theirs.end()), theirs.end());
  Fuse(kf, theirs, cam_, pyr_, 3.0);
  for (Landmark* p : kf->points) {
    if (!p || p->bad) continue;
    Map::ComputeDescriptor(p);
    Map::UpdateNormalAndDepth(p, pyr_);
  }
  Map::UpdateConnections(kf);
}

void LocalMapper::CullKeyFrames(KeyFrame* kf) {
  // A keyframe whose points are mostly (kf_cull_redundancy) seen by >= 3 other
  // keyframes at the same or a finer scale is redundant.
  for (KeyFrame* k : kf->BestCovisibles(20)) {
    if (k->bad || k->fixed || k == kf) continue;
    if (kf->id - k->id < 2) continue;  // keep the newest for tracking
    int total = 0, redundant = 0;
    for (size_t i = 0; i < k->points.size(); ++i) {
      Landmark* p = k->points[i];
      if (!p || p->bad) continue;
      ++total;
      if (p->obs.size() <= 3) continue;
      const int lvl = k->f->keypoints[i].octave;
      int seen = 0;
      for (auto& [o, idx] : p->obs) {
        if (o == k || o->bad) continue;
        if (o->f->keypoints[idx].octave <= lvl + 1) ++seen;
        if (seen >= 3) break;
      }
      if (seen >= 3) ++redundant;
    }
    if (total > 0 && redundant > o_.kf_cull_redundancy * total) Map::SetBad(k);
  }
}

}  // namespace rumi
