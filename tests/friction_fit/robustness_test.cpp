// The split of what the friction model leaves (robustness.hpp), on constructed leftovers: a
// gravity-like torque of the positions is found position-dependent, a velocity-shaped misfit
// and white noise are not; the fractions match the variances put in.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "momentum/friction_fit/robustness.hpp"
#include "momentum/observer/filter.hpp"

namespace friction_fit = momentum::friction_fit;

namespace {

const momentum::observer::Gains kObserver{50.0, 0.2, 0.0};  // the paper arm's

// Two joints moving like the paper's trajectory at 125 Hz; r is irrelevant here but sized.
friction_fit::JointSeries two_joint_motion() {
  friction_fit::JointSeries s;
  s.joint = 2;
  auto positions = std::make_shared<friction_fit::Positions>(2);
  const double w = 2 * std::numbers::pi * 0.2;
  for (int k = 0; k < 2000; ++k) {
    const double t = 0.008 * k;
    s.t.push_back(t);
    (*positions)[0].push_back(0.6 * std::sin(w * t));
    (*positions)[1].push_back(0.7 + 0.6 * std::sin(w * t + 0.5));
    s.dq.push_back(0.6 * w * std::cos(w * t + 0.5));
    s.r.push_back(8.0 * (s.dq.back() > 0 ? 1 : -1));
    s.restart.push_back(k == 0 ? 2 : 0);
    s.scored.push_back(1);
  }
  s.positions = positions;
  return s;
}

// A torque sequence through the observer's filter, as the observer would see it.
std::vector<double> observed(const friction_fit::JointSeries& s, const std::vector<double>& torque) {
  momentum::observer::DisturbanceFilter<double> h(kObserver);
  std::vector<double> out;
  for (std::size_t k = 0; k < s.size(); ++k) out.push_back(h.step(torque[k], k ? s.t[k] - s.t[k - 1] : 0.0));
  return out;
}

}  // namespace

TEST(ResidualSplit, GravityErrorIsPositionDependent) {
  const auto s = two_joint_motion();
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 0.05);
  std::vector<double> torque(s.size());
  for (std::size_t k = 0; k < s.size(); ++k)
    torque[k] = 0.8 * std::sin((*s.positions)[1][k]) + 0.3 * std::sin((*s.positions)[0][k] + (*s.positions)[1][k]);
  auto e = observed(s, torque);
  double var_signal = 0, mean = 0;
  for (double v : e) mean += v / static_cast<double>(e.size());
  for (double v : e) var_signal += (v - mean) * (v - mean) / static_cast<double>(e.size());
  for (double& v : e) v += noise(rng);
  const auto split = friction_fit::split_residual(s, kObserver, e);
  ASSERT_TRUE(split.computed);
  // The positions explain the torque's share of the variance: var / (var + 0.05^2).
  EXPECT_NEAR(split.position_fraction, var_signal / (var_signal + 0.0025), 0.02);
  EXPECT_TRUE(split.position_dependent);
  EXPECT_EQ(split.position_features, 6u);  // sin, cos of q1, q2, q1 + q2
}

TEST(ResidualSplit, VelocityMisfitAndNoiseAreNot) {
  const auto s = two_joint_motion();
  std::vector<double> torque(s.size());
  for (std::size_t k = 0; k < s.size(); ++k) torque[k] = 0.5 * s.dq[k] * std::abs(s.dq[k]);  // wrong viscous shape
  const auto e = observed(s, torque);
  const auto split = friction_fit::split_residual(s, kObserver, e);
  ASSERT_TRUE(split.computed);
  EXPECT_GT(split.velocity_fraction, 0.99);
  EXPECT_FALSE(split.position_dependent);

  std::mt19937_64 rng(4);
  std::normal_distribution<double> noise(0.0, 0.1);
  std::vector<double> white(s.size());
  for (double& v : white) v = noise(rng);
  const auto none = friction_fit::split_residual(s, kObserver, white);
  EXPECT_LT(none.position_fraction, 0.02);
  EXPECT_FALSE(none.position_dependent);
}

TEST(ResidualSplit, NotComputedWithoutPositions) {
  auto s = two_joint_motion();
  s.positions.reset();
  EXPECT_FALSE(friction_fit::split_residual(s, kObserver, std::vector<double>(s.size(), 0.0)).computed);
}
