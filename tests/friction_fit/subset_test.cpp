// The global search's subset of long data (fit/subset.hpp) and the fit that uses it: the
// windows keep every stratum, carry their warm-ups, and the fit searched on them and polished on
// all the data agrees with the fit searched on all the data within the reported uncertainty.
#include <gtest/gtest.h>

#include <cmath>

#include "momentum/friction_fit/friction_fit.hpp"
#include "momentum/friction_fit/subset.hpp"
#include "synthetic.hpp"

namespace friction_fit = momentum::friction_fit;
namespace mf = momentum::friction;
using friction_fit::testing::kPaperObserver;
using friction_fit::testing::kTable1;
using friction_fit::testing::long_motion;
using friction_fit::testing::make_synthetic;
using friction_fit::testing::SyntheticOptions;

TEST(SearchSubset, ShortDataAreSearchedWhole) {
  const auto data = make_synthetic(kTable1[0], kPaperObserver, SyntheticOptions{});
  std::vector<std::size_t> starts, origin;
  friction_fit::SubsetSummary summary;
  const auto subset = friction_fit::search_subset(data.series, kPaperObserver, {}, &starts, &summary, &origin);
  EXPECT_FALSE(summary.used);
  EXPECT_EQ(subset.size(), data.series.size());
  EXPECT_EQ(summary.counted, data.series.scored_count());
  ASSERT_EQ(origin.size(), subset.size());
  EXPECT_EQ(origin.back(), subset.size() - 1);
}

TEST(SearchSubset, WindowsKeepEveryStratumAndTheirWarmUps) {
  const auto data = make_synthetic(kTable1[0], kPaperObserver, long_motion(3));
  friction_fit::SubsetOptions options;
  options.max_samples = 2000;
  options.windows = 10;
  std::vector<std::size_t> starts, origin;
  friction_fit::SubsetSummary summary;
  const auto subset = friction_fit::search_subset(data.series, kPaperObserver, options, &starts, &summary, &origin);
  ASSERT_TRUE(summary.used);
  const std::size_t window = options.max_samples / static_cast<std::size_t>(options.windows);
  // The budget, overshot by at most the last window picked.
  EXPECT_GE(summary.counted, options.max_samples);
  EXPECT_LE(summary.counted, options.max_samples + window);
  EXPECT_EQ(summary.counted, subset.scored_count());
  EXPECT_EQ(summary.counted_total, data.series.scored_count());
  ASSERT_EQ(origin.size(), subset.size());
  ASSERT_EQ(starts.size(), summary.segments);
  ASSERT_GE(starts.size(), 2u);
  // Every stratum present in the data is in the subset.
  std::size_t chosen = 0;
  for (int c = 0; c < friction_fit::kSubsetStrata; ++c) {
    const auto u = static_cast<std::size_t>(c);
    if (summary.strata_total[u] > 0) {
      EXPECT_GT(summary.strata_chosen[u], 0u) << "stratum " << c;
    }
    EXPECT_LE(summary.strata_chosen[u], summary.strata_total[u]);
    chosen += summary.strata_chosen[u];
  }
  EXPECT_EQ(chosen, summary.counted);
  // Samples are copies of the data's, in time order; each segment restarts the model, and its
  // warm-up (5 / K1 = 0.1 s: 13 samples at 125 Hz) does not count.
  for (std::size_t k = 0; k < subset.size(); ++k) {
    EXPECT_EQ(subset.dq[k], data.series.dq[origin[k]]);
    EXPECT_EQ(subset.r[k], data.series.r[origin[k]]);
    if (k > 0) {
      EXPECT_GT(subset.t[k], subset.t[k - 1]);
    }
    if (k > 0 && subset.restart[k] < 2) {
      EXPECT_EQ(origin[k], origin[k - 1] + 1);
    }
  }
  for (std::size_t g = 0; g < starts.size(); ++g) {
    EXPECT_EQ(subset.restart[starts[g]], 2);
    if (origin[starts[g]] == 0) continue;  // the data's own start needs no warm-up
    for (std::size_t k = starts[g]; k < starts[g] + 13; ++k) EXPECT_EQ(subset.scored[k], 0) << k;
  }
}

TEST(SearchSubset, InvalidOptions) {
  friction_fit::SubsetOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why));
  o.windows = 0;
  EXPECT_FALSE(o.IsValid(&why));
  o.windows = 16;
  o.max_samples = 100;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("8 samples"), std::string::npos);
}

// The point of the subset, on one joint (all three: subset_slow_test.cpp): the search on 1,000
// of 6,250 samples, polished on all of them, ends where the search on all of them ends, within
// the uncertainty the fit reports.
TEST(SearchSubset, FitAgreesWithTheFullSearchWithinItsUncertainty) {
  SyntheticOptions so = long_motion(50);
  so.samples = 6250;
  const auto data = make_synthetic(kTable1[0], kPaperObserver, so);
  friction_fit::FitOptions options;
  options.global.genetic = friction_fit::quick_search();
  options.compare_static = false;
  options.search_subset.max_samples = 1000;
  const auto sub = friction_fit::fit_joint(data.series, kPaperObserver, options, 7);
  options.search_subset.max_samples = 0;
  const auto full = friction_fit::fit_joint(data.series, kPaperObserver, options, 7);
  ASSERT_TRUE(sub.model.subset.used);
  EXPECT_LE(sub.model.metrics.cost, full.model.metrics.cost * (1 + 1e-3));
  for (int i = 2; i < 6; ++i) {
    const auto& a = sub.model.estimates[static_cast<std::size_t>(i)];
    const auto& b = full.model.estimates[static_cast<std::size_t>(i)];
    EXPECT_LT(std::abs(a.value - b.value), b.uncertainty)
        << mf::kParameterNames[i] << ": subset " << a.value << ", full " << b.value;
  }
}

// The fit's subset (FitOptions::fit_subset, issue 30): on long data the polish and the
// uncertainties see a bounded set of windows, so the fit's cost stops growing with the hours.
// The metrics still count every sample; the uncertainties say what the subset determines (so
// they are larger than those of a fit on every sample, in about the square root of the ratio
// of the counts), and the estimate is within them of the fit on every sample and within three
// of them of the truth.
TEST(FitSubset, PolishAndUncertaintiesOnABoundedShareOfLongData) {
  SyntheticOptions so = long_motion(61);
  so.samples = 25000;  // 200 s at 125 Hz
  const auto data = make_synthetic(kTable1[1], kPaperObserver, so);
  friction_fit::FitOptions options;
  options.global.genetic = friction_fit::quick_search();
  options.compare_static = false;
  options.fit_subset.max_samples = 4000;
  const auto sub = friction_fit::fit_joint(data.series, kPaperObserver, options, 7);
  options.fit_subset.max_samples = 0;
  const auto full = friction_fit::fit_joint(data.series, kPaperObserver, options, 7);
  ASSERT_TRUE(sub.model.fit_subset.used);
  ASSERT_FALSE(full.model.fit_subset.used);
  // Windows of at least 2 / K2 = 10 s (1,250 samples): the budget, overshot by one window at most.
  EXPECT_LE(sub.model.fit_subset.counted, 4000u + 1250u);
  EXPECT_GE(sub.model.fit_subset.counted, 4000u);
  EXPECT_EQ(sub.model.fit_subset.counted_total, data.series.scored_count());
  EXPECT_EQ(sub.model.metrics.samples, data.series.scored_count());
  EXPECT_EQ(full.model.metrics.samples, data.series.scored_count());
  EXPECT_LE(sub.model.metrics.cost, full.model.metrics.cost * 1.01);
  double truth[mf::Parameters<double>::kSize];
  kTable1[1].to_array(truth);
  const double ratio = std::sqrt(static_cast<double>(data.series.scored_count()) / sub.model.fit_subset.counted);
  for (int i = 2; i < 6; ++i) {
    const auto& a = sub.model.estimates[static_cast<std::size_t>(i)];
    const auto& b = full.model.estimates[static_cast<std::size_t>(i)];
    ASSERT_TRUE(std::isfinite(a.standard_error) && std::isfinite(b.standard_error)) << mf::kParameterNames[i];
    EXPECT_GT(a.standard_error, 0.5 * ratio * b.standard_error) << mf::kParameterNames[i];
    EXPECT_LT(a.standard_error, 2.0 * ratio * b.standard_error) << mf::kParameterNames[i];
    EXPECT_LT(std::abs(a.value - b.value), a.uncertainty)
        << mf::kParameterNames[i] << ": subset " << a.value << ", full " << b.value;
    EXPECT_LT(std::abs(a.value - truth[i]), 3 * a.uncertainty) << mf::kParameterNames[i];
  }
}
