// The search subset on long data, all three joints of the paper arm (subset_test.cpp has one):
// slow because the reference fit searches all 12,500 samples.
#include <gtest/gtest.h>

#include <cmath>

#include "momentum/friction_fit/friction_fit.hpp"
#include "synthetic.hpp"

namespace friction_fit = momentum::friction_fit;
namespace mf = momentum::friction;
using friction_fit::testing::kPaperObserver;
using friction_fit::testing::kTable1;
using friction_fit::testing::long_motion;
using friction_fit::testing::make_synthetic;
using friction_fit::testing::SyntheticOptions;

// The point of the subset: the search on 2,000 of 12,500 samples, polished on all of them, ends
// where the search on all of them ends, within the uncertainty the fit reports; both within
// three uncertainties of the truth. Static parameters (the bristles are not identifiable at
// 125 Hz: they are compared only where the fit says they are).
TEST(SearchSubsetSlow, FitAgreesWithTheFullSearchWithinItsUncertainty) {
  for (int joint = 0; joint < 3; ++joint) {
    const auto data = make_synthetic(kTable1[joint], kPaperObserver, long_motion(50 + static_cast<std::uint64_t>(joint)));
    friction_fit::FitOptions options;
    options.global.genetic = friction_fit::quick_search();
    options.compare_static = false;
    options.search_subset.max_samples = 2000;
    const auto sub = friction_fit::fit_joint(data.series, kPaperObserver, options, 7);
    options.search_subset.max_samples = 0;
    const auto full = friction_fit::fit_joint(data.series, kPaperObserver, options, 7);
    ASSERT_TRUE(sub.model.subset.used);
    ASSERT_FALSE(full.model.subset.used);
    EXPECT_EQ(sub.model.metrics.samples, full.model.metrics.samples);
    EXPECT_LE(sub.model.metrics.cost, full.model.metrics.cost * (1 + 1e-3)) << "joint " << joint + 1;
    double truth[mf::Parameters<double>::kSize];
    kTable1[joint].to_array(truth);
    for (int i = 0; i < 6; ++i) {
      const auto& a = sub.model.estimates[static_cast<std::size_t>(i)];
      const auto& b = full.model.estimates[static_cast<std::size_t>(i)];
      if (!(i >= 2 || (a.identifiable && b.identifiable && !a.at_bound && !b.at_bound))) continue;
      ASSERT_TRUE(std::isfinite(b.uncertainty)) << mf::kParameterNames[i];
      EXPECT_LT(std::abs(a.value - b.value), b.uncertainty)
          << "joint " << joint + 1 << " " << mf::kParameterNames[i] << ": subset " << a.value << ", full " << b.value;
      EXPECT_NEAR(a.uncertainty, b.uncertainty, 0.1 * b.uncertainty) << mf::kParameterNames[i];
      EXPECT_LT(std::abs(a.value - truth[i]), 3 * a.uncertainty) << "joint " << joint + 1 << " " << mf::kParameterNames[i];
    }
  }
}
