// The one seeded random source: the values below were recorded from the simulator's own
// generator before it moved to core/ (mo-sim's published numbers depend on them), so a change
// of derivation or transform shows here first.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <set>

#include "momentum/core/random.hpp"

using momentum::core::derive_seed;
using momentum::core::normal_at;
using momentum::core::Random;
using momentum::core::splitmix64;

TEST(Random, SeedDerivationIsSplitMix64) {
  EXPECT_EQ(derive_seed(1, 0), 10451216379200822465ULL);
  EXPECT_EQ(derive_seed(1, 5), 14072917602864530048ULL);
  // derive_seed(seed, 0) is one SplitMix64 step of the seed.
  EXPECT_EQ(derive_seed(1, 0), splitmix64(1));
  EXPECT_NE(derive_seed(1, 1), derive_seed(2, 1));
  EXPECT_NE(derive_seed(1, 1), derive_seed(1, 2));
}

TEST(Random, ReproducesTheRecordedStream) {
  // Recorded from the simulator's generator (lib/src/sim/random.cpp before the move).
  Random r(derive_seed(42, 3));
  EXPECT_EQ(r.uniform(), 0.009692101716383239);
  EXPECT_EQ(r.normal(), 0.80941121729310817);
  EXPECT_EQ(r.normal(), -0.89651455594104035);  // the second value of the Box-Muller pair
  EXPECT_EQ(r.integer(-5, 5), -1);
  EXPECT_EQ(r.uniform(-2.0, 5.0), 2.311147094485829);
  EXPECT_FALSE(r.chance(0.5));
  Random s(derive_seed(42, 3));
  EXPECT_EQ(s.next(), 178787719898484520ULL);
}

TEST(Random, SameSeedSameNumbers) {
  Random a(derive_seed(7, 1)), b(derive_seed(7, 1));
  for (int k = 0; k < 1000; ++k) {
    ASSERT_EQ(a.uniform(), b.uniform());
    ASSERT_EQ(a.normal(), b.normal());
  }
}

TEST(Random, DrawsStayInTheirRanges) {
  Random r(derive_seed(3, 0));
  std::set<int> seen;
  for (int k = 0; k < 10000; ++k) {
    const double u = r.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    const double v = r.uniform(-2.0, 5.0);
    ASSERT_GE(v, -2.0);
    ASSERT_LT(v, 5.0);
    const int i = r.integer(-3, 3);
    ASSERT_GE(i, -3);
    ASSERT_LE(i, 3);
    seen.insert(i);
    ASSERT_LT(r.below(7), 7u);
    ASSERT_TRUE(std::isfinite(r.normal()));
  }
  EXPECT_EQ(seen.size(), 7u);
  EXPECT_FALSE(r.chance(0.0));
  EXPECT_TRUE(r.chance(1.0));
}

TEST(Random, NormalHasUnitVariance) {
  Random r(derive_seed(11, 0));
  double sum = 0, squares = 0;
  const int n = 200000;
  for (int k = 0; k < n; ++k) {
    const double x = r.normal();
    sum += x;
    squares += x * x;
  }
  EXPECT_NEAR(sum / n, 0.0, 0.01);
  EXPECT_NEAR(squares / n, 1.0, 0.01);
}

TEST(Random, NormalAtDependsOnlyOnTheKey) {
  EXPECT_EQ(normal_at(0), -0.066635602530510693);
  EXPECT_EQ(normal_at(12345), 0.80830838360435109);
  EXPECT_EQ(normal_at(derive_seed(5, 9)), normal_at(derive_seed(5, 9)));
  double squares = 0;
  const int n = 100000;
  for (int k = 0; k < n; ++k) {
    const double x = normal_at(derive_seed(17, static_cast<std::uint64_t>(k)));
    ASSERT_TRUE(std::isfinite(x));
    squares += x * x;
  }
  EXPECT_NEAR(squares / n, 1.0, 0.02);
}

TEST(Random, UnpairedNormalIsTheFittersDraw) {
  // The fitter's former generator: Box-Muller on 1 - u1 and u2, one value per call.
  Random r(derive_seed(9, 0)), u(derive_seed(9, 0));
  for (int k = 0; k < 100; ++k) {
    const double u1 = 1.0 - u.uniform();
    const double u2 = u.uniform();
    ASSERT_EQ(r.normal_unpaired(), std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * 3.141592653589793 * u2));
  }
}
