#include "manager/grid/inverse_sensor_model.h"

#include <gtest/gtest.h>

#include <cmath>

namespace rumi {
namespace {

// The ideal model convolved with N(0, sigma) by direct numerical
// integration (midpoint rule over +-8 sigma): what the closed form must equal.
double ConvolvedNumerically(const InverseSensorModelOptions& o, double d, double band, double sigma) {
  const int n = 40000;
  const double lo = -8 * sigma, step = 16 * sigma / n;
  double sum = 0, weight = 0;
  for (int i = 0; i < n; ++i) {
    const double e = lo + (i + 0.5) * step;
    const double w = std::exp(-0.5 * e * e / (sigma * sigma));
    sum += w * IdealIsm(o, d - e, band);
    weight += w;
  }
  return sum / weight;
}

TEST(InverseSensorModel, ClosedFormEqualsDirectConvolution) {
  InverseSensorModelOptions o;
  double worst = 0;
  for (double band : {0.0707, 0.2, 0.5})
    for (double sigma : {0.01, 0.05, 0.2, 1.0})
      for (double d = -3; d <= 3; d += 0.0137) {
        const double err = std::abs(Ism(o, d, band, sigma) - ConvolvedNumerically(o, d, band, sigma));
        worst = std::max(worst, err);
        ASSERT_LT(err, 2e-4) << "band " << band << " sigma " << sigma << " d " << d;
      }
  std::printf("worst |closed form - numerical| = %.2e\n", worst);
}

TEST(InverseSensorModel, IdealModelAndLimits) {
  InverseSensorModelOptions o;
  const double band = 0.1;
  EXPECT_EQ(IdealIsm(o, -1, band), o.p_free);
  EXPECT_EQ(IdealIsm(o, 0.04, band), o.p_occ);
  EXPECT_EQ(IdealIsm(o, 1, band), o.p_prior);
  EXPECT_EQ(Ism(o, 0.0, band, 0.0), o.p_occ);  // no noise: the ideal model
  // Far from the band the noise no longer matters.
  EXPECT_NEAR(Ism(o, -2, band, 0.05), o.p_free, 1e-9);
  EXPECT_NEAR(Ism(o, 2, band, 0.05), o.p_prior, 1e-9);
  // The more noise, the less the band claims (the paper's Figure 4).
  EXPECT_GT(Ism(o, 0, band, 0.01), Ism(o, 0, band, 0.05));
  EXPECT_GT(Ism(o, 0, band, 0.05), Ism(o, 0, band, 0.2));
  // The wider the band, the more it claims (Figure 3).
  EXPECT_LT(Ism(o, 0, 0.05, 0.05), Ism(o, 0, 0.2, 0.05));
  // Past the reach the update is negligible.
  const double sigma = 0.07;
  EXPECT_LT(std::abs(Ism(o, IsmReach(band, sigma), band, sigma) - o.p_prior), 1e-3 * (o.p_occ - o.p_prior));
  // Noise grows with range.
  EXPECT_GT(o.Sigma(5), o.Sigma(1));
}

TEST(InverseSensorModel, OptionsChecked) {
  InverseSensorModelOptions o;
  std::string why;
  EXPECT_TRUE(o.Check(&why)) << why;
  o.p_occ = 0.4;  // below the prior: an observed point would make its cell freer
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("p_prior"), std::string::npos) << why;
  o = {};
  o.p_free = 1.0;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("p_free"), std::string::npos) << why;
}

TEST(InverseSensorModelTest, TableModelMatchesTheClosedForm) {
  InverseSensorModelOptions o;
  double worst = 0, worst_phi = 0;
  for (double x = -9; x <= 9; x += 0.0013) worst_phi = std::max(worst_phi, std::abs(FastPhi(x) - 0.5 * std::erfc(-x / std::sqrt(2.0))));
  for (double sigma : {0.005, 0.02, 0.1, 0.3, 1.0})
    for (double band : {0.0707, 0.2, 0.5})
      for (double d = -3; d <= 3; d += 0.0017) worst = std::max(worst, std::abs(FastIsm(o, d, band, sigma) - Ism(o, d, band, sigma)));
  EXPECT_LT(worst_phi, 5e-7);
  EXPECT_LT(worst, 5e-7);
}

}  // namespace
}  // namespace rumi
