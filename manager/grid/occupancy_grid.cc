#include "manager/grid/occupancy_grid.h"

#include <algorithm>
#include <cmath>

namespace rumi {

const OptionSpec<OccupancyGridOptions>& OccupancyGridOptions::Spec() {
  using O = OccupancyGridOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("grid cells");
    s->Number("resolution_m", &O::resolution_m, AtLeast(0.005), AtMost(10.0), "cell side (m)");
    s->Number("clamp_min", &O::clamp_min, Above(0.0), Below(0.5), "lowest probability a cell keeps");
    s->Number("clamp_max", &O::clamp_max, Above(0.5), Below(1.0), "highest probability a cell keeps");
    s->Number("max_range_m", &O::max_range_m, Above(0.0), AtMost(1000.0), "rays longer than this are ignored");
    s->Number("max_extent_m", &O::max_extent_m, Above(0.0), AtMost(100000.0), "largest side the grid grows to");
    s->Number("slice_m", &O::slice_m, AtLeast(0.0), AtMost(100.0),
              "height slices of a column (a ray over a low obstacle clears only its own height); 0: flat 2D");
    s->Section("ism", &O::ism, InverseSensorModelOptions::Spec());
    s->Rule("clamp_min < ism.p_prior < clamp_max",
            [](const O& o) { return o.clamp_min < o.ism.p_prior && o.ism.p_prior < o.clamp_max; });
    return s;
  }();
  return *spec;
}

OccupancyGrid::OccupancyGrid(OccupancyGridOptions options, double z_lo, double z_hi)
    : options_(std::move(options)), z_lo_(z_lo), z_hi_(std::max(z_lo, z_hi)) {
  l0_ = LogOdds(options_.ism.p_prior);
  l_min_ = LogOdds(options_.clamp_min) - l0_;
  l_max_ = LogOdds(options_.clamp_max) - l0_;
  l_occupied_ = static_cast<float>(LogOdds(0.65) - l0_);
  if (options_.slice_m > 0 && z_hi_ > z_lo_)
    slices_ = std::clamp(static_cast<int>(std::ceil((z_hi_ - z_lo_) / options_.slice_m - 1e-9)), 1, 64);
}

float OccupancyGrid::log_odds(int col, int row) const {
  const float* l = &cells_[(static_cast<size_t>(row) * width_ + col) * slices_];
  if (slices_ == 1) return l[0];
  const auto [lo, hi] = std::minmax_element(l, l + slices_);
  return *hi > l_occupied_ ? *hi : *lo < 0 ? *lo : *hi;
}

void OccupancyGrid::Clear() {
  width_ = height_ = 0;
  cells_.clear();
  origin_.setZero();
  cells_updated_ = 0;
}

bool OccupancyGrid::CellOf(const Eigen::Vector2d& p, int* col, int* row) const {
  const double res = options_.resolution_m;
  const double c = std::floor((p.x() - origin_.x()) / res), r = std::floor((p.y() - origin_.y()) / res);
  if (!(c >= 0 && r >= 0 && c < width_ && r < height_)) return false;
  *col = static_cast<int>(c);
  *row = static_cast<int>(r);
  return true;
}

Eigen::Vector2d OccupancyGrid::CellCentre(int col, int row) const {
  return origin_ + options_.resolution_m * Eigen::Vector2d(col + 0.5, row + 0.5);
}

CellState OccupancyGrid::State(int col, int row, double occupied_thresh, double free_thresh) const {
  const double p = probability(col, row);
  if (p > occupied_thresh) return CellState::kOccupied;
  if (p < free_thresh) return CellState::kFree;
  return CellState::kUnknown;
}

bool OccupancyGrid::Cover(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  const double res = options_.resolution_m;
  const Eigen::Vector2d old_hi = origin_ + res * Eigen::Vector2d(width_, height_);
  if (width_ > 0 && lo.x() >= origin_.x() && lo.y() >= origin_.y() && hi.x() < old_hi.x() && hi.y() < old_hi.y())
    return true;
  // Grow by a margin, on a lattice of whole cells so existing cells keep their place.
  const double margin = 64 * res;
  Eigen::Vector2d new_lo = lo.array() - margin, new_hi = hi.array() + margin;
  if (width_ > 0) {
    new_lo = new_lo.cwiseMin(origin_);
    new_hi = new_hi.cwiseMax(old_hi);
  }
  if ((new_hi - new_lo).maxCoeff() > options_.max_extent_m + 2 * margin) return false;
  Eigen::Vector2d origin(std::floor(new_lo.x() / res) * res, std::floor(new_lo.y() / res) * res);
  if (width_ > 0) {  // keep the old lattice exactly
    origin = origin_ - res * ((origin_ - origin) / res).array().round().matrix();
  }
  const int w = static_cast<int>(std::ceil((new_hi.x() - origin.x()) / res));
  const int h = static_cast<int>(std::ceil((new_hi.y() - origin.y()) / res));
  std::vector<float> cells(static_cast<size_t>(w) * h * slices_, 0.f);
  const int dc = static_cast<int>(std::lround((origin_.x() - origin.x()) / res));
  const int dr = static_cast<int>(std::lround((origin_.y() - origin.y()) / res));
  for (int r = 0; r < height_; ++r)
    std::copy_n(&cells_[static_cast<size_t>(r) * width_ * slices_], static_cast<size_t>(width_) * slices_,
                &cells[(static_cast<size_t>(r + dr) * w + dc) * slices_]);
  cells_.swap(cells);
  origin_ = origin;
  width_ = w;
  height_ = h;
  return true;
}

bool OccupancyGrid::AddRay3d(const Eigen::Vector3d& from3, const Eigen::Vector3d& to3, bool hit) {
  const Eigen::Vector2d from = from3.head<2>(), to = to3.head<2>();
  const Eigen::Vector2d delta = to - from;
  const double range = delta.norm();
  if (!(range > 1e-9) || range > options_.max_range_m || !from3.allFinite() || !to3.allFinite()) return false;
  const Eigen::Vector2d dir = delta / range;
  const double band = options_.Band(), sigma = options_.ism.Sigma(range);
  const double length = hit ? range + IsmReach(band, sigma) : range;
  const Eigen::Vector2d end = from + length * dir;
  if (!Cover(from.cwiseMin(end), from.cwiseMax(end))) return false;

  InverseSensorModelOptions ism = options_.ism;
  if (!hit) ism.p_occ = ism.p_prior;  // a floor point: free evidence only
  // Amanatides-Woo traversal: every cell the segment [from, end] crosses, once.
  const double res = options_.resolution_m;
  const Eigen::Vector2d s = (from - origin_) / res, e = (end - origin_) / res;
  int c = static_cast<int>(std::floor(s.x())), r = static_cast<int>(std::floor(s.y()));
  const int c_end = static_cast<int>(std::floor(e.x())), r_end = static_cast<int>(std::floor(e.y()));
  const int step_c = dir.x() > 0 ? 1 : -1, step_r = dir.y() > 0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  const double dt_c = dir.x() != 0 ? std::abs(1 / dir.x()) : inf, dt_r = dir.y() != 0 ? std::abs(1 / dir.y()) : inf;
  double t_c = dir.x() != 0 ? ((step_c > 0 ? c + 1 - s.x() : s.x() - c) * dt_c) : inf;
  double t_r = dir.y() != 0 ? ((step_r > 0 ? r + 1 - s.y() : s.y() - r) * dt_r) : inf;
  const int max_steps = std::abs(c_end - c) + std::abs(r_end - r) + 1;
  // Well before the band the noisy model is p_free to 1e-12 (the Gaussian's
  // tail beyond 7 sigma): no erf there, which is most of a long ray.
  const double free_until = -band / 2 - 7 * sigma;
  const double l_free = LogOdds(Ism(ism, free_until - 1.0, band, sigma)) - l0_;
  // d: the cell centre's distance along the ray past the point, kept up to
  // date as the traversal steps a column or a row.
  double d = (CellCentre(c, r) - from).dot(dir) - range;
  const double dd_c = step_c * res * dir.x(), dd_r = step_r * res * dir.y();
  // The ray's height over a cell: linear in its length, the point's height
  // past it; as a slice index, also linear.
  const double slice_per_m = slices_ > 1 ? slices_ / (z_hi_ - z_lo_) : 0;
  const double k_from = (from3.z() - z_lo_) * slice_per_m, k_to = (to3.z() - z_lo_) * slice_per_m;
  for (int i = 0; i < max_steps; ++i) {
    if (c >= 0 && r >= 0 && c < width_ && r < height_) {
      const double l = d < free_until ? l_free : LogOdds(FastIsm(ism, d, band, sigma)) - l0_;
      // Above the band (a camera higher than the robot) the ray counts for
      // the top slice, below it for the bottom one.
      const double u = std::clamp(1 + d / range, 0.0, 1.0);
      const int k = slices_ == 1 ? 0 : std::clamp(static_cast<int>(k_from + u * (k_to - k_from)), 0, slices_ - 1);
      float& cell = cells_[(static_cast<size_t>(r) * width_ + c) * slices_ + k];
      cell = static_cast<float>(std::clamp(cell + l, l_min_, l_max_));
      ++cells_updated_;
    }
    if (c == c_end && r == r_end) break;
    if (t_c < t_r) {
      c += step_c;
      t_c += dt_c;
      d += dd_c;
    } else {
      r += step_r;
      t_r += dt_r;
      d += dd_r;
    }
  }
  return true;
}

}  // namespace rumi
