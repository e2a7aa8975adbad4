// detail::sin_cos (the momentum pass's sin and cos, fdlibm's method, sin_cos_kernel.hpp)
// against libm's sin and cos: within 1 ulp of them over joint angles, over many turns, at the
// doubles nearest to multiples of pi/2 (where the reduction loses the most), for tiny angles,
// and libm's own values beyond the reduced range and for inf and NaN.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <random>

#include "momentum/model/dynamics.hpp"

namespace {

namespace mm = momentum::model;

// Distance in units in the last place between two finite doubles of the same sign.
std::int64_t ulp_distance(double a, double b) {
  if (a == b) return 0;
  if (std::signbit(a) != std::signbit(b)) return std::numeric_limits<std::int64_t>::max();
  const auto ia = std::bit_cast<std::int64_t>(std::fabs(a)), ib = std::bit_cast<std::int64_t>(std::fabs(b));
  return ia > ib ? ia - ib : ib - ia;
}

struct Worst {
  std::int64_t ulps = 0;
  double at = 0;
  long differing = 0, count = 0;
  void add(double x) {
    double s, c;
    mm::detail::sin_cos(x, &s, &c);
    const std::int64_t e = std::max(ulp_distance(s, std::sin(x)), ulp_distance(c, std::cos(x)));
    ++count;
    differing += e != 0;
    if (e > ulps) {
      ulps = e;
      at = x;
    }
  }
};

void expect_within_an_ulp(const Worst& w, const char* what) {
  std::printf("%s: %ld values, %ld differ from libm, by at most %lld ulp (x = %.17g)\n", what, w.count,
              w.differing, static_cast<long long>(w.ulps), w.at);
  EXPECT_LE(w.ulps, 1) << what << " at x = " << w.at;
}

}  // namespace

TEST(SinCos, WithinAnUlpOfLibmOverJointAngles) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> turn(-2 * std::numbers::pi, 2 * std::numbers::pi);
  Worst w;
  for (int k = 0; k < 1000000; ++k) w.add(turn(rng));
  expect_within_an_ulp(w, "|x| < 2 pi");
}

TEST(SinCos, WithinAnUlpOfLibmOverManyTurns) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> wide(-mm::detail::kSinCosRange, mm::detail::kSinCosRange);
  Worst w;
  for (int k = 0; k < 1000000; ++k) w.add(wide(rng));
  expect_within_an_ulp(w, "|x| < 2^19");
}

TEST(SinCos, WithinAnUlpOfLibmNearMultiplesOfHalfPi) {
  // The doubles around k pi/2 for k up to 2^19 / (pi/2): sin or cos is nearly 0 there, and any
  // error of the reduction shows whole.
  Worst w;
  for (long k = 1; k * (std::numbers::pi / 2) < mm::detail::kSinCosRange; k += 97) {
    const double x = k * (std::numbers::pi / 2);
    double around = x;
    for (int step = 0; step < 3; ++step) around = std::nextafter(around, 0.0);
    for (int step = 0; step < 7; ++step, around = std::nextafter(around, 2 * x)) {
      w.add(around);
      w.add(-around);
    }
  }
  expect_within_an_ulp(w, "near k pi/2");
}

TEST(SinCos, TinyAnglesAndZeros) {
  Worst w;
  for (double x = 1e-300; x < 1e-2; x *= 1.37) {
    w.add(x);
    w.add(-x);
  }
  w.add(5e-324);
  expect_within_an_ulp(w, "tiny");
  double s, c;
  mm::detail::sin_cos(0.0, &s, &c);
  EXPECT_EQ(s, 0.0);
  EXPECT_EQ(c, 1.0);
  mm::detail::sin_cos(-0.0, &s, &c);
  EXPECT_EQ(s, 0.0);
  EXPECT_TRUE(std::signbit(s));
  EXPECT_EQ(c, 1.0);
}

TEST(SinCos, LibmBeyondTheRangeAndForInfAndNan) {
  for (double x : {mm::detail::kSinCosRange, -mm::detail::kSinCosRange, 1e6, -3e9, 1e300}) {
    double s, c;
    mm::detail::sin_cos(x, &s, &c);
    EXPECT_EQ(s, std::sin(x)) << x;
    EXPECT_EQ(c, std::cos(x)) << x;
  }
  for (double x : {std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                   std::numeric_limits<double>::quiet_NaN()}) {
    double s = 0, c = 0;
    mm::detail::sin_cos(x, &s, &c);
    EXPECT_TRUE(std::isnan(s)) << x;
    EXPECT_TRUE(std::isnan(c)) << x;
  }
}
