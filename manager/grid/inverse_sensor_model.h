#pragma once
// The inverse sensor model (ISM) of a visual range observation along one ray
// (the grid paper, ../shared/papers/001_*, Section 1): what one observed map
// point at range r says about a cell at range z on the ray from the camera.
//
// The ideal model, in d = z - r: free (p_free) before the point, occupied
// (p_occ) across a band of width L centred on it, the prior (unknown) behind
// it. L is the diagonal of one grid cell, so that the cell holding the point
// is always inside the band. The practical model is the ideal one convolved
// with Gaussian range noise N(0, sigma), which has a closed form in erf:
//
//   h(d) = p_free * (1 - Phi((d + L/2) / sigma))
//        + p_occ  * (Phi((d + L/2) / sigma) - Phi((d - L/2) / sigma))
//        + p_prior * Phi((d - L/2) / sigma),     Phi(x) = (1 + erf(x / sqrt 2)) / 2.
//
// Monocular depth noise grows with range, so sigma = sigma_0 + sigma_per_m * r.
#include <cmath>
#include <string>

#include "common/option_spec.h"

namespace rumi {

struct InverseSensorModelOptions {
  double p_free = 0.4;    // occupancy evidence of a cell the ray crossed
  double p_occ = 0.9;     // of a cell holding the observed point (before the noise spreads it)
  double p_prior = 0.5;   // unknown: what a cell behind the point keeps
  double band_m = 0;      // L; 0: the diagonal of one grid cell
  double sigma_m = 0.02;  // range noise at range 0 (metres)
  double sigma_per_m = 0.02;  // its growth per metre of range
  static const OptionSpec<InverseSensorModelOptions>& Spec();  // section `grid.ism:`
  bool Check(std::string* why = nullptr) const { return Spec().Check(*this, why); }
  double Sigma(double range_m) const { return sigma_m + sigma_per_m * range_m; }
};

// The ideal model at d = z - r for a band of width L.
double IdealIsm(const InverseSensorModelOptions& o, double d, double band);
// The ideal model convolved with N(0, sigma): the closed form above. sigma
// 0 gives the ideal model.
double Ism(const InverseSensorModelOptions& o, double d, double band, double sigma);
// How far past r the model still differs from the prior by more than 1e-3
// of (p_occ - p_prior): where a ray's update may stop.
double IsmReach(double band, double sigma);
// Ism with the normal CDF from a table (within 5e-7 of Ism): the grid's
// per-cell model, a few ns instead of two erf.
double FastIsm(const InverseSensorModelOptions& o, double d, double band, double sigma);
double FastPhi(double x);

inline double LogOdds(double p) { return std::log(p / (1 - p)); }
inline double Probability(double log_odds) { return 1 - 1 / (1 + std::exp(log_odds)); }

}  // namespace rumi
