#include "front/matcher.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "common/descriptor_match.h"
#include "common/orb_extractor.h"

namespace rumi {
namespace {

constexpr int kHistBins = 30;

// Keeps matches whose orientation change falls in the three most populated
// bins (rotation consistency); returns indices to drop.
class RotationHistogram {
 public:
  void Add(float angle1, float angle2, int idx) {
    float rot = angle1 - angle2;
    if (rot < 0) rot += 360.f;
    int bin = static_cast<int>(std::round(rot * kHistBins / 360.f));
    if (bin == kHistBins) bin = 0;
    hist_[bin].push_back(idx);
  }
  std::vector<int> Outliers() const {
    std::array<size_t, 3> top{0, 0, 0};
    std::array<int, 3> ind{-1, -1, -1};
    for (int i = 0; i < kHistBins; ++i) {
      const size_t s = hist_[i].size();
      if (s > top[0]) { top = {s, top[0], top[1]}; ind = {i, ind[0], ind[1]}; }
      else if (s > top[1]) { top = {top[0], s, top[1]}; ind = {ind[0], i, ind[1]}; }
      else if (s > top[2]) { top[2] = s; ind[2] = i; }
    }
    // Bins much weaker than the best are not kept.
    if (top[1] < 0.1 * top[0]) ind[1] = ind[2] = -1;
    if (top[2] < 0.1 * top[0]) ind[2] = -1;
    std::vector<int> out;
    for (int i = 0; i < kHistBins; ++i) {
      if (i == ind[0] || i == ind[1] || i == ind[2]) continue;
      out.insert(out.end(), hist_[i].begin(), hist_[i].end());
    }
    return out;
  }

 private:
  std::array<std::vector<int>, kHistBins> hist_;
};

}  // namespace

int TrackFrame::NumMatches() const {
  int n = 0;
  for (size_t i = 0; i < points.size(); ++i) n += (points[i] && !outlier[i]) ? 1 : 0;
  return n;
}

int SearchByProjection(TrackFrame* cur, const TrackFrame& last, const PinholeCamera& cam, const ScalePyramid& pyr,
                       double radius, bool check_rotation) {
  const Features& f = *cur->f;
  RotationHistogram hist;
  int n = 0;
  for (size_t i = 0; i < last.points.size(); ++i) {
    Landmark* p = last.points[i];
    if (!p || p->bad || last.outlier[i]) continue;
    const Eigen::Vector3d pc = cur->T_cw * p->pos;
    if (pc.z() <= 0) continue;
    const Eigen::Vector2d u = ProjectUndistorted(cam, pc);
    if (!f.InImage(u.x(), u.y())) continue;
    const int level = last.f->keypoints[i].octave;
    const double r = radius * pyr.scales[level];
    const auto cand = f.InArea(u.x(), u.y(), r, std::max(0, level - 1), level + 1);
    int best = 256, best_idx = -1;
    const uint8_t* pd = p->descriptor.ptr<uint8_t>();
    for (int j : cand) {
      if (cur->points[j] && !cur->points[j]->obs.empty()) continue;
      const int d = DescriptorDistance(pd, f.descriptors.ptr<uint8_t>(j));
      if (d < best) { best = d; best_idx = j; }
    }
    if (best_idx < 0 || best > kDescHigh) continue;
    cur->points[best_idx] = p;
    cur->outlier[best_idx] = false;
    ++n;
    if (check_rotation) hist.Add(last.f->keypoints[i].angle, f.keypoints[best_idx].angle, best_idx);
  }
  if (check_rotation) {
    for (int j : hist.Outliers()) { cur->points[j] = nullptr; --n; }
  }
  return n;
}

int SearchLocalPoints(TrackFrame* cur, const std::vector<Landmark*>& points, const PinholeCamera& cam, const ScalePyramid& pyr,
                      double radius) {
  const Features& f = *cur->f;
  const Eigen::Matrix3d R = cur->T_cw.R();
  const Eigen::Vector3d t = cur->T_cw.translation();
  const Eigen::Vector3d Ow = -(R.transpose() * t);
  int n = 0;
  for (Landmark* p : points) {
    if (p->bad || p->last_frame_seen == cur->id) continue;
    const Eigen::Vector3d pc = R * p->pos + t;
    if (pc.z() <= 0) continue;
    const Eigen::Vector2d u = ProjectUndistorted(cam, pc);
    if (!f.InImage(u.x(), u.y())) continue;
    const Eigen::Vector3d po = p->pos - Ow;
    const double dist = po.norm();
    if (dist < 0.8 * p->min_dist || dist > 1.2 * p->max_dist) continue;
    const double view_cos = po.dot(p->normal) / dist;
    if (view_cos < 0.5) continue;
    p->visible++;
    const int level = p->PredictLevel(dist, pyr);
    const double r = radius * (view_cos > 0.998 ? 2.5 : 4.0) * pyr.scales[level];
    const auto cand = f.InArea(u.x(), u.y(), r, level - 1, level);
    NearestTwo n2;
    const uint8_t* pd = p->descriptor.ptr<uint8_t>();
    for (int j : cand) {
      if (cur->points[j] && !cur->points[j]->obs.empty()) continue;
      n2.Add(DescriptorDistance(pd, f.descriptors.ptr<uint8_t>(j)), j);
    }
    if (n2.best_index < 0 || n2.best > kDescHigh) continue;
    // The ratio test only between candidates of one pyramid level.
    const auto octave = [&](int j) { return j < 0 ? -1 : f.keypoints[j].octave; };
    if (octave(n2.best_index) == octave(n2.second_index) && n2.best > 0.8 * n2.second) continue;
    cur->points[n2.best_index] = p;
    cur->outlier[n2.best_index] = false;
    ++n;
  }
  return n;
}

int SearchKeyFramePoints(TrackFrame* cur, const KeyFrame& kf, const PinholeCamera& cam, const ScalePyramid& pyr, double radius,
                         int max_desc, double ratio) {
  const Features& f = *cur->f;
  RotationHistogram hist;
  int n = 0;
  for (size_t i = 0; i < kf.points.size(); ++i) {
    Landmark* p = kf.points[i];
    if (!p || p->bad) continue;
    if (std::find(cur->points.begin(), cur->points.end(), p) != cur->points.end()) continue;
    const Eigen::Vector3d pc = cur->T_cw * p->pos;
    if (pc.z() <= 0) continue;
    const Eigen::Vector2d u = ProjectUndistorted(cam, pc);
    if (!f.InImage(u.x(), u.y())) continue;
    const int level = kf.f->keypoints[i].octave;
    const auto cand = f.InArea(u.x(), u.y(), radius * pyr.scales[level], level - 2, level + 2);
    NearestTwo n2;
    const uint8_t* pd = p->descriptor.ptr<uint8_t>();
    for (int j : cand) {
      if (cur->points[j]) continue;
      n2.Add(DescriptorDistance(pd, f.descriptors.ptr<uint8_t>(j)), j);
    }
    if (n2.best_index < 0 || n2.best > max_desc || n2.best > ratio * n2.second) continue;
    cur->points[n2.best_index] = p;
    cur->outlier[n2.best_index] = false;
    hist.Add(kf.f->keypoints[i].angle, f.keypoints[n2.best_index].angle, n2.best_index);
    ++n;
  }
  for (int j : hist.Outliers()) { cur->points[j] = nullptr; --n; }
  return n;
}

int SearchForInitialization(const Features& f1, const Features& f2,
                            std::vector<Eigen::Vector2d>* prev_matched, double radius,
                            std::vector<int>* m12) {
  m12->assign(f1.size(), -1);
  std::vector<int> dist21(f2.size(), 256), m21(f2.size(), -1);
  RotationHistogram hist;
  for (size_t i = 0; i < f1.size(); ++i) {
    const int level = f1.keypoints[i].octave;
    const Eigen::Vector2d& u = (*prev_matched)[i];
    const auto cand = f2.InArea(u.x(), u.y(), radius, level, level);
    int best = 256, second = 256, best_idx = -1;
    for (int j : cand) {
      const int d = DescriptorDistance(f1.descriptors.ptr<uint8_t>(static_cast<int>(i)), f2.descriptors.ptr<uint8_t>(j));
      if (dist21[j] <= d) continue;
      if (d < best) { second = best; best = d; best_idx = j; }
      else if (d < second) second = d;
    }
    if (best_idx < 0 || best > kDescLow || best >= 0.9 * second) continue;
    if (m21[best_idx] >= 0) (*m12)[m21[best_idx]] = -1;
    (*m12)[i] = best_idx;
    m21[best_idx] = static_cast<int>(i);
    dist21[best_idx] = best;
  }
  for (size_t i = 0; i < f1.size(); ++i)
    if ((*m12)[i] >= 0) hist.Add(f1.keypoints[i].angle, f2.keypoints[(*m12)[i]].angle, static_cast<int>(i));
  for (int i : hist.Outliers()) (*m12)[i] = -1;
  int n = 0;
  for (size_t i = 0; i < f1.size(); ++i) {
    if ((*m12)[i] < 0) continue;
    (*prev_matched)[i] = f2.un[(*m12)[i]];
    ++n;
  }
  return n;
}

std::vector<std::pair<int, int>> SearchForTriangulation(const KeyFrame& k1, const KeyFrame& k2,
                                                        const PinholeCamera& cam, const ScalePyramid& pyr) {
  std::vector<std::pair<int, int>> out;
  const Features& f1 = *k1.f;
  const Features& f2 = *k2.f;
  // Relative pose 2 <- 1 and fundamental matrix in pixels.
  const Se3 T21 = k2.T_cw * k1.T_cw.Inverse();
  const Eigen::Matrix3d R21 = T21.R();
  const Eigen::Vector3d t21 = T21.translation();
  Eigen::Matrix3d tx;
  tx << 0, -t21.z(), t21.y(), t21.z(), 0, -t21.x(), -t21.y(), t21.x(), 0;
  const Eigen::Matrix3d Kinv = PinholeMatrix(cam).inverse();
  const Eigen::Matrix3d F21 = Kinv.transpose() * tx * R21 * Kinv;
  // Epipole in image 2 (centre of camera 1).
  const Eigen::Vector3d c1in2 = t21;
  const bool epipole_ok = c1in2.z() > 1e-9;
  const Eigen::Vector2d ep = epipole_ok ? ProjectUndistorted(cam, c1in2) : Eigen::Vector2d(-1e9, -1e9);
  const double median = k1.MedianDepth();
  const double dmin = 0.2 * median, dmax = 50.0 * median;
  std::vector<char> used2(f2.size(), 0);
  for (size_t j = 0; j < f2.size(); ++j) used2[j] = k2.points[j] != nullptr;
  std::vector<int> match21(f2.size(), -1), dist21(f2.size(), 256);
  std::vector<int> m12(f1.size(), -1);
  std::vector<int> stamp(f2.grid.size(), -1);
  RotationHistogram hist;
  for (size_t i = 0; i < f1.size(); ++i) {
    if (k1.points[i]) continue;
    const Eigen::Vector3d x1 = UndistortedRay(cam, f1.un[i]);
    const Eigen::Vector3d l2 = F21 * Eigen::Vector3d(f1.un[i].x(), f1.un[i].y(), 1.0);
    const double ln = std::hypot(l2.x(), l2.y());
    if (ln < 1e-12) continue;
    // Epipolar segment of depths [dmin, dmax] in image 2 (z linear in depth,
    // so the segment is valid between two valid end points).
    Eigen::Vector3d pa = R21 * (x1 * dmin) + t21, pb = R21 * (x1 * dmax) + t21;
    if (pb.z() <= 1e-6) continue;
    if (pa.z() <= 1e-6) {  // move the near end to where the ray enters view
      const double dz = (pb.z() - pa.z()) / (dmax - dmin);
      const double d0 = dmin + (1e-3 * dmax - pa.z()) / dz;
      if (!(d0 < dmax)) continue;
      pa = R21 * (x1 * d0) + t21;
    }
    Eigen::Vector2d a = ProjectUndistorted(cam, pa), b = ProjectUndistorted(cam, pb);
    // Clip to the image (Liang-Barsky).
    double t0 = 0, t1 = 1;
    const Eigen::Vector2d dvec = b - a;
    const double pq[4][2] = {{-dvec.x(), a.x() - f2.min_x}, {dvec.x(), f2.max_x - 1e-3 - a.x()},
                             {-dvec.y(), a.y() - f2.min_y}, {dvec.y(), f2.max_y - 1e-3 - a.y()}};
    bool inside = true;
    for (const auto& e : pq) {
      if (std::abs(e[0]) < 1e-12) { if (e[1] < 0) inside = false; continue; }
      const double r = e[1] / e[0];
      if (e[0] < 0) t0 = std::max(t0, r); else t1 = std::min(t1, r);
    }
    if (!inside || t0 > t1) continue;
    const Eigen::Vector2d ca = a + t0 * dvec, cb = a + t1 * dvec;
    const double len = (cb - ca).norm();
    const double step = 0.5 * std::min(f2.cell_w, f2.cell_h);
    const int nsteps = static_cast<int>(len / step) + 1;
    int best = 256, best_j = -1;
    const uint8_t* d1 = f1.descriptors.ptr<uint8_t>(static_cast<int>(i));
    int last_cell = -1;
    for (int s = 0; s <= nsteps; ++s) {
      const Eigen::Vector2d q = ca + (cb - ca) * (static_cast<double>(s) / nsteps);
      const int gx = static_cast<int>((q.x() - f2.min_x) / f2.cell_w);
      const int gy = static_cast<int>((q.y() - f2.min_y) / f2.cell_h);
      const int centre = gy * f2.grid_cols + gx;
      if (centre == last_cell) continue;
      last_cell = centre;
      for (int cy = std::max(0, gy - 1); cy <= std::min(f2.grid_rows - 1, gy + 1); ++cy) {
        for (int cx = std::max(0, gx - 1); cx <= std::min(f2.grid_cols - 1, gx + 1); ++cx) {
          const int c = cy * f2.grid_cols + cx;
          if (stamp[c] == static_cast<int>(i)) continue;
          stamp[c] = static_cast<int>(i);
          for (int j : f2.grid[c]) {
            if (used2[j]) continue;
            const int lvl2 = f2.keypoints[j].octave;
            const double e = l2.dot(Eigen::Vector3d(f2.un[j].x(), f2.un[j].y(), 1.0)) / ln;
            if (e * e > 3.84 * pyr.sigma2[lvl2]) continue;
            if ((f2.un[j] - ep).squaredNorm() < 1e4 * pyr.sigma2[lvl2]) continue;
            const int d = DescriptorDistance(d1, f2.descriptors.ptr<uint8_t>(j));
            if (d < best) { best = d; best_j = j; }
          }
        }
      }
    }
    if (best_j < 0 || best > kDescLow) continue;
    if (best >= dist21[best_j]) continue;
    if (match21[best_j] >= 0) m12[match21[best_j]] = -1;
    match21[best_j] = static_cast<int>(i);
    dist21[best_j] = best;
    m12[i] = best_j;
  }
  for (size_t i = 0; i < f1.size(); ++i)
    if (m12[i] >= 0) hist.Add(f1.keypoints[i].angle, f2.keypoints[m12[i]].angle, static_cast<int>(i));
  for (int i : hist.Outliers()) m12[i] = -1;
  for (size_t i = 0; i < f1.size(); ++i)
    if (m12[i] >= 0) out.push_back({static_cast<int>(i), m12[i]});
  return out;
}

int Fuse(KeyFrame* kf, const std::vector<Landmark*>& points, const PinholeCamera& cam, const ScalePyramid& pyr, double radius) {
  const Features& f = *kf->f;
  const Eigen::Matrix3d R = kf->T_cw.R();
  const Eigen::Vector3d t = kf->T_cw.translation();
  const Eigen::Vector3d Ow = kf->Centre();
  int n = 0;
  for (Landmark* p : points) {
    if (!p || p->bad || p->obs.count(kf)) continue;
    const Eigen::Vector3d pc = R * p->pos + t;
    if (pc.z() <= 0) continue;
    const Eigen::Vector2d u = ProjectUndistorted(cam, pc);
    if (!f.InImage(u.x(), u.y())) continue;
    const Eigen::Vector3d po = p->pos - Ow;
    const double dist = po.norm();
    if (dist < 0.8 * p->min_dist || dist > 1.2 * p->max_dist) continue;
    if (po.dot(p->normal) < 0.5 * dist) continue;
    const int level = p->PredictLevel(dist, pyr);
    const auto cand = f.InArea(u.x(), u.y(), radius * pyr.scales[level]);
    int best = 256, best_j = -1;
    const uint8_t* pd = p->descriptor.ptr<uint8_t>();
    for (int j : cand) {
      const int kl = f.keypoints[j].octave;
      if (kl < level - 1 || kl > level) continue;
      const double e2 = (f.un[j] - u).squaredNorm();
      if (e2 * pyr.inv_sigma2[kl] > 5.99) continue;
      const int d = DescriptorDistance(pd, f.descriptors.ptr<uint8_t>(j));
      if (d < best) { best = d; best_j = j; }
    }
    if (best_j < 0 || best > kDescLow) continue;
    Landmark* q = kf->points[best_j];
    if (q && !q->bad) {
      if (q->obs.size() > p->obs.size()) Map::Replace(p, q);
      else Map::Replace(q, p);
    } else {
      Map::AddObservation(p, kf, best_j);
    }
    ++n;
  }
  return n;
}

}  // namespace rumi
