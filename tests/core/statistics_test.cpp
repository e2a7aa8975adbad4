// Robust statistics against closed-form cases.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
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

// RunningMedian selects by buckets of order keys: its median must be the one an nth_element over
// the last N values gives (the value selected afresh), bit for bit, whether it is updated after
// every push, every few, or after more pushes than the window holds; with tied values, values
// of both signs, zeros of both signs and infinities, values over many decades, while the window
// fills, and with a NaN in the window (then selected with nth_element).
TEST(RunningMedian, EqualsTheMedianSelectedAfreshAtEveryUpdate) {
  constexpr int kN = 32;
  auto selected = [](const std::vector<double>& history) {
    const std::size_t count = std::min<std::size_t>(history.size(), kN);
    std::vector<double> last(history.end() - static_cast<std::ptrdiff_t>(count), history.end());
    const std::size_t mid = count / 2;
    std::nth_element(last.begin(), last.begin() + static_cast<std::ptrdiff_t>(mid), last.end());
    double median = last[mid];
    if (count % 2 == 0) median = 0.5 * (median + *std::max_element(last.begin(), last.begin() + static_cast<std::ptrdiff_t>(mid)));
    return median;
  };
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> any(0.0, 1.0);
  std::uniform_int_distribution<int> few(0, 4);
  std::uniform_int_distribution<int> gap(1, 80);  // pushes between updates: up to 2.5 N
  std::normal_distribution<double> normal(0.0, 1.0);
  int updates = 0;
  for (int series = 0; series < 5; ++series) {
    RunningMedian<kN> median;
    std::vector<double> history;
    int until_update = 1;
    for (int k = 0; k < 20000; ++k) {
      double v = series == 1 ? 1e-4 * few(rng) : any(rng);
      if (series == 3) v = few(rng) == 0 ? (few(rng) % 2 ? 0.0 : -0.0) : normal(rng);
      if (series == 3 && k % 211 == 7) v = k % 2 ? HUGE_VAL : -HUGE_VAL;
      if (series == 4) v = std::exp(20 * normal(rng));
      if (series == 2 && k % 997 == 500) v = std::nan("");
      median.push(v);
      history.push_back(v);
      if (--until_update > 0) continue;
      until_update = (k / 1000) % 2 ? gap(rng) : 1 + few(rng);
      const double expected = selected(history);
      const double got = median.update();
      bool nan_in_window = false;
      for (std::size_t m = history.size() > kN ? history.size() - kN : 0; m < history.size(); ++m)
        nan_in_window = nan_in_window || std::isnan(history[m]);
      if (nan_in_window) continue;  // the selection with a NaN is unspecified, but finite values follow
      ASSERT_EQ(got, expected) << "series " << series << ", push " << k;
      ASSERT_EQ(median.value(), expected);
      ++updates;
    }
  }
  EXPECT_GT(updates, 16000);
  RunningMedian<4> m;
  EXPECT_EQ(m.update(), 0);
  for (double v : {3.0, 1.0, 2.0, 10.0, 0.0}) m.push(v);
  EXPECT_EQ(m.update(), 1.5);  // 3 left: {0, 1, 2, 10}
}

// The lower bound kept between updates is at most the window's exact median after every push
// while bound_holds(), through a scale that drifts, falls by a factor of 100 (an arm coming to
// rest), rises again, and values at rest that are 0; and a push that leaves it failing is
// seen: a window of 1s after an update (bound 0.75) fails once 64 of 128 values are 0.5.
TEST(RunningMedianBank, LowerBoundHoldsBetweenUpdates) {
  constexpr int kN = 128;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_int_distribution<int> few(0, 3);
  RunningMedianBank<kN> median(1);
  RunningMedian<kN> exact;
  int updates = 0;
  for (int k = 0; k < 40000; ++k) {
    double scale = 1.0;
    if (k % 10000 >= 2000 && k % 10000 < 4000) scale = 1.0 - 0.99 * (k % 10000 - 2000) / 2000.0;
    if (k % 10000 >= 4000) scale = 0.01 + 3.0 * (k % 10000 - 4000) / 6000.0;
    double v = std::fabs(scale * normal(rng));
    if (k >= 30000) v = 1e-4 * few(rng);
    median.push(&v);
    exact.push(v);
    // A bound of 0 always holds: computed first as the signal check does through its warm-up.
    if (k < 16 || !median.bound_holds(0)) {
      median.update(0);
      ++updates;
    }
    ASSERT_TRUE(median.bound_holds(0));
    ASSERT_LE(median.lower_bound(0), exact.update()) << "push " << k;
  }
  // 16 in the warm-up, and about log(100) / log(4/3) = 16 as the scale falls by 100: far fewer
  // recomputations than pushes.
  EXPECT_LT(updates, 60);
  RunningMedianBank<kN> ones(1);
  const double one = 1.0, half = 0.5;
  for (int k = 0; k < kN; ++k) ones.push(&one);
  EXPECT_EQ(ones.update(0), 1.0);
  EXPECT_EQ(ones.lower_bound(0), 0.75);
  for (int k = 0; k < 63; ++k) ones.push(&half);
  EXPECT_TRUE(ones.bound_holds(0));
  EXPECT_TRUE(ones.bounds_held_at_push());
  ones.push(&half);
  EXPECT_FALSE(ones.bound_holds(0));
  EXPECT_FALSE(ones.bounds_held_at_push());
  EXPECT_EQ(ones.update(0), 0.75);  // the mean of 0.5 and 1
}

// A bank of windows pushed together: each window's median is RunningMedian's, bit for bit;
// its lower bound is 0.75 times the lower middle value of the window at its update (selected
// afresh), and bound_holds() says, after every push, whether at most the lower half of the
// window's values lie below that bound (counted afresh); bounds_held_at_push() is every
// window's bound_holds() after the push. Windows are updated on their own schedules (as the
// signal check updates a joint's scale when its bound fails), on values of other scales and
// kinds (ties, zeros, a NaN now and then), while the ring fills and once it slides.
TEST(RunningMedianBank, IsRunningMedianPerWindowWithItsBoundCountedAfresh) {
  constexpr int kN = 128, kWindows = 7;
  std::mt19937_64 rng(17);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_int_distribution<int> few(0, 5);
  std::uniform_int_distribution<int> gap(1, 300);
  RunningMedianBank<kN> bank(kWindows);
  RunningMedianBank<kN, false> plain(kWindows);  // the same medians without the bound
  std::vector<RunningMedian<kN>> single(kWindows);
  std::vector<std::vector<double>> history(kWindows);
  std::vector<double> bound(kWindows, 0.0);
  std::vector<int> until_update(kWindows, 1);
  std::vector<double> values(kWindows);
  EXPECT_EQ(bank.windows(), kWindows);
  EXPECT_EQ(bank.update(3), 0);  // empty
  single[3].update();
  auto last = [&](int k) {  // the window: the last kN values of history k
    const std::vector<double>& h = history[static_cast<std::size_t>(k)];
    return std::vector<double>(h.end() - std::min<std::ptrdiff_t>(kN, static_cast<std::ptrdiff_t>(h.size())), h.end());
  };
  int updates = 0, bound_failures = 0;
  for (int push = 0; push < 30000; ++push) {
    for (int k = 0; k < kWindows; ++k) {
      const double scale = k == 0 ? 1.0 : std::exp(3.0 * std::sin(1e-3 * push + k));  // drifts by decades
      double v = std::fabs(scale * normal(rng));
      if (k == 1) v = 1e-4 * few(rng);  // quantised, many ties and zeros
      if (k == 2 && push % 4999 == 100) v = std::nan("");
      values[static_cast<std::size_t>(k)] = v;
      single[static_cast<std::size_t>(k)].push(v);
      history[static_cast<std::size_t>(k)].push_back(v);
    }
    bank.push(values.data());
    plain.push(values.data());
    ASSERT_EQ(bank.full(), single[0].full());
    bool all_held = true;
    for (int k = 0; k < kWindows; ++k) {
      const std::vector<double> window = last(k);
      const auto below = std::count_if(window.begin(), window.end(), [&](double x) { return x < bound[static_cast<std::size_t>(k)]; });
      const bool holds = below <= (static_cast<std::ptrdiff_t>(window.size()) - 1) / 2;
      ASSERT_EQ(bank.bound_holds(k), holds) << "window " << k << ", push " << push;
      all_held = all_held && holds;
      ASSERT_EQ(bank.pushes_since_update(k), single[static_cast<std::size_t>(k)].pushes_since_update());
    }
    ASSERT_EQ(bank.bounds_held_at_push(), all_held);
    for (int k = 0; k < kWindows; ++k) {
      const bool fails = !bank.bound_holds(k);
      bound_failures += fails;
      if (--until_update[static_cast<std::size_t>(k)] > 0 && !fails) continue;
      until_update[static_cast<std::size_t>(k)] = k % 2 ? gap(rng) : 1 + few(rng);
      const double expected = single[static_cast<std::size_t>(k)].update();
      const double got = bank.update(k);
      ASSERT_EQ(std::bit_cast<std::uint64_t>(plain.update(k)), std::bit_cast<std::uint64_t>(got));
      ++updates;
      std::vector<double> window = last(k);
      if (std::any_of(window.begin(), window.end(), [](double x) { return std::isnan(x); })) {
        bound[static_cast<std::size_t>(k)] = bank.lower_bound(k);  // unspecified with a NaN; followed
        continue;
      }
      ASSERT_EQ(std::bit_cast<std::uint64_t>(got), std::bit_cast<std::uint64_t>(expected)) << "window " << k;
      ASSERT_EQ(bank.value(k), expected);
      const std::size_t lower_rank = (window.size() - 1) / 2;
      std::nth_element(window.begin(), window.begin() + static_cast<std::ptrdiff_t>(lower_rank), window.end());
      bound[static_cast<std::size_t>(k)] = 0.75 * window[lower_rank];
      ASSERT_EQ(bank.lower_bound(k), bound[static_cast<std::size_t>(k)]) << "window " << k;
      ASSERT_TRUE(bank.bound_holds(k));
      ASSERT_EQ(bank.pushes_since_update(k), 0);
    }
  }
  EXPECT_GT(updates, 30000);
  EXPECT_GT(bound_failures, 100);  // the bound's failures were exercised, not only the schedule
}

// The sorted window gives RunningMedian's median bit for bit after every push: while the window
// fills (odd and even counts) and once it slides, with repeated values (a stream's time steps
// take few distinct values) and with arbitrary ones; and the median of a known window.
TEST(SortedRunningMedian, EqualsRunningMedianAfterEveryPush) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> any(-1.0, 1.0);
  std::uniform_int_distribution<int> few(0, 3);
  for (int series = 0; series < 2; ++series) {
    RunningMedian<16> reference;
    SortedRunningMedian<16> sorted;
    for (int k = 0; k < 2000; ++k) {
      const double v = series == 0 ? any(rng) : 0.008 + 0.001 * few(rng);
      reference.push(v);
      const double expected = reference.update();
      ASSERT_EQ(sorted.push(v), expected) << "series " << series << ", push " << k;
      ASSERT_EQ(sorted.value(), expected);
      ASSERT_EQ(sorted.full(), reference.full());
    }
  }
  SortedRunningMedian<4> m;
  EXPECT_EQ(m.value(), 0);
  EXPECT_EQ(m.push(3), 3);
  EXPECT_EQ(m.push(1), 2);     // {1, 3}
  EXPECT_EQ(m.push(2), 2);     // {1, 2, 3}
  EXPECT_EQ(m.push(10), 2.5);  // {1, 2, 3, 10}
  EXPECT_EQ(m.push(0), 1.5);   // 3 leaves: {0, 1, 2, 10}
}
