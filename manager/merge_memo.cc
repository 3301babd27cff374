#include "manager/merge_memo.h"

#include <algorithm>

#include "common/logging.h"
#include "manager/place_merge.h"

namespace rumi {
namespace {

// FNV-1a, 64 bit.
class Hasher {
 public:
  void Bytes(const void* data, size_t n) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < n; ++i) {
      h_ ^= b[i];
      h_ *= 1099511628211ull;
    }
  }
  template <typename T>
  void Add(T v) {
    static_assert(std::is_arithmetic_v<T>);
    Bytes(&v, sizeof v);
  }
  template <typename T>
  void AddArray(const std::vector<T>& v, size_t bytes_per_element = sizeof(T)) {
    Add(v.size());
    if (!v.empty()) Bytes(v.data(), v.size() * bytes_per_element);
  }
  void Add(const Se3& T) {
    Bytes(T.translation().data(), 3 * sizeof(double));
    Bytes(T.rotation().coeffs().data(), 4 * sizeof(double));
  }
  uint64_t value() const { return h_ == 0 ? 1 : h_; }  // 0 means "not computed"

 private:
  uint64_t h_ = 14695981039346656037ull;
};

}  // namespace

uint64_t MergeMemo::KeyHash(const Key& key) {
  Hasher h;
  h.Add(std::get<0>(key));
  h.Add(std::get<1>(key));
  h.Add(std::get<2>(key));
  h.Add(std::get<3>(key));
  return h.value();
}

uint64_t KeyframePoseFingerprint(const Submap& s) {
  Hasher h;
  h.Add(s.keyframes.size());
  for (const Keyframe& kf : s.keyframes) {
    h.Add(kf.id);
    h.Add(kf.T_cw);
  }
  return h.value();
}

uint64_t SubmapFingerprint(const Submap& s) {
  Hasher h;
  h.Add(int(s.source));
  h.Add(s.id);
  for (double v : {s.camera.fx, s.camera.fy, s.camera.cx, s.camera.cy}) h.Add(v);
  h.Add(s.keyframes.size());
  for (const Keyframe& kf : s.keyframes) {
    h.Add(kf.id);
    h.Add(kf.timestamp);
    h.Add(kf.T_cw);
    static_assert(sizeof(Eigen::Vector2f) == 2 * sizeof(float));
    h.AddArray(kf.keypoints);
    h.AddArray(kf.octaves);
    h.AddArray(kf.point_ids);
  }
  h.Add(s.points.size());
  for (const MapPoint& p : s.points) {
    h.Add(p.id);
    h.Bytes(p.position.data(), 3 * sizeof(double));
    h.Add(p.observations.size());
    for (const MapPoint::Observation& o : p.observations) {
      h.Add(o.keyframe_id);
      h.Add(o.keypoint_index);
    }
  }
  h.Add(s.frames.size());
  for (const FrameRecord& f : s.frames) {
    h.Add(f.timestamp);
    h.Add(int(f.state));
    h.Add(f.submap_id);
    h.Add(f.T_wc);
  }
  h.Add(s.odometry.size());
  for (const OdometryPose& o : s.odometry) {
    h.Add(o.timestamp);
    h.Add(o.T_wb);
  }
  return h.value();
}

namespace {
bool Same(const Se3& a, const Se3& b) {
  return a.translation() == b.translation() && a.rotation().coeffs() == b.rotation().coeffs();
}
bool Same(const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return a == b; }

// Keeps the entries of `v` (index, value before) whose value in `after`
// differs, with the value after. False when the counts differ.
template <typename T, typename Get>
bool KeepChanged(std::vector<std::pair<int32_t, T>>* v, size_t count, Get get) {
  if (v->size() != count) return false;
  size_t n = 0;
  for (auto& [i, x] : *v) {
    const T& now = get(size_t(i));
    if (Same(x, now)) continue;
    (*v)[n++] = {i, now};
  }
  v->resize(n);
  v->shrink_to_fit();
  return true;
}
}  // namespace

void SubmapEdit::Begin(const Submap& s) {
  keyframe_poses.clear();
  point_positions.clear();
  frame_poses.clear();
  for (size_t i = 0; i < s.keyframes.size(); ++i) keyframe_poses.emplace_back(int32_t(i), s.keyframes[i].T_cw);
  for (size_t i = 0; i < s.points.size(); ++i) point_positions.emplace_back(int32_t(i), s.points[i].position);
  for (size_t i = 0; i < s.frames.size(); ++i) frame_poses.emplace_back(int32_t(i), s.frames[i].T_wc);
}

bool SubmapEdit::Finish(const Submap& s) {
  return KeepChanged(&keyframe_poses, s.keyframes.size(), [&](size_t i) -> const Se3& { return s.keyframes[i].T_cw; }) &&
         KeepChanged(&point_positions, s.points.size(),
                     [&](size_t i) -> const Eigen::Vector3d& { return s.points[i].position; }) &&
         KeepChanged(&frame_poses, s.frames.size(), [&](size_t i) -> const Se3& { return s.frames[i].T_wc; });
}

void SubmapEdit::Apply(Submap* s) const {
  for (const auto& [i, T] : keyframe_poses) s->keyframes[size_t(i)].T_cw = T;
  for (const auto& [i, X] : point_positions) s->points[size_t(i)].position = X;
  for (const auto& [i, T] : frame_poses) s->frames[size_t(i)].T_wc = T;
}

void MergeMemo::StartFingerprints(const GlobalMap& map) {
  if (content_.size() == map.size()) fingerprint_ = std::move(content_);
  else fingerprint_.assign(map.size(), 0);
  content_.clear();
}

void MergeMemo::BeginRun(const GlobalMap& map, const SearchSet& search, int64_t max_dt_ns) {
  StartFingerprints(map);
  chained_ = true;
  membership_.assign(map.size(), 0);
  for (auto it = used_.begin(); it != used_.end();) it = std::get<0>(*it) == kBackMerge ? used_.erase(it) : std::next(it);
  hits_ = misses_ = 0;
  // Which of a back submap's keyframes are in F^search: all that pairing
  // reads of the search set.
  for (size_t i = 0; i < map.size(); ++i) {
    const Submap& s = map.submap(int(i));
    if (s.source != SubmapSource::kBack) continue;
    std::vector<Timestamp> t;
    for (const Keyframe& kf : s.keyframes) t.push_back(kf.timestamp);
    std::sort(t.begin(), t.end());
    Hasher h;
    for (Timestamp ts : t) {
      h.Add(ts);
      h.Add(int(search.Contains(ts, max_dt_ns)));
    }
    membership_[i] = h.value();
  }
}

uint64_t MergeMemo::Fingerprint(const GlobalMap& map, int i) {
  if (fingerprint_[i] == 0) fingerprint_[i] = SubmapFingerprint(map.submap(i));
  return fingerprint_[i];
}

template <typename Compute>
MergeReport MergeMemo::Attempt(GlobalMap* map, int front, int other, const Key& key, Compute compute) {
  used_.insert(key);
  const auto it = entries_.find(key);
  if (it != entries_.end()) {
    ++hits_;
    const Entry& e = it->second;
    MergeReport r = e.report;
    r.replayed = true;
    if (!r.merged) {
      spdlog::debug("{} <-> {} rejected (as in an earlier rebuild): {}", ToString(r.front), ToString(r.back), r.reason);
      return r;
    }
    r.front_moved = JoinComponents(map, front, other, r.S_bf);
    e.front_edit.Apply(&map->submap(front));
    for (const auto& [f, b] : e.fused) map->fused().push_back({front, f, other, b});
    fingerprint_[front] = KeyHash(key);
    spdlog::info("merged {} with {} as in an earlier rebuild (neither changed): {} common points, {} fused",
                 ToString(r.front), ToString(r.back), r.common_points, r.fused_points);
    return r;
  }
  ++misses_;
  const size_t fused_before = map->fused().size();
  Entry e;
  e.front_edit.Begin(map->submap(front));
  e.report = compute();
  if (e.report.merged) {
    fingerprint_[front] = KeyHash(key);
    if (!e.front_edit.Finish(map->submap(front))) {
      fingerprint_[front] = 0;
      spdlog::warn("merge memo: merging {} changed more than poses and positions; not kept",
                   ToString(e.report.front));
      used_.erase(key);
      entries_.erase(key);
      return e.report;
    }
    for (size_t k = fused_before; k < map->fused().size(); ++k)
      e.fused.emplace_back(map->fused()[k].dup_point, map->fused()[k].kept_point);
  } else {
    e.front_edit = SubmapEdit();
  }
  return entries_.insert_or_assign(key, std::move(e)).first->second.report;
}

MergeReport MergeMemo::Merge(GlobalMap* map, int front, int back, const SearchSet& search,
                             const ManagerOptions& options) {
  if (map->Connected(front, back)) return MergePair(map, front, back, search, options);
  const Key key{kBackMerge, Fingerprint(*map, front), Fingerprint(*map, back), membership_[back]};
  return Attempt(map, front, back, key, [&] { return MergePair(map, front, back, search, options); });
}

void MergeMemo::BeginPlaceRun(const GlobalMap& map) {
  if (!chained_ || fingerprint_.size() != map.size()) StartFingerprints(map);
  chained_ = false;
  for (auto it = used_.begin(); it != used_.end();) it = std::get<0>(*it) == kPlaceMerge ? used_.erase(it) : std::next(it);
}

MergeReport MergeMemo::Place(GlobalMap* map, int a, int b, const ManagerOptions& options) {
  if (map->Connected(a, b)) return PlaceMergePair(map, a, b, options);
  const Key key{kPlaceMerge, Fingerprint(*map, a), Fingerprint(*map, b), 0};
  return Attempt(map, a, b, key, [&] { return PlaceMergePair(map, a, b, options); });
}

void MergeMemo::Drop(Kind kind) {
  for (auto it = entries_.begin(); it != entries_.end();)
    it = std::get<0>(it->first) == kind && !used_.count(it->first) ? entries_.erase(it) : std::next(it);
}

void MergeMemo::EndRun() { Drop(kBackMerge); }
void MergeMemo::EndPlaceRun() { Drop(kPlaceMerge); }

}  // namespace rumi
