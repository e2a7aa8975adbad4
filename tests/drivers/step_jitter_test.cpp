// StepJitter: a log's own timing jitter against lost samples, on clocks with known jitter.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "momentum/drivers/observe_stream.hpp"

namespace mo = momentum::observer;
namespace md = momentum::drivers;

namespace {

// Steps of a clock of period T whose sampling instants jitter by sigma * T (normal), every
// `lost`-th sample dropped (0: none). Returns the jitter statistics.
md::StepJitter clock(double sigma, int steps, int lost, unsigned seed) {
  std::mt19937_64 random(seed);
  std::normal_distribution<double> normal(0.0, sigma);
  const double period = 0.008;
  md::StepJitter jitter;
  double previous = normal(random) * period;
  for (int k = 1; k <= steps; ++k) {
    if (lost && k % lost == 0) continue;
    const double t = k * period + normal(random) * period;
    jitter.add(t - previous, period);
    previous = t;
  }
  return jitter;
}

}  // namespace

// The jitter's standard deviation is that of a step (sqrt(2) sigma of the instants), within
// the estimate's spread and the cut at 1.5 periods (which takes 2% off at 15%); at 10% and
// 15% jitter (1 step in 5,000 and in 110 over 1.5 periods, which the observer checks as gaps
// and which all warned before), no gap of 450,000 steps (an hour at 125 Hz) is unusual.
TEST(StepJitter, OrdinaryJitterIsNoGap) {
  for (const double sigma : {0.1, 0.15}) {
    const md::StepJitter j = clock(sigma, 450000, 0, 7);
    EXPECT_NEAR(j.sigma(), std::sqrt(2.0) * sigma, 0.04 * sigma);
    EXPECT_GT(j.gaps(), 50u);
    EXPECT_EQ(j.unusual_gaps(), 0u) << "sigma " << sigma;
    EXPECT_EQ(j.longest_unusual(), 0.0);
  }
}

// One sample in 100 lost: a step of 2 periods, give or take the jitter. Unusual are most of
// them at 10% jitter (the line at k = 5.8 step deviations is 0.82: of steps 2 +- 0.14 periods,
// 1 - P(Z < -1.27) = 90% beyond), and all of them on a clean clock.
TEST(StepJitter, LostSamplesAre) {
  const md::StepJitter jittered = clock(0.1, 450000, 100, 7);
  EXPECT_NEAR(jittered.gap_line(), std::sqrt(2 * std::log(50.0 * jittered.steps())) * jittered.sigma(), 1e-12);
  EXPECT_GT(jittered.unusual_gaps(), 0.85 * 4500);
  EXPECT_LT(jittered.unusual_gaps(), 0.95 * 4500);
  EXPECT_LE(jittered.unusual_gaps(), jittered.gaps());
  const md::StepJitter clean = clock(0.0, 45000, 100, 7);
  EXPECT_LT(clean.sigma(), 1e-9);  // the rounding of k T
  EXPECT_EQ(clean.gap_line(), 0.5);
  EXPECT_EQ(clean.unusual_gaps(), 449u);  // the last sample lost has no step after it
  EXPECT_NEAR(clean.longest_unusual(), 2.0, 1e-9);
}
