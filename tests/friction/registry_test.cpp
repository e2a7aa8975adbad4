// The contract every friction model of registry.hpp keeps, checked for each registered model
// (a model added to the list is checked without a line here): its names parse back, its JSON
// round-trips, it reads exactly the parameters it lists, it starts in and relaxes to its own
// steady state, its steady gradient matches finite differences and is affine where it says, and
// what IsValid accepts the fitter finds feasible.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "momentum/friction/friction.hpp"
#include "momentum/friction/registry.hpp"

namespace mf = momentum::friction;
using Params = mf::Parameters<double>;

namespace {

// Valid for every model: levels positive in both directions, a Stribeck peak, stiff bristles.
const Params kJoint = {1.0e5, 300.0, 0.8, 2.0, 3.0, 0.05, 0.2, 0.1};

double get(const Params& p, int i) {
  double x[Params::kSize];
  p.to_array(x);
  return x[i];
}
Params with(const Params& p, int i, double v) {
  double x[Params::kSize];
  p.to_array(x);
  x[i] = v;
  return Params::from_array(x);
}
bool contains(const std::vector<int>& v, int i) { return std::find(v.begin(), v.end(), i) != v.end(); }

// Friction torques for a motion with reversals and a rest, 1 kHz.
std::vector<double> run(mf::Kind kind, const Params& p) {
  mf::JointFriction<double> f(kind, p);
  std::vector<double> out;
  for (int k = 0; k < 3000; ++k) {
    const double t = k * 1e-3;
    const double w = t < 2.5 ? 0.3 * std::sin(2 * M_PI * t) : 0.0;
    out.push_back(f.step(w, 1e-3));
  }
  return out;
}

}  // namespace

TEST(FrictionRegistry, NamesParseBackAndAreListed) {
  const std::string names = mf::kind_names_text();
  for (mf::Kind kind : mf::kKinds) {
    mf::Kind parsed{};
    ASSERT_TRUE(mf::parse_kind(mf::kind_name(kind), &parsed)) << mf::kind_name(kind);
    EXPECT_EQ(parsed, kind);
    EXPECT_NE(names.find(mf::kind_name(kind)), std::string::npos) << names;
  }
  mf::Kind parsed{};
  EXPECT_TRUE(mf::parse_kind("coulomb_viscous", &parsed));
  EXPECT_EQ(parsed, mf::Kind::coulomb_viscous);
  EXPECT_FALSE(mf::parse_kind("Lugre", &parsed));
  const std::string listed = mf::kind_names_text(" (default)");
  EXPECT_EQ(listed.rfind("lugre (default), stribeck", 0), 0u) << listed;
  const std::string last = mf::kind_name(mf::kKinds[std::size(mf::kKinds) - 1]);
  EXPECT_EQ(listed.substr(listed.size() - last.size() - 4), " or " + last) << listed;
}

TEST(FrictionRegistry, JsonRoundTripsWhatTheModelReads) {
  for (mf::Kind kind : mf::kKinds) {
    SCOPED_TRACE(mf::kind_name(kind));
    ASSERT_TRUE(mf::IsValid(kind, kJoint, nullptr));
    mf::FrictionModel model{kind, {}, {kJoint}, {}};
    const auto section = mf::to_json(model);
    const auto& entry = section["joints"][0];
    const auto used = mf::used_parameters(kind, true);
    for (int i = 0; i < Params::kSize; ++i) EXPECT_EQ(entry.contains(mf::kParameterNames[i]), contains(used, i)) << i;
    EXPECT_EQ(section.contains("update"), mf::has_state(kind));
    const auto back = mf::friction_from_json(section);
    EXPECT_EQ(back.kind, kind);
    for (int i : used) EXPECT_EQ(get(back.joints[0], i), get(kJoint, i)) << i;
    EXPECT_EQ(mf::to_json(back).dump(), section.dump());
  }
}

TEST(FrictionRegistry, ReadsExactlyTheParametersItLists) {
  for (mf::Kind kind : mf::kKinds) {
    SCOPED_TRACE(mf::kind_name(kind));
    const auto used = mf::used_parameters(kind, true);
    const auto reference = run(kind, kJoint);
    for (int i = 0; i < Params::kSize; ++i) {
      const auto changed = run(kind, with(kJoint, i, get(kJoint, i) * 1.1 + 0.01));
      double difference = 0;
      for (std::size_t k = 0; k < reference.size(); ++k) difference = std::max(difference, std::abs(changed[k] - reference[k]));
      if (contains(used, i)) EXPECT_GT(difference, 1e-6) << mf::kParameterNames[i] << " is listed but not read";
      else EXPECT_EQ(difference, 0.0) << mf::kParameterNames[i] << " is read but not listed";
    }
  }
}

TEST(FrictionRegistry, StartsInAndRelaxesToItsSteadyState) {
  for (mf::Kind kind : mf::kKinds) {
    SCOPED_TRACE(mf::kind_name(kind));
    for (double w : {-0.4, -0.02, 0.0, 0.01, 0.3}) {
      const double steady = mf::visit(kind, [&](auto model) { return decltype(model)::steady(kJoint, w); });
      // Sliding, the steady friction is the sliding level in the direction of motion plus viscous.
      if (w != 0) {
        EXPECT_NEAR(steady - kJoint.sigma2 * w, std::copysign(mf::sliding_level(kind, kJoint, w), w), 1e-12) << w;
      }
      mf::JointFriction<double> started(kind, kJoint);
      EXPECT_DOUBLE_EQ(started.step(w, 1e-3), steady) << w;
      // From rest at another velocity: the state relaxes within a few travels of level / sigma0.
      mf::JointFriction<double> moved(kind, kJoint);
      moved.step(-w, 1e-3);
      double tau = 0;
      for (int k = 0; k < 2000; ++k) tau = moved.step(w, 1e-3);
      EXPECT_NEAR(tau, steady, 1e-9 * (1 + std::abs(steady))) << w;
    }
  }
}

TEST(FrictionRegistry, SteadyGradientMatchesFiniteDifferencesAndIsAffineWhereItSays) {
  for (mf::Kind kind : mf::kKinds) {
    SCOPED_TRACE(mf::kind_name(kind));
    const auto used = mf::used_parameters(kind, true);
    auto magnitude = [&](const Params& p, double w) {
      return std::abs(mf::visit(kind, [&](auto model) { return decltype(model)::steady(p, w); }));
    };
    for (double w : {-0.3, -0.04, 0.03, 0.07, 0.5}) {
      double gradient[Params::kSize];
      mf::steady_gradient(kind, kJoint, w, gradient);
      for (int i = 0; i < Params::kSize; ++i) {
        const double h = 1e-6 * std::max(1.0, std::abs(get(kJoint, i)));
        const double numeric = (magnitude(with(kJoint, i, get(kJoint, i) + h), w) -
                                magnitude(with(kJoint, i, get(kJoint, i) - h), w)) / (2 * h);
        EXPECT_NEAR(gradient[i], contains(used, i) ? numeric : 0.0, 1e-6) << mf::kParameterNames[i] << " at " << w;
      }
      double constant[Params::kSize], slope[Params::kSize];
      const double direction = w < 0 ? -1.0 : 1.0;
      const double from = mf::affine_from(kind, kJoint, direction, constant, slope);
      if (std::abs(w) < from) continue;
      for (int i = 0; i < Params::kSize; ++i)
        EXPECT_NEAR(gradient[i], constant[i] + slope[i] * std::abs(w), 1e-12) << mf::kParameterNames[i] << " at " << w;
    }
  }
}

TEST(FrictionRegistry, WhatIsValidIsFeasibleAndBoundsAreChecked) {
  for (mf::Kind kind : mf::kKinds) {
    SCOPED_TRACE(mf::kind_name(kind));
    EXPECT_TRUE(mf::feasible(kind, kJoint));
    std::string why;
    for (int i : mf::used_parameters(kind, true)) {
      EXPECT_FALSE(mf::IsValid(kind, with(kJoint, i, NAN), &why));
      EXPECT_EQ(why, std::string(mf::kParameterNames[i]) + " is not finite");
      if (i < mf::kFirstSignedParameter) {
        EXPECT_FALSE(mf::IsValid(kind, with(kJoint, i, -1.0), nullptr)) << mf::kParameterNames[i];
        const Params symmetric = with(with(kJoint, 6, 0.0), 7, 0.0);
        EXPECT_EQ(mf::IsValid(kind, with(symmetric, i, 0.0), nullptr), !mf::must_be_positive(kind, i)) << mf::kParameterNames[i];
      } else {
        // An asymmetry as large as its level: one direction's level is not positive.
        const int level = i == 6 ? 3 : 4;
        const Params p = with(kJoint, i, 1.5 * get(kJoint, level));
        EXPECT_FALSE(mf::IsValid(kind, p, nullptr)) << mf::kParameterNames[i];
        EXPECT_FALSE(mf::feasible(kind, p)) << mf::kParameterNames[i];
      }
    }
  }
}
