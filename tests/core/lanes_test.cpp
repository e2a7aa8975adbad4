#include "momentum/core/lanes.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace lanes = momentum::core::lanes;
using lanes::Pair;
using lanes::PairMask;

namespace {

std::uint64_t bits(double x) { return std::bit_cast<std::uint64_t>(x); }

// Values where a pair operation could part from the scalar one: signed zeros, NaN, infinities,
// subnormals, ties.
const std::vector<double>& awkward() {
  static const std::vector<double> values = {0.0,  -0.0, 1.0, -1.0, 2.5, -2.5, std::numeric_limits<double>::quiet_NaN(),
                                             -std::numeric_limits<double>::quiet_NaN(),
                                             std::numeric_limits<double>::infinity(),
                                             -std::numeric_limits<double>::infinity(),
                                             std::numeric_limits<double>::denorm_min(), 1e-300, 1e300};
  return values;
}

}  // namespace

// The signal check runs its joints in pairs and its odd last joint alone, and promises the same
// bits either way: each pair operation is its scalar one in each lane, bit for bit.
TEST(Lanes, PairOperationsAreTheScalarOnesLaneByLane) {
  for (double a0 : awkward())
    for (double b0 : awkward())
      for (double a1 : {0.0, -0.0, 3.0, std::numeric_limits<double>::quiet_NaN()})
        for (double b1 : {-0.0, 3.0, -7.0}) {
          const double a[2] = {a0, a1}, b[2] = {b0, b1};
          const Pair pa = lanes::load<Pair>(a), pb = lanes::load<Pair>(b);
          double got[2];
          lanes::store(got, lanes::max(pa, pb));
          for (int k = 0; k < 2; ++k) {
            EXPECT_EQ(bits(got[k]), bits(std::max(a[k], b[k]))) << a[k] << " " << b[k];
            EXPECT_EQ(bits(got[k]), bits(lanes::max(a[k], b[k])));
          }
          lanes::store(got, lanes::abs(pa));
          for (int k = 0; k < 2; ++k) EXPECT_EQ(bits(got[k]), bits(std::fabs(a[k])));
          const PairMask less = pa < pb;
          lanes::store(got, lanes::select(less, pa, pb));
          for (int k = 0; k < 2; ++k) EXPECT_EQ(bits(got[k]), bits(a[k] < b[k] ? a[k] : b[k]));
          EXPECT_EQ(lanes::all(less), a[0] < b[0] && a[1] < b[1]);
          EXPECT_EQ(lanes::any(less), a[0] < b[0] || a[1] < b[1]);
        }
}

// The per-joint loop visits every joint once, in pairs and an odd last one alone, and all_joints
// stops at the first joint that fails.
TEST(Lanes, JointLoopsVisitEveryJointOnceInPairs) {
  for (std::size_t n : {0u, 1u, 2u, 5u, 6u, 7u}) {
    std::vector<int> visits(n, 0);
    std::vector<std::size_t> pair_starts;
    lanes::for_joints(n, [&]<class V>(std::size_t j) {
      const std::size_t width = sizeof(V) / sizeof(double);
      if (width == 2) pair_starts.push_back(j);
      for (std::size_t k = j; k < j + width; ++k) ++visits.at(k);
    });
    EXPECT_EQ(visits, std::vector<int>(n, 1)) << n << " joints";
    EXPECT_EQ(pair_starts.size(), n / 2) << n << " joints";
    for (std::size_t k = 0; k < pair_starts.size(); ++k) EXPECT_EQ(pair_starts[k], 2 * k);
  }
  // Joint 3 of 7 fails: the pair (2, 3) is the last looked at, and the odd joint 6 is not.
  std::vector<std::size_t> seen;
  const double value[7] = {0, 0, 0, 1, 0, 0, 0};
  const bool all = lanes::all_joints(7, [&]<class V>(std::size_t j) {
    seen.push_back(j);
    return lanes::all(lanes::load<V>(value + j) == 0.0);
  });
  EXPECT_FALSE(all);
  EXPECT_EQ(seen, (std::vector<std::size_t>{0, 2}));
  EXPECT_TRUE(lanes::all_joints(7, [&]<class V>(std::size_t j) { return lanes::all(lanes::load<V>(value + j) < 2.0); }));
  EXPECT_TRUE(lanes::all_joints(0, [&]<class V>(std::size_t) { return false; }));
}
