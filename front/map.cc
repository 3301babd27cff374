#include "front/map.h"

#include <algorithm>
#include <cmath>

#include "common/orb_extractor.h"

namespace rumi {

void Features::BuildGrid(int cols, int rows) {
  grid_cols = std::max(1, cols);
  grid_rows = std::max(1, rows);
  cell_w = (max_x - min_x) / grid_cols;
  cell_h = (max_y - min_y) / grid_rows;
  grid.assign(grid_cols * grid_rows, {});
  for (int i = 0; i < static_cast<int>(un.size()); ++i) {
    const int cx = static_cast<int>((un[i].x() - min_x) / cell_w);
    const int cy = static_cast<int>((un[i].y() - min_y) / cell_h);
    if (cx < 0 || cy < 0 || cx >= grid_cols || cy >= grid_rows) continue;
    grid[cy * grid_cols + cx].push_back(i);
  }
}

std::vector<int> Features::InArea(double x, double y, double r, int min_level, int max_level) const {
  std::vector<int> out;
  const int x0 = std::max(0, static_cast<int>(std::floor((x - r - min_x) / cell_w)));
  const int x1 = std::min(grid_cols - 1, static_cast<int>(std::floor((x + r - min_x) / cell_w)));
  const int y0 = std::max(0, static_cast<int>(std::floor((y - r - min_y) / cell_h)));
  const int y1 = std::min(grid_rows - 1, static_cast<int>(std::floor((y + r - min_y) / cell_h)));
  if (x0 > x1 || y0 > y1) return out;
  for (int cy = y0; cy <= y1; ++cy) {
    for (int cx = x0; cx <= x1; ++cx) {
      for (int i : grid[cy * grid_cols + cx]) {
        const int lvl = keypoints[i].octave;
        if (min_level >= 0 && lvl < min_level) continue;
        if (max_level >= 0 && lvl > max_level) continue;
        if (std::abs(un[i].x() - x) < r && std::abs(un[i].y() - y) < r) out.push_back(i);
      }
    }
  }
  return out;
}

ScalePyramid::ScalePyramid(int levels, double factor) : num_levels(levels), scale_factor(factor) {
  for (int l = 0; l < levels; ++l) {
    const double s = std::pow(factor, l);
    scales.push_back(s);
    sigma2.push_back(s * s);
    inv_sigma2.push_back(1.0 / (s * s));
  }
}

int Landmark::PredictLevel(double dist, const ScalePyramid& pyr) const {
  if (dist <= 0) return 0;
  const double ratio = max_dist / dist;
  int l = static_cast<int>(std::ceil(std::log(ratio) / std::log(pyr.scale_factor)));
  return std::clamp(l, 0, pyr.num_levels - 1);
}

std::vector<KeyFrame*> KeyFrame::BestCovisibles(int n) const {
  if (static_cast<int>(ordered_covis.size()) <= n) return ordered_covis;
  return std::vector<KeyFrame*>(ordered_covis.begin(), ordered_covis.begin() + n);
}

int KeyFrame::TrackedPoints(int min_obs) const {
  int n = 0;
  for (Landmark* p : points)
    if (p && !p->bad && static_cast<int>(p->obs.size()) >= min_obs) ++n;
  return n;
}

double KeyFrame::MedianDepth() const {
  std::vector<double> z;
  const Eigen::Matrix3d R = T_cw.R();
  for (Landmark* p : points)
    if (p && !p->bad) z.push_back(R.row(2).dot(p->pos) + T_cw.translation().z());
  if (z.empty()) return 1.0;
  std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
  return z[z.size() / 2];
}

KeyFrame* Map::NewKeyFrame(Timestamp t, int64_t frame_id, std::shared_ptr<const Features> f, const Se3& T_cw) {
  auto kf = std::make_unique<KeyFrame>();
  kf->id = next_kf_id_++;
  kf->timestamp = t;
  kf->frame_id = frame_id;
  kf->T_cw = T_cw;
  kf->points.assign(f->size(), nullptr);
  kf->f = std::move(f);
  KeyFrame* raw = kf.get();
  keyframes[raw->id] = std::move(kf);
  return raw;
}

Landmark* Map::NewPoint(const Eigen::Vector3d& pos, KeyFrame* ref) {
  auto p = std::make_unique<Landmark>();
  p->id = next_point_id_++;
  p->pos = pos;
  p->ref_kf = ref;
  p->first_kf_id = ref ? ref->id : 0;
  Landmark* raw = p.get();
  points[raw->id] = std::move(p);
  return raw;
}

int Map::NumGoodKeyFrames() const {
  int n = 0;
  for (const auto& [id, kf] : keyframes) n += kf->bad ? 0 : 1;
  return n;
}

void Map::AddObservation(Landmark* p, KeyFrame* kf, int idx) {
  p->obs[kf] = idx;
  kf->points[idx] = p;
}

void Map::EraseObservation(Landmark* p, KeyFrame* kf) {
  auto it = p->obs.find(kf);
  if (it == p->obs.end()) return;
  if (kf->points[it->second] == p) kf->points[it->second] = nullptr;
  p->obs.erase(it);
  if (p->ref_kf == kf && !p->obs.empty()) p->ref_kf = p->obs.begin()->first;
  if (p->obs.size() < 2) SetBad(p);
}

void Map::SetBad(Landmark* p) {
  if (p->bad) return;
  p->bad = true;
  for (auto& [kf, idx] : p->obs)
    if (kf->points[idx] == p) kf->points[idx] = nullptr;
  p->obs.clear();
}

Se3 KeyFrame::PoseFollowingParents() const {
  Se3 rel;
  const KeyFrame* k = this;
  for (int hops = 0; k->bad && k->parent && hops < 1000; ++hops) {
    rel = rel * k->T_rel_parent;
    k = k->parent;
  }
  return rel * k->T_cw;
}

size_t Map::PurgeCulled() {
  size_t freed = 0;
  auto old = [&](int64_t* seen_at) {
    if (*seen_at < 0) *seen_at = frame_counter;
    return *seen_at <= frame_counter - 2;
  };
  for (auto it = points.begin(); it != points.end();) {
    if (it->second->bad && old(&it->second->bad_seen_at)) {
      it = points.erase(it);
      ++freed;
    } else {
      ++it;
    }
  }
  for (auto& [id, kf] : keyframes) {
    if (!kf->bad || !kf->f || !old(&kf->bad_seen_at)) continue;
    kf->f.reset();
    std::vector<Landmark*>().swap(kf->points);
    ++freed;
  }
  return freed;
}

void Map::SetBad(KeyFrame* kf) {
  if (kf->bad || kf->fixed) return;
  for (KeyFrame* c : kf->ordered_covis)
    if (!c->bad) {
      kf->parent = c;
      kf->T_rel_parent = kf->T_cw * c->T_cw.Inverse();
      break;
    }
  kf->bad = true;
  for (auto& [other, w] : kf->covis) {
    other->covis.erase(kf);
    auto& oc = other->ordered_covis;
    oc.erase(std::remove(oc.begin(), oc.end(), kf), oc.end());
  }
  kf->covis.clear();
  kf->ordered_covis.clear();
  for (Landmark*& p : kf->points) {
    if (!p) continue;
    Landmark* q = p;
    p = nullptr;
    q->obs.erase(kf);
    if (q->ref_kf == kf && !q->obs.empty()) q->ref_kf = q->obs.begin()->first;
    if (q->obs.size() < 2) SetBad(q);
  }
}

void Map::Replace(Landmark* p, Landmark* q) {
  if (p == q || p->bad || q->bad) return;
  for (auto& [kf, idx] : p->obs) {
    if (q->obs.count(kf)) {
      kf->points[idx] = nullptr;
    } else {
      kf->points[idx] = q;
      q->obs[kf] = idx;
    }
  }
  q->visible += p->visible;
  q->found += p->found;
  p->obs.clear();
  p->bad = true;
  ComputeDescriptor(q);
}

void Map::UpdateNormalAndDepth(Landmark* p, const ScalePyramid& pyr) {
  if (p->bad || p->obs.empty() || !p->ref_kf) return;
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  for (auto& [kf, idx] : p->obs) n += (p->pos - kf->Centre()).normalized();
  p->normal = n.normalized();
  auto it = p->obs.find(p->ref_kf);
  if (it == p->obs.end()) return;
  const double dist = (p->pos - p->ref_kf->Centre()).norm();
  const int level = p->ref_kf->f->keypoints[it->second].octave;
  p->max_dist = dist * pyr.scales[level];
  p->min_dist = p->max_dist / pyr.scales[pyr.num_levels - 1];
}

void Map::ComputeDescriptor(Landmark* p) {
  // Representative descriptor: the one with the least median distance to the
  // rest, among the 12 newest views. The newest views look most like the next
  // frames (a turn changes a point's appearance); taking the oldest ones lost
  // matches in turns and froze the translation (docs/results/2026-11-29-front-order.md).
  std::vector<cv::Mat> d;
  for (auto it = p->obs.rbegin(); it != p->obs.rend() && d.size() < 12; ++it)
    if (!it->first->bad) d.push_back(it->first->f->descriptors.row(it->second));
  if (d.empty()) return;
  const size_t n = d.size();
  int best = 0, best_med = 1 << 30;
  std::vector<int> dist(n);
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = 0; j < n; ++j) dist[j] = DescriptorDistance(d[i], d[j]);
    std::nth_element(dist.begin(), dist.begin() + (n - 1) / 2, dist.end());
    if (dist[(n - 1) / 2] < best_med) {
      best_med = dist[(n - 1) / 2];
      best = static_cast<int>(i);
    }
  }
  p->descriptor = d[best].clone();
}

void Map::UpdateConnections(KeyFrame* kf) {
  std::map<KeyFrame*, int, ById> counts;
  for (Landmark* p : kf->points) {
    if (!p || p->bad) continue;
    for (auto& [other, idx] : p->obs)
      if (other != kf && !other->bad) ++counts[other];
  }
  // Drop old links, then keep those with >= 15 shared points (or the best one).
  for (auto& [other, w] : kf->covis) {
    other->covis.erase(kf);
  }
  kf->covis.clear();
  KeyFrame* best = nullptr;
  int best_w = 0;
  for (auto& [other, w] : counts) {
    if (w > best_w) { best_w = w; best = other; }
    if (w >= 15) { kf->covis[other] = w; other->covis[kf] = w; }
  }
  if (kf->covis.empty() && best) { kf->covis[best] = best_w; best->covis[kf] = best_w; }
  auto order = [](KeyFrame* k) {
    std::vector<std::pair<int, KeyFrame*>> v;
    for (auto& [o, w] : k->covis) v.push_back({w, o});
    std::sort(v.begin(), v.end(), [](auto& a, auto& b) { return a.first > b.first || (a.first == b.first && a.second->id > b.second->id); });
    k->ordered_covis.clear();
    for (auto& e : v) k->ordered_covis.push_back(e.second);
  };
  order(kf);
  for (auto& [o, w] : kf->covis) order(o);
}

Submap Map::Export(int64_t submap_id, const PinholeCamera& cam) const {
  Submap s;
  s.id = submap_id;
  s.source = SubmapSource::kFront;
  s.camera = {cam.width(), cam.height(), cam.fx(), cam.fy(), cam.cx(), cam.cy()};
  std::map<const Landmark*, bool, ById> exported;
  for (const auto& [id, p] : points) exported[p.get()] = !p->bad && p->obs.size() >= 2;
  for (const auto& [id, kf] : keyframes) {
    if (kf->bad) continue;
    Keyframe k;
    k.id = kf->id;
    k.timestamp = kf->timestamp;
    k.T_cw = kf->T_cw;
    const Features& f = *kf->f;
    k.keypoints.reserve(f.size());
    k.octaves.reserve(f.size());
    for (size_t i = 0; i < f.size(); ++i) {
      k.keypoints.emplace_back(static_cast<float>(f.un[i].x()), static_cast<float>(f.un[i].y()));
      k.octaves.push_back(static_cast<uint8_t>(f.keypoints[i].octave));
    }
    k.descriptors = f.descriptors.clone();
    k.point_ids.assign(f.size(), -1);
    for (size_t i = 0; i < f.size(); ++i) {
      const Landmark* p = kf->points[i];
      if (p && exported[p]) k.point_ids[i] = p->id;
    }
    s.keyframes.push_back(std::move(k));
  }
  std::sort(s.keyframes.begin(), s.keyframes.end(),
            [](const Keyframe& a, const Keyframe& b) { return a.timestamp < b.timestamp; });
  for (const auto& [id, p] : points) {
    if (!exported[p.get()]) continue;
    rumi::MapPoint q;
    q.id = p->id;
    q.position = p->pos;
    q.descriptor = p->descriptor.clone();
    for (const auto& [kf, idx] : p->obs)
      if (!kf->bad) q.observations.push_back({kf->id, idx});
    s.points.push_back(std::move(q));
  }
  return s;
}

}  // namespace rumi
