// The Dahl model (friction/dahl.hpp) against its closed forms: the pre-sliding curve from rest
// at constant velocity, z(t) = (c / sigma0) (1 - exp(-sigma0 w t / c)), and the bound that
// holds for any velocity sequence, |z| <= c_max / sigma0, so |tau_f - sigma2 w| <= c_max.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "momentum/friction/friction.hpp"
#include "momentum/friction/registry.hpp"

namespace mf = momentum::friction;
using Params = mf::Parameters<double>;

namespace {
// sigma0, sigma2, tau_c, delta_c of a joint (the others are not Dahl's).
const Params kDahl = {2.0e4, 0.0, 0.6, 5.0, 0.0, 1.0, 0.5, 0.0};
}  // namespace

TEST(Dahl, PreSlidingFromRestFollowsTheClosedForm) {
  for (auto update : {mf::LugreUpdate::exact, mf::LugreUpdate::semi_implicit}) {
    for (double w : {0.02, -0.05}) {
      mf::Options options;
      options.update = update;
      mf::JointFriction<double> f(mf::Kind::dahl, kDahl, options);
      EXPECT_EQ(f.step(0.0, 0.0), 0.0);  // at rest: no bristle deflection
      const double c = kDahl.tau_c + std::copysign(kDahl.delta_c, w);
      const double dt = 1e-5;
      double worst = 0;
      for (int k = 1; k <= 2000; ++k) {
        const double tau = f.step(w, dt);
        const double t = k * dt;
        const double z = std::copysign(c / kDahl.sigma0, w) * -std::expm1(-kDahl.sigma0 * std::abs(w) * t / c);
        worst = std::max(worst, std::abs(tau - (kDahl.sigma0 * z + kDahl.sigma2 * w)));
      }
      // Exact for a velocity constant over the step; backward Euler to first order in dt.
      EXPECT_LT(worst, update == mf::LugreUpdate::exact ? 1e-12 : 0.02) << w;
    }
  }
}

TEST(Dahl, BristleAndTorqueStayBoundedForAnyVelocities) {
  std::mt19937_64 random(7);
  std::normal_distribution<double> velocity(0.0, 0.3);
  std::uniform_real_distribution<double> interval(1e-5, 0.02);
  const double c_max = kDahl.tau_c + std::abs(kDahl.delta_c);
  for (auto update : {mf::LugreUpdate::exact, mf::LugreUpdate::semi_implicit}) {
    mf::Options options;
    options.update = update;
    mf::JointFriction<double> f(mf::Kind::dahl, kDahl, options);
    for (int k = 0; k < 100000; ++k) {
      const double w = velocity(random);
      const double tau = f.step(w, interval(random));
      ASSERT_LE(std::abs(f.z()), c_max / kDahl.sigma0 * (1 + 1e-12)) << k;
      ASSERT_LE(std::abs(tau - kDahl.sigma2 * w), c_max * (1 + 1e-12)) << k;
    }
  }
}

TEST(Dahl, SteadyStateIsCoulombViscousAndValidityNamesTheBound) {
  for (double w : {-0.3, 0.001, 0.4})
    EXPECT_EQ(mf::Dahl::steady(kDahl, w), mf::CoulombViscous::steady(kDahl, w));
  std::string why;
  Params p = kDahl;
  p.delta_c = 5.0;
  EXPECT_FALSE(mf::IsValid(mf::Kind::dahl, p, &why));
  EXPECT_EQ(why, "|delta_c| = 5 is not below tau_c = 5 (the level of one direction would not be positive)");
  p = kDahl;
  p.sigma0 = 0;
  EXPECT_FALSE(mf::IsValid(mf::Kind::dahl, p, &why));
  EXPECT_EQ(why, "sigma0 = 0 is not positive");
}
