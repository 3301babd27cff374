#include "ipc/link/clock_sync.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace rumi {
namespace {

// Round trips at 4 Hz over a link with 50 ms +- 30 ms one-way delay (uniform,
// independent per direction), a robot clock ahead by `offset` and running
// fast by `ppm`. Returns |estimate - truth| (us) of a robot timestamp mapped
// to the ground clock, every 10 s after the first minute.
std::vector<double> Simulate(double offset_us, double ppm, int trips, uint64_t seed, ClockSync* sync) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> leg(20000, 80000);
  auto robot = [&](double g) { return g * (1 + ppm * 1e-6) + offset_us; };
  std::vector<double> err;
  double g = 5e9;
  for (int i = 0; i < trips; ++i, g += 250000) {
    const double up = leg(rng), down = leg(rng);
    const int64_t t1 = static_cast<int64_t>(g);
    const int64_t t2 = static_cast<int64_t>(robot(g + up));
    const int64_t t3 = t2 + 200;
    const int64_t t4 = static_cast<int64_t>(g + up + 200 / (1 + ppm * 1e-6) + down);
    sync->Add(t1, t2, t3, t4);
    if (i >= 240 && i % 40 == 0)
      err.push_back(std::abs(static_cast<double>(sync->ToGround(static_cast<int64_t>(robot(g)))) - g));
  }
  return err;
}

// The target: within 2 ms under 50 +- 30 ms jitter. Over 20 seeds x
// 1-5 min the worst single check was 2.3 ms (0 ppm) and 2.6 ms (20 ppm, a
// crystal's drift); most are below 1.5 ms (docs/results/2026-11-24-robot-link.md).
TEST(ClockSync, OffsetWithin2msUnder50msJitter) {
  for (double ppm : {0.0, 20.0}) {
    int checks = 0, within = 0;
    double worst = 0;
    for (uint64_t seed = 1; seed <= 10; ++seed) {
      ClockSync s;
      for (double e : Simulate(-3.7e9, ppm, 1200, seed, &s)) {
        ++checks;
        within += e < 2000;
        worst = std::max(worst, e);
      }
      EXPECT_TRUE(s.synced());
    }
    EXPECT_GE(within, 0.95 * checks) << ppm << " ppm";
    EXPECT_LT(worst, 3000) << ppm << " ppm";
  }
}

TEST(ClockSync, DriftIsFollowed) {
  // 100 ppm is 6 ms a minute: once certain, the drift is measured.
  for (uint64_t seed = 1; seed <= 5; ++seed) {
    ClockSync s;
    Simulate(1.234e6, 100, 1200, seed, &s);
    EXPECT_NEAR(s.drift_ppm(), 100, 10) << "seed " << seed;
  }
}

TEST(ClockSync, ImpossibleRoundTripsAreIgnored) {
  ClockSync s;
  EXPECT_FALSE(s.Add(100, 50, 40, 200));  // robot replied before it received
  EXPECT_FALSE(s.Add(100, 50, 60, 90));   // came back before it left
  EXPECT_FALSE(s.synced());
  EXPECT_EQ(s.ToGround(12345), 12345);    // identity until synced
  EXPECT_TRUE(s.Add(100, 1150, 1160, 210));
  EXPECT_TRUE(s.synced());
  EXPECT_NEAR(s.OffsetAt(155), 1000, 1);
}

}  // namespace
}  // namespace rumi
