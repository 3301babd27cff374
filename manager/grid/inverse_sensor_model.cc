#include "manager/grid/inverse_sensor_model.h"

#include <cmath>
#include <vector>

namespace rumi {

const OptionSpec<InverseSensorModelOptions>& InverseSensorModelOptions::Spec() {
  using O = InverseSensorModelOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("grid ism");
    s->Number("p_free", &O::p_free, Above(0.0), Below(1.0), "occupancy evidence of a cell a ray crossed");
    s->Number("p_occ", &O::p_occ, Above(0.0), Below(1.0), "occupancy evidence of the cell holding the point");
    s->Number("p_prior", &O::p_prior, Above(0.0), Below(1.0), "prior occupancy (unknown)");
    s->Number("band_m", &O::band_m, AtLeast(0.0), AtMost(10.0), "L, band of the occupied part; 0: cell diagonal");
    s->Number("sigma_m", &O::sigma_m, AtLeast(0.0), AtMost(10.0), "range noise at range 0 (m)");
    s->Number("sigma_per_m", &O::sigma_per_m, AtLeast(0.0), AtMost(10.0), "growth of the range noise per metre");
    s->Rule("p_free < p_prior < p_occ", [](const O& o) { return o.p_free < o.p_prior && o.p_prior < o.p_occ; });
    return s;
  }();
  return *spec;
}

double IdealIsm(const InverseSensorModelOptions& o, double d, double band) {
  if (d < -band / 2) return o.p_free;
  if (d <= band / 2) return o.p_occ;
  return o.p_prior;
}

double Ism(const InverseSensorModelOptions& o, double d, double band, double sigma) {
  if (sigma <= 0) return IdealIsm(o, d, band);
  const double k = 1 / (sigma * std::sqrt(2.0));
  const double a = 0.5 * (1 + std::erf((d + band / 2) * k));  // P(noise puts the cell before the band's end)
  const double b = 0.5 * (1 + std::erf((d - band / 2) * k));  // ... before the band's start
  return o.p_free * (1 - a) + o.p_occ * (a - b) + o.p_prior * b;
}

namespace {
// The standard normal CDF on [-8, 8] every 1/256, interpolated linearly:
// within 5e-7 of erf's (Φ'' <= 0.242, step^2 / 8 * 0.242).
constexpr int kPhiPerUnit = 256, kPhiHalf = 8;
const std::vector<double>& PhiTable() {
  static const std::vector<double> t = [] {
    std::vector<double> v(2 * kPhiHalf * kPhiPerUnit + 2);
    for (size_t i = 0; i < v.size(); ++i)
      v[i] = 0.5 * std::erfc(-(static_cast<double>(i) / kPhiPerUnit - kPhiHalf) / std::sqrt(2.0));
    return v;
  }();
  return t;
}
}  // namespace

double FastPhi(double x) {
  const std::vector<double>& t = PhiTable();
  const double u = (x + kPhiHalf) * kPhiPerUnit;
  if (!(u > 0)) return 0;
  if (u >= 2 * kPhiHalf * kPhiPerUnit) return 1;
  const size_t i = static_cast<size_t>(u);
  const double f = u - static_cast<double>(i);
  return t[i] + f * (t[i + 1] - t[i]);
}

double FastIsm(const InverseSensorModelOptions& o, double d, double band, double sigma) {
  if (sigma <= 0) return IdealIsm(o, d, band);
  const double a = FastPhi((d + band / 2) / sigma), b = FastPhi((d - band / 2) / sigma);
  return o.p_free * (1 - a) + o.p_occ * (a - b) + o.p_prior * b;
}

double IsmReach(double band, double sigma) { return band / 2 + 3.3 * sigma; }

}  // namespace rumi
