#pragma once
// Closed 3D scenes for synthetic sequences, rendered exactly by ray casting:
// axis-aligned rectangles (walls) and solid axis-aligned boxes (furniture).
// Surface appearance is a pure function of world position (texture lives in
// surface coordinates), so every view of a point agrees and renders are
// bit-identical for a given seed. World frame: z up, metres.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace rumi {

enum class SynthMaterial : uint8_t {
  kWallpaper,  // multi-scale noise with blots and strokes
  kConcrete,   // fine grain, stains, cracks
  kTiles,      // tiles with grout and per-tile shade
  kWood,       // warped stripes
  kFabric,     // woven fine texture
  kPlain,      // texture-poor paint (only faint large blotches)
};

enum class SynthDecalKind : uint8_t {
  kPoster,  // random shapes: discs, bars, frames, text-like rows
  kMarker,  // black/white checkerboard with known corners
};

// One random shape of a poster (derived from the decal's seed).
struct SynthPosterShape {
  uint64_t seed = 0;
  double kind = 0, cx = 0, cy = 0, sx = 0, sy = 0, value = 0;
};

// A rectangle [u0,u1]x[v0,v1] in a surface's (u, v) coordinates.
struct SynthDecal {
  SynthDecalKind kind = SynthDecalKind::kPoster;
  double u0 = 0, v0 = 0, u1 = 0, v1 = 0;
  int squares = 4;  // marker: squares per side
  uint64_t seed = 0;
  // Poster shapes, precomputed from seed and bounds by PreparePoster (the
  // renderer derives them per pixel when empty).
  std::vector<SynthPosterShape> shapes;
};

// Fills d->shapes (a pure function of d's seed and bounds).
void PreparePoster(SynthDecal* d);

// Axis-aligned rectangle: points with p[axis] == offset and the two other
// coordinates (u = p[(axis+1)%3], v = p[(axis+2)%3]) inside the bounds.
struct SynthQuad {
  int axis = 0;
  double offset = 0;
  double u0 = 0, u1 = 0, v0 = 0, v1 = 0;
  SynthMaterial material = SynthMaterial::kWallpaper;
  double contrast = 1.0;  // scales texture amplitude around the mean albedo
  uint64_t seed = 0;
  std::vector<SynthDecal> decals;
};

struct SynthBox {
  Eigen::Vector3d lo, hi;
  SynthMaterial material = SynthMaterial::kWood;
  SynthMaterial top_material = SynthMaterial::kWood;
  double contrast = 1.0;
  uint64_t seed = 0;
};

// Region where every surface is texture-poor (faint blotches only).
struct SynthQuietZone {
  Eigen::Vector3d center;
  double radius = 0;  // full effect inside radius, fades out over `fade`
  double fade = 0.3;
};

// Point light; irradiance falls off as 1 / (1 + (d / falloff)^2).
struct SynthLight {
  Eigen::Vector3d position;
  double power = 1.0;
  double falloff = 3.0;
  bool attached_to_camera = false;  // headlamp: position is camera-relative
};

struct SynthHit {
  double t = 0;
  Eigen::Vector3d point;
  Eigen::Vector3d normal;  // unit, facing the ray origin
  int axis = 0;            // axis of the surface normal
  double albedo = 0;
};

// A marker corner with its world position (for ground-truth checks).
struct SynthMarkerCorner {
  Eigen::Vector3d point;
  Eigen::Vector3d normal;  // unit normal of the wall (sign arbitrary)
  double square = 0;       // checker square size, metres
};

class SynthScene {
 public:
  std::vector<SynthQuad> quads;
  std::vector<SynthBox> boxes;
  std::vector<SynthQuietZone> quiet_zones;
  std::vector<SynthLight> lights;
  double ambient = 0.25;
  double quiet_amplitude = 0.03;  // albedo amplitude left inside quiet zones
  // Free space for trajectory checks: union of these boxes minus `boxes`.
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> free_space;

  // Nearest hit along origin + t * dir (dir need not be unit) with t > t_min.
  // Fills albedo when `shade` is true. False when nothing is hit.
  bool CastRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, SynthHit* hit,
               bool shade = true, double t_min = 1e-6) const;

  // Radiance seen along the ray (albedo times lighting), in [0, ~1.2].
  double Radiance(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) const;

  // Distance from p to the nearest obstacle (wall or box); negative outside
  // free space.
  double Clearance(const Eigen::Vector3d& p) const;

  // Inner corners of every marker decal (world points).
  std::vector<SynthMarkerCorner> MarkerCorners() const;

  // Albedo of a surface point (texture + decals + quiet zones).
  double Albedo(const SynthQuad& q, const Eigen::Vector3d& p) const;
};

// Room of lx * ly * h metres with furniture boxes along the walls, posters
// and markers; the central region stays free for the camera.
SynthScene BuildRoomScene(uint64_t seed, double lx = 8.0, double ly = 6.0, double h = 3.0);

// L-shaped drainage-like corridor: leg A along +x (x in [0, len_a], y in
// [0, width]), leg B along +y (x in [len_a - width, len_a], y in [0, len_b]).
// Stained concrete, marks and markers along the legs; a plain zone at the
// start of leg B, which the camera faces from the middle of the turn on.
SynthScene BuildCorridorScene(uint64_t seed, double len_a, double len_b, double width = 1.6,
                              double height = 1.5);

// Deterministic noise helpers (exposed for tests). SynthHash(a, b, c, d)
// chains one mixing step per argument; the staged form below lets hot loops
// reuse a shared prefix (same seed, same cell row) with identical results:
// SynthHash(a, b, c, d) == SynthHashD(SynthHashC(SynthHashB(SynthHashA(a), b), c), d).
inline uint64_t SynthMix(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}
inline uint64_t SynthHashA(uint64_t a) { return SynthMix(a ^ 0x51ed270b27bd1a2bULL); }
inline uint64_t SynthHashB(uint64_t h, uint64_t b) { return SynthMix(h ^ b); }
inline uint64_t SynthHashC(uint64_t h, uint64_t c) { return SynthMix(h ^ (c * 0x632be59bd9b4e019ULL)); }
inline uint64_t SynthHashD(uint64_t h, uint64_t d) { return SynthMix(h ^ (d * 0x85157af5ULL)); }
inline uint64_t SynthHash(uint64_t a, uint64_t b = 0, uint64_t c = 0, uint64_t d = 0) {
  return SynthHashD(SynthHashC(SynthHashB(SynthHashA(a), b), c), d);
}
double SynthValueNoise(double u, double v, uint64_t seed);  // in [-1, 1]
double SynthFbm(double u, double v, uint64_t seed, int octaves, double base_freq);

}  // namespace rumi
