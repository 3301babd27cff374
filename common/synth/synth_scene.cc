#include "common/synth/synth_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rumi {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Uniform in [0, 1) from a hash.
inline double Unit(uint64_t h) { return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0); }

inline double Smooth5(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }

inline double Clamp01(double x) { return x < 0 ? 0 : (x > 1 ? 1 : x); }

inline double SmoothStep(double e0, double e1, double x) {
  const double t = Clamp01((x - e0) / (e1 - e0));
  return t * t * (3 - 2 * t);
}

// Per-cell random values for cellular marks.
struct Cell {
  int64_t i, j;
  double fu, fv;  // position inside the cell, [0, 1)
};
inline Cell CellOf(double u, double v, double size) {
  const double a = u / size, b = v / size;
  const double fa = std::floor(a), fb = std::floor(b);
  return {static_cast<int64_t>(fa), static_cast<int64_t>(fb), a - fa, b - fb};
}
// Hash prefix SynthHash(seed, i, j, .) of a cell: its k-th value costs one
// more mixing step (CellRand(c, seed, k) == CellRandK(CellKey(c, seed), k)).
inline uint64_t CellKey(const Cell& c, uint64_t seed) {
  return SynthHashC(SynthHashB(SynthHashA(seed), static_cast<uint64_t>(c.i)), static_cast<uint64_t>(c.j));
}
inline double CellRandK(uint64_t key, int k) { return Unit(SynthHashD(key, static_cast<uint64_t>(k))); }
inline double CellRand(const Cell& c, uint64_t seed, int k) { return CellRandK(CellKey(c, seed), k); }

// Random values 0..10 of a cell, memoised per thread (exact, like the
// lattice cache of SynthValueNoise, so images do not change).
struct CellCache {
  static constexpr int kSize = 256;
  struct Entry {
    uint64_t seed = 0;
    int64_t i = std::numeric_limits<int64_t>::min(), j = 0;  // min: empty
    double r[11] = {};
  };
  Entry entries[kSize];
};

const double* CellValues(const Cell& c, uint64_t seed) {
  thread_local CellCache cache;
  const uint64_t slot = ((static_cast<uint64_t>(c.i) * 0x9e3779b97f4a7c15ULL) ^
                         (static_cast<uint64_t>(c.j) * 0xc2b2ae3d27d4eb4fULL) ^ (seed * 0x165667b19e3779f9ULL)) >>
                        56;  // 8 bits: kSize
  CellCache::Entry& e = cache.entries[slot];
  if (e.i == c.i && e.j == c.j && e.seed == seed) return e.r;
  const uint64_t key = CellKey(c, seed);
  e.seed = seed;
  e.i = c.i;
  e.j = c.j;
  for (int k = 0; k < 11; ++k) e.r[k] = CellRandK(key, k);
  return e.r;
}

// Dark or light blot / stroke inside one cell of `size` metres (cell-local
// shapes never cross the cell border, so one cell lookup is exact).
double CellMarks(double u, double v, uint64_t seed, double size, double density,
                 double strength) {
  const Cell c = CellOf(u, v, size);
  const double* rnd = CellValues(c, seed);
  if (rnd[0] >= density) return 0.0;
  const double kind = rnd[1];
  const double sign = rnd[2] < 0.5 ? -1.0 : 1.0;
  const double amp = strength * (0.5 + 0.5 * rnd[3]);
  const double cu = 0.3 + 0.4 * rnd[4], cv = 0.3 + 0.4 * rnd[5];
  const double du = (c.fu - cu) * size, dv = (c.fv - cv) * size;
  if (kind < 0.45) {  // soft-edged blot with a noisy outline
    const double r = size * (0.08 + 0.17 * rnd[6]);
    const double wob = 1.0 + 0.25 * SynthValueNoise(u * 30, v * 30, seed + 17);
    const double d = std::sqrt(du * du + dv * dv) / (r * wob);
    return sign * amp * (1.0 - SmoothStep(0.8, 1.0, d));
  }
  if (kind < 0.8) {  // stroke: a thick segment
    const double ang = kPi * rnd[7];
    const double ca = std::cos(ang), sa = std::sin(ang);
    const double along = du * ca + dv * sa, across = -du * sa + dv * ca;
    const double half_len = size * (0.1 + 0.18 * rnd[8]);
    const double half_w = size * (0.012 + 0.03 * rnd[9]);
    const double d = std::max(std::abs(along) / half_len, std::abs(across) / half_w);
    return sign * amp * (1.0 - SmoothStep(0.85, 1.0, d));
  }
  // ring
  const double r = size * (0.1 + 0.15 * rnd[10]);
  const double w = r * 0.25;
  const double d = std::abs(std::sqrt(du * du + dv * dv) - r) / w;
  return sign * amp * (1.0 - SmoothStep(0.7, 1.0, d));
}

constexpr int kPosterShapes = 14;

SynthPosterShape PosterShape(const SynthDecal& d, int k) {
  const double w = d.u1 - d.u0, h = d.v1 - d.v0;
  SynthPosterShape p;
  p.seed = SynthHash(d.seed, static_cast<uint64_t>(k));
  p.kind = Unit(SynthHash(p.seed, 1));
  p.cx = 0.1 + 0.8 * Unit(SynthHash(p.seed, 2));
  p.cy = 0.1 + 0.8 * Unit(SynthHash(p.seed, 3));
  p.sx = (0.03 + 0.15 * Unit(SynthHash(p.seed, 4))) * std::min(w, h) / w;
  p.sy = (0.03 + 0.15 * Unit(SynthHash(p.seed, 5))) * std::min(w, h) / h;
  p.value = 0.05 + 0.9 * Unit(SynthHash(p.seed, 6));
  return p;
}

double PosterAlbedo(const SynthDecal& d, double u, double v) {
  const double w = d.u1 - d.u0, h = d.v1 - d.v0;
  const double x = (u - d.u0) / w, y = (v - d.v0) / h;  // [0, 1]
  // Frame around the poster.
  if (x < 0.03 || x > 0.97 || y < 0.03 || y > 0.97) return 0.12;
  double a = 0.55 + 0.35 * (Unit(SynthHash(d.seed, 99)) - 0.5) +
             0.12 * SynthFbm(u, v, d.seed + 5, 3, 3.0);
  const bool prepared = static_cast<int>(d.shapes.size()) == kPosterShapes;
  for (int k = 0; k < kPosterShapes; ++k) {
    const SynthPosterShape sh = prepared ? d.shapes[k] : PosterShape(d, k);
    const double dx = (x - sh.cx) / sh.sx, dy = (y - sh.cy) / sh.sy;
    bool in = false;
    if (sh.kind < 0.35) {
      in = dx * dx + dy * dy < 1.0;
    } else if (sh.kind < 0.6) {
      in = std::abs(dx) < 1.0 && std::abs(dy) < 1.0;
    } else if (sh.kind < 0.8) {  // hollow frame
      const double m = std::max(std::abs(dx), std::abs(dy));
      in = m < 1.0 && m > 0.7;
    } else {  // text-like rows of bars
      if (std::abs(dx) < 2.0 && std::abs(dy) < 0.6) {
        const double row = (dy + 0.6) / 1.2 * 3.0;
        const double col = (dx + 2.0) * 4.0;
        const int ci = static_cast<int>(col);
        const bool gap = Unit(SynthHash(sh.seed, static_cast<uint64_t>(ci), 7)) < 0.3;
        in = !gap && (row - std::floor(row)) < 0.55 && (col - std::floor(col)) < 0.75;
      }
    }
    if (in) a = sh.value;
  }
  return a;
}

double MarkerAlbedo(const SynthDecal& d, double u, double v) {
  // One-square white border around n x n squares.
  const double s = (d.u1 - d.u0) / (d.squares + 2);
  const int i = static_cast<int>(std::floor((u - d.u0) / s)) - 1;
  const int j = static_cast<int>(std::floor((v - d.v0) / s)) - 1;
  if (i < 0 || j < 0 || i >= d.squares || j >= d.squares) return 0.92;
  return ((i + j) % 2 == 0) ? 0.06 : 0.92;
}

double MaterialAlbedo(SynthMaterial m, double u, double v, uint64_t seed, double contrast) {
  double base = 0.5, var = 0.0;
  switch (m) {
    case SynthMaterial::kWallpaper:
      base = 0.58;
      var = 0.2 * SynthFbm(u, v, seed, 5, 1.5) + CellMarks(u, v, seed + 1, 0.35, 0.55, 0.3) +
            CellMarks(u + 0.11, v + 0.07, seed + 2, 0.12, 0.35, 0.18);
      break;
    case SynthMaterial::kConcrete:
      base = 0.5;
      var = 0.12 * SynthFbm(u, v, seed, 4, 2.0) + 0.07 * SynthFbm(u, v, seed + 3, 2, 25.0) +
            CellMarks(u, v, seed + 1, 0.6, 0.4, 0.22) +
            CellMarks(u + 0.05, v + 0.13, seed + 2, 0.2, 0.25, 0.15);
      break;
    case SynthMaterial::kTiles: {
      const double size = 0.3, grout = 0.012;
      const Cell c = CellOf(u, v, size);
      const double gu = std::min(c.fu, 1 - c.fu) * size, gv = std::min(c.fv, 1 - c.fv) * size;
      if (std::min(gu, gv) < grout * 0.5) return 0.22 + 0.05 * SynthFbm(u, v, seed, 2, 20.0);
      base = 0.35 + 0.4 * CellRand(c, seed, 0);
      var = 0.08 * SynthFbm(u, v, seed + 1, 4, 4.0) + CellMarks(u, v, seed + 2, 0.15, 0.2, 0.2);
      break;
    }
    case SynthMaterial::kWood: {
      base = 0.45;
      const double warp = 1.5 * SynthFbm(u * 0.7, v * 0.7, seed, 3, 1.0);
      var = 0.12 * std::sin(2 * kPi * (v * 9.0 + warp)) + 0.08 * SynthFbm(u * 0.3, v * 6, seed + 1, 3, 2.0) +
            CellMarks(u, v, seed + 2, 0.4, 0.3, 0.2);
      break;
    }
    case SynthMaterial::kFabric:
      base = 0.42;
      var = 0.05 * std::sin(2 * kPi * u * 20.0) * std::sin(2 * kPi * v * 20.0) +
            0.16 * SynthFbm(u, v, seed, 4, 3.0) + CellMarks(u, v, seed + 1, 0.25, 0.3, 0.2);
      break;
    case SynthMaterial::kPlain:
      base = 0.7;
      var = 0.03 * SynthFbm(u, v, seed, 3, 2.0);
      break;
  }
  return base + contrast * var;
}

Eigen::Vector3d AxisVector(int axis, double sign) {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  n[axis] = sign;
  return n;
}

// Distance from p to an axis-aligned rectangle.
double DistToQuad(const SynthQuad& q, const Eigen::Vector3d& p) {
  const int a = q.axis, b = (a + 1) % 3, c = (a + 2) % 3;
  const double du = std::max({q.u0 - p[b], 0.0, p[b] - q.u1});
  const double dv = std::max({q.v0 - p[c], 0.0, p[c] - q.v1});
  const double dn = p[a] - q.offset;
  return std::sqrt(du * du + dv * dv + dn * dn);
}

double DistToBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Eigen::Vector3d& p) {
  double s = 0;
  bool inside = true;
  double in_d = std::numeric_limits<double>::max();
  for (int k = 0; k < 3; ++k) {
    const double d = std::max({lo[k] - p[k], 0.0, p[k] - hi[k]});
    if (d > 0) inside = false;
    s += d * d;
    in_d = std::min({in_d, p[k] - lo[k], hi[k] - p[k]});
  }
  return inside ? -in_d : std::sqrt(s);
}

}  // namespace

namespace {

// The four lattice values of a noise cell, memoised per thread: neighbouring
// rays (supersamples, pixels of a row) mostly fall into the same cells of
// the low octaves, and hashing them dominated the render time. A cache hit
// returns exactly the values the hash gives, so images do not change.
struct LatticeCache {
  static constexpr int kSize = 512;
  struct Entry {
    uint64_t seed = 0;
    int64_t i = std::numeric_limits<int64_t>::min(), j = 0;  // min: empty
    double v[4] = {0, 0, 0, 0};
  };
  Entry entries[kSize];
};

const double* LatticeValues(uint64_t seed, int64_t i, int64_t j) {
  thread_local LatticeCache cache;
  const uint64_t slot = ((static_cast<uint64_t>(i) * 0x9e3779b97f4a7c15ULL) ^
                         (static_cast<uint64_t>(j) * 0xc2b2ae3d27d4eb4fULL) ^ (seed * 0x165667b19e3779f9ULL)) >>
                        55;  // 9 bits: kSize
  LatticeCache::Entry& e = cache.entries[slot];
  if (e.i == i && e.j == j && e.seed == seed) return e.v;
  // The four corners share the seed step and two column steps of the hash.
  const uint64_t hs = SynthHashA(seed);
  const uint64_t h0 = SynthHashB(hs, static_cast<uint64_t>(i)), h1 = SynthHashB(hs, static_cast<uint64_t>(i + 1));
  auto g = [](uint64_t hcol, int64_t b) {
    return 2.0 * Unit(SynthHashD(SynthHashC(hcol, static_cast<uint64_t>(b)), 0)) - 1.0;
  };
  e.seed = seed;
  e.i = i;
  e.j = j;
  e.v[0] = g(h0, j);
  e.v[1] = g(h1, j);
  e.v[2] = g(h0, j + 1);
  e.v[3] = g(h1, j + 1);
  return e.v;
}

}  // namespace

double SynthValueNoise(double u, double v, uint64_t seed) {
  const double fu = std::floor(u), fv = std::floor(v);
  const int64_t i = static_cast<int64_t>(fu), j = static_cast<int64_t>(fv);
  const double tu = Smooth5(u - fu), tv = Smooth5(v - fv);
  const double* g = LatticeValues(seed, i, j);
  const double a = g[0], b = g[1], c = g[2], d = g[3];
  return (a + (b - a) * tu) + ((c + (d - c) * tu) - (a + (b - a) * tu)) * tv;
}

double SynthFbm(double u, double v, uint64_t seed, int octaves, double base_freq) {
  double sum = 0, amp = 1, norm = 0, f = base_freq;
  for (int o = 0; o < octaves; ++o) {
    // Rotate each octave a little so lattice axes do not line up.
    const double ru = 0.8 * u - 0.6 * v, rv = 0.6 * u + 0.8 * v;
    sum += amp * SynthValueNoise(ru * f + 17.3 * o, rv * f - 9.1 * o, seed + 1013 * o);
    norm += amp;
    amp *= 0.55;
    f *= 2.03;
    u = ru;
    v = rv;
  }
  return sum / norm;
}

void PreparePoster(SynthDecal* d) {
  d->shapes.clear();
  if (d->kind != SynthDecalKind::kPoster) return;
  for (int k = 0; k < kPosterShapes; ++k) d->shapes.push_back(PosterShape(*d, k));
}

double SynthScene::Albedo(const SynthQuad& q, const Eigen::Vector3d& p) const {
  const double u = p[(q.axis + 1) % 3], v = p[(q.axis + 2) % 3];
  double a = -1;
  for (const SynthDecal& d : q.decals) {
    if (u >= d.u0 && u <= d.u1 && v >= d.v0 && v <= d.v1) {
      a = d.kind == SynthDecalKind::kMarker ? MarkerAlbedo(d, u, v) : PosterAlbedo(d, u, v);
      break;
    }
  }
  double quiet = 0;
  for (const SynthQuietZone& z : quiet_zones) {
    const double dist = (p - z.center).norm();
    quiet = std::max(quiet, 1.0 - SmoothStep(z.radius, z.radius + z.fade, dist));
  }
  if (a < 0 || quiet > 0) {
    const double full = a >= 0 ? a : MaterialAlbedo(q.material, u, v, q.seed, q.contrast);
    if (quiet > 0) {
      // Texture-poor paint: only faint blotches at a few scales.
      const double calm = 0.62 + quiet_amplitude * (SynthFbm(u, v, q.seed + 77, 4, 2.5) +
                                                    0.6 * SynthFbm(u, v, q.seed + 78, 2, 9.0));
      a = full + (calm - full) * quiet;
    } else {
      a = full;
    }
  }
  return std::clamp(a, 0.02, 1.0);
}

bool SynthScene::CastRay(const Eigen::Vector3d& o, const Eigen::Vector3d& d, SynthHit* hit,
                         bool shade, double t_min) const {
  double best = std::numeric_limits<double>::max();
  int best_quad = -1, best_box = -1, best_axis = 0;
  for (size_t k = 0; k < quads.size(); ++k) {
    const SynthQuad& q = quads[k];
    const double da = d[q.axis];
    if (std::abs(da) < 1e-15) continue;
    const double t = (q.offset - o[q.axis]) / da;
    if (t <= t_min || t >= best) continue;
    const double u = o[(q.axis + 1) % 3] + t * d[(q.axis + 1) % 3];
    const double v = o[(q.axis + 2) % 3] + t * d[(q.axis + 2) % 3];
    if (u < q.u0 || u > q.u1 || v < q.v0 || v > q.v1) continue;
    best = t;
    best_quad = static_cast<int>(k);
    best_axis = q.axis;
  }
  // Slab test; the reciprocals are shared by all boxes.
  const bool flat[3] = {std::abs(d[0]) < 1e-15, std::abs(d[1]) < 1e-15, std::abs(d[2]) < 1e-15};
  const double inv_d[3] = {flat[0] ? 0.0 : 1.0 / d[0], flat[1] ? 0.0 : 1.0 / d[1], flat[2] ? 0.0 : 1.0 / d[2]};
  for (size_t k = 0; k < boxes.size(); ++k) {
    const SynthBox& b = boxes[k];
    double t0 = t_min, t1 = best;
    int axis = -1;
    bool miss = false;
    for (int a = 0; a < 3 && !miss; ++a) {
      if (flat[a]) {
        if (o[a] < b.lo[a] || o[a] > b.hi[a]) miss = true;
        continue;
      }
      const double inv = inv_d[a];
      double ta = (b.lo[a] - o[a]) * inv, tb = (b.hi[a] - o[a]) * inv;
      if (ta > tb) std::swap(ta, tb);
      if (ta > t0) {
        t0 = ta;
        axis = a;
      }
      t1 = std::min(t1, tb);
      if (t0 > t1) miss = true;
    }
    if (miss || axis < 0 || t0 >= best) continue;  // axis < 0: origin inside
    best = t0;
    best_box = static_cast<int>(k);
    best_quad = -1;
    best_axis = axis;
  }
  if (best_quad < 0 && best_box < 0) return false;
  hit->t = best;
  hit->point = o + best * d;
  hit->axis = best_axis;
  hit->normal = AxisVector(best_axis, d[best_axis] > 0 ? -1.0 : 1.0);
  if (shade) {
    if (best_quad >= 0) {
      hit->albedo = Albedo(quads[best_quad], hit->point);
    } else {
      const SynthBox& b = boxes[best_box];
      SynthQuad face;
      face.axis = best_axis;
      const bool top = best_axis == 2 && hit->normal.z() > 0;
      face.material = top ? b.top_material : b.material;
      face.contrast = b.contrast;
      face.seed = SynthHash(b.seed, static_cast<uint64_t>(best_axis), hit->normal[best_axis] > 0);
      hit->albedo = Albedo(face, hit->point);
    }
  }
  return true;
}

double SynthScene::Radiance(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
  SynthHit h;
  if (!CastRay(o, d, &h)) return 0.0;
  double e = ambient;
  for (const SynthLight& l : lights) {
    const Eigen::Vector3d lp = l.attached_to_camera ? o + l.position : l.position;
    Eigen::Vector3d to = lp - h.point;
    const double dist = to.norm();
    if (dist < 1e-9) continue;
    to /= dist;
    const double cosine = std::max(0.0, h.normal.dot(to));
    const double r = dist / l.falloff;
    e += l.power * cosine / (1.0 + r * r);
  }
  return h.albedo * e;
}

double SynthScene::Clearance(const Eigen::Vector3d& p) const {
  bool inside = false;
  for (const auto& fs : free_space) inside = inside || DistToBox(fs.first, fs.second, p) <= 0;
  double best = std::numeric_limits<double>::max();
  for (const SynthQuad& q : quads) best = std::min(best, DistToQuad(q, p));
  for (const SynthBox& b : boxes) {
    const double d = DistToBox(b.lo, b.hi, p);
    if (d <= 0) inside = false;
    best = std::min(best, std::abs(d));
  }
  return inside ? best : -best;
}

std::vector<SynthMarkerCorner> SynthScene::MarkerCorners() const {
  std::vector<SynthMarkerCorner> out;
  for (const SynthQuad& q : quads) {
    for (const SynthDecal& d : q.decals) {
      if (d.kind != SynthDecalKind::kMarker) continue;
      const double s = (d.u1 - d.u0) / (d.squares + 2);
      for (int i = 1; i < d.squares; ++i) {
        for (int j = 1; j < d.squares; ++j) {
          Eigen::Vector3d p;
          p[q.axis] = q.offset;
          p[(q.axis + 1) % 3] = d.u0 + (i + 1) * s;
          p[(q.axis + 2) % 3] = d.v0 + (j + 1) * s;
          out.push_back({p, Eigen::Vector3d::Unit(q.axis), s});  // normal sign: either side
        }
      }
    }
  }
  return out;
}

// ---------------------------------------------------------------- builders
namespace {

struct Rng {
  uint64_t s;
  uint64_t k = 0;
  double Uniform(double a, double b) { return a + (b - a) * Unit(SynthHash(s, k++)); }
};

// Wall quad facing the room interior; (h, z) are horizontal/vertical wall
// coordinates; decals are placed through AddWallDecal.
SynthQuad Wall(int axis, double offset, double h0, double h1, double z0, double z1,
               SynthMaterial m, uint64_t seed, double contrast = 1.0) {
  SynthQuad q;
  q.axis = axis;
  q.offset = offset;
  // axis 0 (x = c): u = y, v = z.  axis 1 (y = c): u = z, v = x.
  if (axis == 0) {
    q.u0 = h0; q.u1 = h1; q.v0 = z0; q.v1 = z1;
  } else {
    q.u0 = z0; q.u1 = z1; q.v0 = h0; q.v1 = h1;
  }
  q.material = m;
  q.seed = seed;
  q.contrast = contrast;
  return q;
}

void AddWallDecal(SynthQuad* q, SynthDecalKind kind, double h0, double h1, double z0, double z1,
                  uint64_t seed, int squares = 4) {
  SynthDecal d;
  d.kind = kind;
  d.seed = seed;
  d.squares = squares;
  if (q->axis == 0) {
    d.u0 = h0; d.u1 = h1; d.v0 = z0; d.v1 = z1;
  } else {
    d.u0 = z0; d.u1 = z1; d.v0 = h0; d.v1 = h1;
  }
  PreparePoster(&d);
  q->decals.push_back(d);
}

SynthQuad Horizontal(double z, double x0, double x1, double y0, double y1, SynthMaterial m,
                     uint64_t seed, double contrast = 1.0) {
  SynthQuad q;
  q.axis = 2;
  q.offset = z;
  q.u0 = x0; q.u1 = x1; q.v0 = y0; q.v1 = y1;
  q.material = m;
  q.seed = seed;
  q.contrast = contrast;
  return q;
}

}  // namespace

SynthScene BuildRoomScene(uint64_t seed, double lx, double ly, double h) {
  SynthScene s;
  Rng rng{SynthHash(seed, 0x700d)};
  const SynthMaterial wall_materials[] = {SynthMaterial::kWallpaper, SynthMaterial::kConcrete,
                                          SynthMaterial::kWallpaper, SynthMaterial::kFabric};
  // Walls: x = 0, x = lx (axis 0; horizontal coordinate y), y = 0, y = ly (axis 1; x).
  struct WallDef { int axis; double offset; double len; };
  const WallDef walls[] = {{0, 0.0, ly}, {0, lx, ly}, {1, 0.0, lx}, {1, ly, lx}};
  for (int w = 0; w < 4; ++w) {
    const WallDef& wd = walls[w];
    const SynthMaterial m = wall_materials[(w + static_cast<int>(rng.Uniform(0, 4))) % 4];
    SynthQuad q = Wall(wd.axis, wd.offset, 0.0, wd.len, 0.0, h, m, SynthHash(seed, 10 + w));
    // Posters and one marker per wall, at eye height, not overlapping.
    double pos = rng.Uniform(0.3, 0.8);
    int placed = 0;
    while (pos < wd.len - 0.9) {
      const double width = rng.Uniform(0.5, 1.1);
      if (pos + width > wd.len - 0.3) break;
      const double z0 = rng.Uniform(1.0, 1.5);
      if (placed == 1) {
        AddWallDecal(&q, SynthDecalKind::kMarker, pos, pos + 0.72, 1.05, 1.77, SynthHash(seed, 50 + w));
        pos += 0.72 + rng.Uniform(0.3, 0.9);
      } else if (rng.Uniform(0, 1) < 0.65) {
        AddWallDecal(&q, SynthDecalKind::kPoster, pos, pos + width, z0,
                     std::min(h - 0.2, z0 + rng.Uniform(0.5, 1.0)), SynthHash(seed, 60 + w, placed));
        pos += width + rng.Uniform(0.3, 1.0);
      } else {
        pos += rng.Uniform(0.5, 1.2);
      }
      ++placed;
    }
    s.quads.push_back(q);
  }
  s.quads.push_back(Horizontal(0.0, 0, lx, 0, ly, SynthMaterial::kTiles, SynthHash(seed, 20)));
  s.quads.push_back(Horizontal(h, 0, lx, 0, ly, SynthMaterial::kPlain, SynthHash(seed, 21)));

  // Furniture along the walls, at most 1.0 m deep so the centre stays free.
  const SynthMaterial box_materials[] = {SynthMaterial::kWood, SynthMaterial::kFabric,
                                         SynthMaterial::kConcrete, SynthMaterial::kWallpaper,
                                         SynthMaterial::kPlain};
  for (int w = 0; w < 4; ++w) {
    const WallDef& wd = walls[w];
    double pos = rng.Uniform(0.2, 1.5);
    while (true) {
      const double len = rng.Uniform(0.5, 1.6);
      if (pos + len > wd.len - 0.2) break;
      const double depth = rng.Uniform(0.35, 0.9);
      const double height = rng.Uniform(0.4, 1.9);
      SynthBox b;
      const double inner = wd.offset == 0.0 ? 0.0 : wd.offset - depth;
      if (wd.axis == 0) {
        b.lo = Eigen::Vector3d(inner, pos, 0.0);
        b.hi = Eigen::Vector3d(inner + depth, pos + len, height);
      } else {
        b.lo = Eigen::Vector3d(pos, inner, 0.0);
        b.hi = Eigen::Vector3d(pos + len, inner + depth, height);
      }
      const int mi = static_cast<int>(rng.Uniform(0, 5));
      b.material = box_materials[mi];
      b.top_material = rng.Uniform(0, 1) < 0.5 ? SynthMaterial::kWood : SynthMaterial::kWallpaper;
      b.seed = SynthHash(seed, 100 + w, static_cast<uint64_t>(pos * 1000));
      s.boxes.push_back(b);
      pos += len + rng.Uniform(0.4, 1.5);
    }
  }
  // A low table in the middle: parallax and occlusion for the circling camera.
  SynthBox table;
  table.lo = Eigen::Vector3d(lx / 2 - 0.45, ly / 2 - 0.3, 0.0);
  table.hi = Eigen::Vector3d(lx / 2 + 0.45, ly / 2 + 0.3, 0.72);
  table.material = SynthMaterial::kWood;
  table.top_material = SynthMaterial::kWallpaper;
  table.seed = SynthHash(seed, 200);
  s.boxes.push_back(table);

  s.lights.push_back({Eigen::Vector3d(lx / 3, ly / 2, h - 0.2), 0.9, 3.0, false});
  s.lights.push_back({Eigen::Vector3d(2 * lx / 3, ly / 2, h - 0.2), 0.9, 3.0, false});
  s.ambient = 0.3;
  s.free_space.push_back({Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(lx, ly, h)});
  return s;
}

SynthScene BuildCorridorScene(uint64_t seed, double la, double lb, double w, double h) {
  SynthScene s;
  Rng rng{SynthHash(seed, 0xc0de)};
  // Stained bare concrete everywhere (dim under the headlamp): enough for a
  // tracker in the legs, which the calm zone below removes at the turn.
  const double c = 1.0;
  const uint64_t wall_seed = SynthHash(seed, 30);
  // Leg A walls.
  s.quads.push_back(Wall(1, 0.0, 0.0, la, 0.0, h, SynthMaterial::kConcrete, wall_seed, c));    // y = 0
  s.quads.push_back(Wall(1, w, 0.0, la - w, 0.0, h, SynthMaterial::kConcrete, wall_seed + 1, c));  // y = w
  s.quads.push_back(Wall(0, 0.0, 0.0, w, 0.0, h, SynthMaterial::kConcrete, wall_seed + 2, c));  // x = 0
  // Leg B walls.
  s.quads.push_back(Wall(0, la, 0.0, lb, 0.0, h, SynthMaterial::kConcrete, wall_seed + 3, c));  // x = la
  s.quads.push_back(Wall(0, la - w, w, lb, 0.0, h, SynthMaterial::kConcrete, wall_seed + 4, c));  // x = la - w
  s.quads.push_back(Wall(1, lb, la - w, la, 0.0, h, SynthMaterial::kConcrete, wall_seed + 5, c));  // y = lb
  // Floor and ceiling of both legs share seeds, so their overlap agrees.
  const uint64_t floor_seed = SynthHash(seed, 31), ceil_seed = SynthHash(seed, 32);
  s.quads.push_back(Horizontal(0.0, 0, la, 0, w, SynthMaterial::kConcrete, floor_seed, 1.0));
  s.quads.push_back(Horizontal(0.0, la - w, la, 0, lb, SynthMaterial::kConcrete, floor_seed, 1.0));
  s.quads.push_back(Horizontal(h, 0, la, 0, w, SynthMaterial::kConcrete, ceil_seed, 0.6));
  s.quads.push_back(Horizontal(h, la - w, la, 0, lb, SynthMaterial::kConcrete, ceil_seed, 0.6));

  // Marks along the legs (graffiti-like posters, markers) every 0.8-1.6 m,
  // none within `quiet` + 0.4 m of the calm zone.
  const double quiet = 1.8;
  const Eigen::Vector2d corner(la - w / 2, w / 2);
  // Freshly plastered start of leg B (about 1 to 4.5 m past the corner): the
  // camera looks into it from mid-turn on. Not centred on the corner: the
  // end wall of leg A, which the robot drives at for seconds before the
  // turn, would then make the approach texture-poor as well.
  const std::vector<Eigen::Vector2d> calm = {corner + Eigen::Vector2d(0, 2.0)};
  const int side_walls[] = {0, 1, 3, 4};
  for (int k = 0; k < 4; ++k) {
    SynthQuad& q = s.quads[side_walls[k]];
    const double len = (q.axis == 1) ? la : lb;
    double pos = rng.Uniform(0.5, 1.5);
    int n = 0;
    while (pos < len - 1.0) {
      Eigen::Vector2d at = q.axis == 1 ? Eigen::Vector2d(pos, q.offset) : Eigen::Vector2d(q.offset, pos);
      const bool in_range = q.axis == 1 ? (pos > q.v0 && pos + 1.1 < q.v1) : (pos > q.u0 && pos + 1.1 < q.u1);
      const Eigen::Vector2d at_end = at + (q.axis == 1 ? Eigen::Vector2d(1.1, 0) : Eigen::Vector2d(0, 1.1));
      bool clear = in_range;
      for (const Eigen::Vector2d& cz : calm)
        clear = clear && (at - cz).norm() > quiet + 0.4 && (at_end - cz).norm() > quiet + 0.4;
      if (clear) {
        if (n % 2 == 1) {
          AddWallDecal(&q, SynthDecalKind::kMarker, pos, pos + 1.0, 0.1, 1.1, SynthHash(seed, 300 + k, n), 3);
        } else {
          AddWallDecal(&q, SynthDecalKind::kPoster, pos, pos + rng.Uniform(0.3, 0.6), rng.Uniform(0.2, 0.5),
                       rng.Uniform(0.8, 1.2), SynthHash(seed, 400 + k, n));
        }
        ++n;
      }
      pos += rng.Uniform(0.8, 1.6);
    }
  }
  for (const Eigen::Vector2d& cz : calm) s.quiet_zones.push_back({Eigen::Vector3d(cz.x(), cz.y(), h / 2), quiet, 0.4});
  s.quiet_amplitude = 0.035;
  // Headlamp on the robot plus a little daylight from manholes. The slow
  // falloff keeps walls a few metres ahead visible without clipping the end
  // wall at 1 m.
  s.lights.push_back({Eigen::Vector3d(0, 0, 0.05), 1.3, 3.0, true});
  s.ambient = 0.12;
  s.free_space.push_back({Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(la, w, h)});
  s.free_space.push_back({Eigen::Vector3d(la - w, 0, 0), Eigen::Vector3d(la, lb, h)});
  return s;
}

}  // namespace rumi
