// The identifier on data generated from a known TRUE arm (tests/data/dynfit/true-arm.urdf:
// masses and centres of mass 17-24% off, an unknown 0.8 kg tool) by the library's recursive
// inverse dynamics plus a known Coulomb + viscous friction, fitted against the nominal arm
// (nominal-arm.urdf). Reference: the true URDF's parameters projected on the identified
// combinations, and the true friction.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>
#include <cstdio>
#include <random>

#include "momentum/core/error.hpp"
#include "momentum/inertia/identify.hpp"
#include "momentum/inertia/regressor.hpp"
#include "momentum/model/dynamics.hpp"
#include "momentum/model/inertial_corrections.hpp"
#include "momentum/model/profile.hpp"

namespace {

using Eigen::VectorXd;
using momentum::model::Model;

Model load(const std::string& name) {
  return momentum::model::build_model(momentum::model::load_profile(
      std::string(MOMENTUM_TEST_DATA) + "/dynfit/" + name + ".json"));
}

// A smooth excitation: per joint a sum of 5 harmonics of 0.1 Hz around a home pose.
struct Motion {
  VectorXd home{{0.0, 0.5, 0.8}};
  void at(double t, VectorXd& q, VectorXd& dq, VectorXd& ddq) const {
    q = home;
    dq.setZero(3);
    ddq.setZero(3);
    for (int j = 0; j < 3; ++j) {
      for (int k = 1; k <= 5; ++k) {
        const double w = 2 * M_PI * 0.1 * k, a = 0.5 / k, phase = 1.3 * j + 0.7 * k * k;
        q[j] += a * std::sin(w * t + phase);
        dq[j] += a * w * std::cos(w * t + phase);
        ddq[j] -= a * w * w * std::sin(w * t + phase);
      }
    }
  }
};

const VectorXd kCoulomb{{6.0, 7.0, 5.0}};
const VectorXd kViscous{{4.0, 3.0, 2.5}};

// `bump`: a Stribeck-like friction at low speed, bump sign(dq) exp(-(dq / 0.07)^2) Nm, that the
// Coulomb + viscous model does not have (below 1e-3 of it above 0.2 rad/s).
momentum::inertia::IdentifySummary identify(const momentum::inertia::IdentifyOptions& options,
                                           double noise, double seconds, double bump = 0.0) {
  const Model truth = load("true");
  static Model nominal;  // outlives the identifier
  nominal = load("nominal");
  momentum::inertia::Identifier identifier(nominal, options);
  momentum::model::Data data(truth);
  Motion motion;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> gauss(0.0, 1.0);
  VectorXd q, dq, ddq, tau;
  const double dt = 1e-3;
  for (long i = 0; i * dt <= seconds; ++i) {
    const double t = static_cast<double>(i) * dt;
    motion.at(t, q, dq, ddq);
    momentum::model::inverse_dynamics(truth, data, q, dq, ddq, tau);
    for (int j = 0; j < 3; ++j) {
      tau[j] += kCoulomb[j] * std::tanh(dq[j] / options.coulomb_speed) + kViscous[j] * dq[j];
      if (bump != 0) tau[j] += bump * (dq[j] > 0 ? 1.0 : -1.0) * std::exp(-std::pow(dq[j] / 0.07, 2));
      tau[j] += noise * gauss(rng);
    }
    identifier.add(t, q, dq, tau);
  }
  return identifier.solve();
}

TEST(Identify, RecoversTrueBaseParametersFromExactData) {
  momentum::inertia::IdentifyOptions options;
  const auto s = identify(options, 0.0, 120.0);
  const VectorXd truth = momentum::inertia::model_parameters(load("true"));
  // The paper arm (z, y, y axes) has 10 base parameters of its 30 inertial ones... plus the
  // ones the rank tolerance keeps; at least the classic count must be identified.
  EXPECT_GE(s.rank, 10);
  EXPECT_LT(s.rank, 30);
  for (const auto& base : s.base) {
    const double want = base.direction.dot(truth);
    EXPECT_NEAR(base.value, want, 1e-4 * (1 + std::abs(want)))
        << "nominal " << base.nominal << " se " << base.standard_error;
  }
  for (int j = 0; j < 3; ++j) {
    EXPECT_NEAR(s.coulomb[j], kCoulomb[j], 1e-3);
    EXPECT_NEAR(s.viscous[j], kViscous[j], 1e-3);
  }
  ASSERT_TRUE(s.held_out);
  for (int j = 0; j < 3; ++j) {
    EXPECT_GT(s.rms_before[j], 0.05) << j;  // the wrong URDF shows
    EXPECT_LT(s.rms_after[j], 1e-3) << j;   // and is gone
  }
  // The corrected bodies are physical (the minimum-norm correction may not be; the fix moves
  // along unidentified directions only, which the base-parameter checks above would catch).
  const Model nominal = load("nominal");
  for (int k = 0; k < 3; ++k) {
    momentum::model::Body body;
    EXPECT_TRUE(momentum::model::set_standard_parameters(
        body, s.nominal.segment<10>(10 * k) + s.delta.segment<10>(10 * k), nullptr)) << k;
  }
  for (const auto& note : s.projections) std::printf("projection: %s\n", note.c_str());
  // This data set needs the projection; it keeps what the data say (every identified
  // combination of the projected correction still matches the truth) and moves what they do
  // not say only as far as physics needs: an unexcited inertia entry by less than its body's
  // nominal inertia trace.
  ASSERT_FALSE(s.projections.empty());
  for (const auto& base : s.base) {
    const double want = base.direction.dot(truth);
    EXPECT_NEAR(base.direction.dot(s.nominal + s.delta), want, 1e-4 * (1 + std::abs(want)));
  }
  for (const auto& e : s.parameters) {
    if (e.index < 4 || e.identifiability > 1e-9) continue;
    const double trace = s.nominal[10 * e.body + 4] + s.nominal[10 * e.body + 7] + s.nominal[10 * e.body + 9];
    EXPECT_LT(std::abs(e.value - e.nominal), trace) << "body " << e.body << " parameter " << e.index;
  }
}

// Friction the model does not have, below min_speed only: the rows of slow joints do not count,
// and their filters restart when the joint is fast again, so nothing of it is left in the
// filtered equation and the fit is exact. (Waiting 3 / K after the slow phase instead left
// e^-3 of the filtered error, which biased the fit.)
TEST(Identify, SlowMotionLeavesNothingBehind) {
  momentum::inertia::IdentifyOptions options;
  options.filter_gain = 10;  // mo-dynfit's: a longer memory than the default's
  options.min_speed = 0.2;
  options.velocity_noise_draws = 0;
  const auto s = identify(options, 0.0, 120.0, 5.0);
  const VectorXd truth = momentum::inertia::model_parameters(load("true"));
  for (const auto& base : s.base) {
    const double want = base.direction.dot(truth);
    EXPECT_NEAR(base.value, want, 1e-3 * (1 + std::abs(want))) << "se " << base.standard_error;
  }
  for (int j = 0; j < 3; ++j) {
    EXPECT_NEAR(s.coulomb[j], kCoulomb[j], 2e-3);
    EXPECT_NEAR(s.viscous[j], kViscous[j], 2e-3);
  }
}

TEST(Identify, WithNoiseWithinReportedConfidence) {
  momentum::inertia::IdentifyOptions options;
  const double noise = 0.5;  // Nm on tau_m
  const auto s = identify(options, noise, 200.0);
  const VectorXd truth = momentum::inertia::model_parameters(load("true"));
  int outside = 0;
  for (const auto& base : s.base) {
    const double want = base.direction.dot(truth);
    ASSERT_TRUE(std::isfinite(base.standard_error));
    if (std::abs(base.value - want) > 3 * base.standard_error) ++outside;
  }
  EXPECT_LE(outside, 1) << "of " << s.base.size();
  // The residual after correction is the filtered noise: 0.5 Nm white at 1 kHz through
  // K/(s+K), K = 50: sigma sqrt(K dt / 2) = 0.079 Nm.
  const double filtered_noise = noise * std::sqrt(50 * 1e-3 / 2);
  for (int j = 0; j < 3; ++j) {
    EXPECT_NEAR(s.rms_after[j], filtered_noise, 0.1 * filtered_noise) << j;
    EXPECT_GT(s.rms_before[j], 2 * filtered_noise) << j;
  }
}

TEST(Identify, GravityOnlyFitsMassAndFirstMomentOnly) {
  momentum::inertia::IdentifyOptions options;
  options.gravity_only = true;
  const auto s = identify(options, 0.0, 60.0);
  for (const auto& p : s.parameters) EXPECT_EQ(p.fitted, p.index < 4);
  // The inertias about the centres of mass stay nominal.
  const Model nominal = load("nominal");
  for (int k = 0; k < 3; ++k) {
    momentum::model::Body body;
    ASSERT_TRUE(momentum::model::set_standard_parameters(
        body, s.nominal.segment<10>(10 * k) + s.delta.segment<10>(10 * k), nullptr));
    EXPECT_LT((body.inertia - nominal.bodies[static_cast<std::size_t>(k)].inertia).norm(), 1e-12) << k;
  }
  EXPECT_GT(s.rank, 0);
}

// Logs of the true arm as identify() makes them, each starting at t = 0 (`seconds` each), fed
// in order with a restart before each; with `plan`, the identifier is told their samples first.
// `disturbance` (Nm) is added to every joint's torque in the middle of the segments that the
// whole time line holds out (10 s segments, every 5th; each log starts at the next multiple of
// 10 s, the first at 10 s, as Identifier::restart() places them), smoothly and 1 s clear of
// their ends, so that the filtered equation of the rows fitted never sees it when the segments
// held out are those of the whole logs.
momentum::inertia::IdentifySummary identify_logs(const momentum::inertia::IdentifyOptions& options,
                                                const std::vector<double>& seconds, double noise, double disturbance,
                                                bool plan) {
  const Model truth = load("true");
  static Model nominal;
  nominal = load("nominal");
  momentum::inertia::Identifier identifier(nominal, options);
  const double dt = 1e-3;
  if (plan) {
    std::uint64_t samples = 0;
    for (double s : seconds) samples += static_cast<std::uint64_t>(std::floor(s / dt + 1e-9)) + 1;
    identifier.plan(samples);
  }
  momentum::model::Data data(truth);
  Motion motion;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> gauss(0.0, 1.0);
  VectorXd q, dq, ddq, tau;
  double origin = 0;  // where each log starts on the whole time line
  for (double length : seconds) {
    origin = 10.0 * std::ceil(origin / 10.0 + 1e-9);
    identifier.restart();
    for (long i = 0; static_cast<double>(i) * dt <= length + 1e-9; ++i) {
      const double t = static_cast<double>(i) * dt;
      motion.at(origin + t, q, dq, ddq);
      momentum::model::inverse_dynamics(truth, data, q, dq, ddq, tau);
      const double in_segment = std::fmod(origin + t, 10.0);
      const bool held = static_cast<long>(std::floor((origin + t) / 10.0)) % 5 == 4;
      const double bump = held && in_segment > 1 && in_segment < 9 ? std::pow(std::sin(M_PI * (in_segment - 1) / 8), 2) : 0.0;
      for (int j = 0; j < 3; ++j) {
        tau[j] += kCoulomb[j] * std::tanh(dq[j] / options.coulomb_speed) + kViscous[j] * dq[j];
        tau[j] += disturbance * bump + noise * gauss(rng);
      }
      identifier.add(t, q, dq, tau);
    }
    origin += length;
  }
  return identifier.solve();
}

// Two logs, 203 s and 300 s (503 k samples), to a budget of 170 k: every third 50 s stretch
// of the whole time line is fitted, the second log's first stretch not (its time still counts).
TEST(Identify, ThinnedToTheBudgetKeepsTheHeldOutSegmentsAndTheTruth) {
  momentum::inertia::IdentifyOptions options;
  options.max_samples = 170000;
  const std::vector<double> logs{203.0, 300.0};
  const auto thin = identify_logs(options, logs, 0.0, 2.0, true);
  EXPECT_TRUE(thin.thinned);
  EXPECT_EQ(thin.samples_read, 503002u);
  EXPECT_LE(thin.samples_taken, options.max_samples);
  EXPECT_GT(thin.samples_taken, 140000u);  // 3 whole stretches of 50 s
  EXPECT_EQ(thin.stretches_kept, 3);
  EXPECT_EQ(thin.stretch_seconds, 50.0);
  EXPECT_EQ(thin.restarts, 3);
  // The disturbance is held out only: the rows fitted are exact, and so is the fit.
  const VectorXd truth = momentum::inertia::model_parameters(load("true"));
  EXPECT_GE(thin.rank, 10);
  for (const auto& base : thin.base) {
    const double want = base.direction.dot(truth);
    EXPECT_NEAR(base.value, want, 1e-4 * (1 + std::abs(want))) << "se " << base.standard_error;
    // So is the friction probe's, whose held-out segments are the same.
    EXPECT_LT(std::abs(base.friction_shift), 1e-4 * (1 + std::abs(want)));
  }
  for (int j = 0; j < 3; ++j) {
    EXPECT_NEAR(thin.coulomb[j], kCoulomb[j], 1e-3);
    EXPECT_NEAR(thin.viscous[j], kViscous[j], 1e-3);
  }
  // A fifth of what was taken is held out, and the disturbance there shows as it does on all
  // the samples (the same segments, a third of them).
  const auto all = identify_logs(options, logs, 0.0, 2.0, false);
  EXPECT_FALSE(all.thinned);
  EXPECT_EQ(all.samples_taken, all.samples_read);
  EXPECT_NEAR(thin.seconds_held_out / (thin.seconds_fit + thin.seconds_held_out), 0.2, 0.01);
  for (int j = 0; j < 3; ++j) {
    EXPECT_GT(thin.rms_after[j], 0.5) << j;
    EXPECT_NEAR(thin.rms_after[j], all.rms_after[j], 0.1 * all.rms_after[j]) << j;
  }
}

// With noise on the torque, the thinned fit is within its stated uncertainty of the truth, and
// that uncertainty is of the samples taken: about sqrt(3) times that of all of them.
TEST(Identify, ThinnedFitWithNoiseWithinItsUncertainty) {
  momentum::inertia::IdentifyOptions options;
  options.max_samples = 170000;
  const std::vector<double> logs{203.0, 300.0};
  const auto thin = identify_logs(options, logs, 0.5, 0.0, true);
  const auto all = identify_logs(options, logs, 0.5, 0.0, false);
  ASSERT_TRUE(thin.thinned);
  const VectorXd truth = momentum::inertia::model_parameters(load("true"));
  int outside = 0;
  std::vector<double> ratio;
  for (const auto& base : thin.base) {
    const double want = base.direction.dot(truth);
    ASSERT_TRUE(std::isfinite(base.uncertainty));
    if (std::abs(base.value - want) > 3 * base.uncertainty) ++outside;
    ratio.push_back(base.standard_error / std::sqrt(base.direction.dot(all.covariance * base.direction)));
  }
  EXPECT_LE(outside, 1) << "of " << thin.base.size();
  std::sort(ratio.begin(), ratio.end());
  const double median = ratio[ratio.size() / 2];
  EXPECT_GT(median, 1.3);
  EXPECT_LT(median, 2.5);
}

// Logs within the budget are fitted as without one, bit for bit.
TEST(Identify, WithinTheBudgetNothingChanges) {
  momentum::inertia::IdentifyOptions options;
  options.velocity_noise_draws = 2;
  options.max_samples = 0;
  const auto unbounded = identify_logs(options, {30.0, 25.0}, 0.3, 0.0, false);
  options.max_samples = 55002;  // exactly the samples
  const auto bounded = identify_logs(options, {30.0, 25.0}, 0.3, 0.0, true);
  EXPECT_FALSE(bounded.thinned);
  EXPECT_EQ(bounded.samples_taken, 55002u);
  EXPECT_EQ(bounded.delta, unbounded.delta);
  EXPECT_EQ(bounded.delta_unprojected, unbounded.delta_unprojected);
  EXPECT_EQ(bounded.covariance, unbounded.covariance);
  EXPECT_EQ(bounded.rms_after, unbounded.rms_after);
  ASSERT_EQ(bounded.base.size(), unbounded.base.size());
  for (std::size_t r = 0; r < bounded.base.size(); ++r) EXPECT_EQ(bounded.base[r].uncertainty, unbounded.base[r].uncertainty);
}

TEST(Identify, InvalidOptionsAndNoData) {
  momentum::inertia::IdentifyOptions options;
  options.rank_tolerance = 2;
  std::string why;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("rank"), std::string::npos);
  const Model nominal = load("nominal");
  EXPECT_THROW(momentum::inertia::Identifier(nominal, options), momentum::Error);
  options = {};
  options.max_samples = 100;  // fewer than the velocity-noise estimate's samples
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("budget"), std::string::npos);
  momentum::inertia::Identifier empty(nominal, momentum::inertia::IdentifyOptions{});
  EXPECT_THROW(empty.solve(), momentum::Error);
}

}  // namespace
