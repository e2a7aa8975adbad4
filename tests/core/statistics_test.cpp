// Robust statistics against closed-form cases.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "momentum/core/statistics.hpp"

using namespace momentum::core;

TEST(GroupedMedian, IsThePlainMedianForDistinctValues) {
  std::vector<double> v{5, 1, 4, 2, 3};
  EXPECT_EQ(grouped_median(v), 3);
  std::vector<double> empty;
  EXPECT_TRUE(std::isnan(grouped_median(empty)));
  std::vector<double> same{2, 2, 2};
  EXPECT_EQ(grouped_median(same), 2);
}

TEST(GroupedMedian, InterpolatesWithinTheBinOfTiedValues) {
  // 1 x 0, 4 x 1, 5 x 2 on a step of 1: the middle (5 of 10) is 4/4 of the way through the
  // ties at 1, whose bin is [0.5, 1.5]: 1.5.
  std::vector<double> v{0, 1, 1, 1, 1, 2, 2, 2, 2, 2};
  EXPECT_DOUBLE_EQ(grouped_median(v), 1.5);
  // Ties at the smallest value: the bin starts at the value itself (magnitudes from 0).
  std::vector<double> w{0, 0, 0, 0, 1, 1};
  EXPECT_DOUBLE_EQ(grouped_median(w), 0 + 0.5 * 3.0 / 4.0);
}

TEST(WhiteNoise, QuantisedNoiseIsNotRoundedToTheStep) {
  // Velocity noise of 2e-3 rad/s reported in steps of 1e-3: the second differences' median is a
  // multiple of the step, so the plain median estimate is 0.003 / 0.6745 / sqrt(6) = 1.816e-3,
  // 10% low. Quantisation adds step^2 / 12 of variance: the estimate must be near
  // sqrt(s^2 + step^2 / 12), and unquantised noise must still give s.
  const double s = 2e-3, step = 1e-3;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal(0, s);
  std::vector<double> exact, quantised;
  for (int k = 0; k < 200000; ++k) {
    const double x = normal(rng);
    exact.push_back(x);
    quantised.push_back(step * std::round(x / step));
  }
  auto estimate = [](const std::vector<double>& x) {
    std::vector<double> d2;
    for (std::size_t k = 1; k + 1 < x.size(); ++k) d2.push_back(std::abs(x[k + 1] - 2 * x[k] + x[k - 1]));
    return white_noise_from_second_differences(d2);
  };
  EXPECT_NEAR(estimate(exact), s, 0.01 * s);
  const double with_steps = std::sqrt(s * s + step * step / 12);
  EXPECT_NEAR(estimate(quantised), with_steps, 0.02 * with_steps);
}
