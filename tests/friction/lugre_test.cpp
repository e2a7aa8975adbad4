// LuGre and the static friction curves against closed forms, a fine RK4 integration of the
// bristle ODE, and finite differences (for the ceres::Jet instantiation the fitter uses).
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "momentum/friction/friction.hpp"
#include "momentum/friction/lugre.hpp"

namespace mf = momentum::friction;
using Params = mf::Parameters<double>;

namespace {

// The paper's Table 1 (Zhang et al. 2020), joints 1..3. Note tau_c > tau_s there.
const Params kTable1[3] = {
    {98467.9088, 314.0483, 6.4865, 7.8322, 4.0033, 0.0978},
    {95487.8562, 499.4331, 6.1838, 8.1855, 4.5407, 0.0996},
    {94546.6673, 489.1297, 5.3929, 7.0023, 4.9450, 0.0917},
};
// A textbook joint with a static peak above the Coulomb level.
const Params kTypical = {1.0e5, 300.0, 0.8, 2.0, 3.0, 0.05};

double level_max(const Params& p) { return std::max(p.tau_c, p.tau_s); }

// dz/dt of eq. 12b for a constant velocity.
double bristle_rate(const Params& p, double w, double z) {
  return w - p.sigma0 * std::abs(w) * z / mf::stribeck_level(p, w);
}

}  // namespace

TEST(StaticCurves, ClosedForm) {
  const Params& p = kTypical;
  // g(w) at w = 0, w = w_s and far away.
  EXPECT_DOUBLE_EQ(mf::stribeck_level(p, 0.0), p.tau_s);
  EXPECT_NEAR(mf::stribeck_level(p, p.w_s), p.tau_c + (p.tau_s - p.tau_c) * std::exp(-1.0), 1e-15);
  EXPECT_NEAR(mf::stribeck_level(p, 100 * p.w_s), p.tau_c, 1e-12);
  EXPECT_NEAR(mf::stribeck_torque(p, 0.3), mf::stribeck_level(p, 0.3) + p.sigma2 * 0.3, 1e-15);
  EXPECT_NEAR(mf::stribeck_torque(p, -0.3), -mf::stribeck_torque(p, 0.3), 1e-15);
  EXPECT_EQ(mf::stribeck_torque(p, 0.0), 0.0);
  EXPECT_NEAR(mf::coulomb_viscous_torque(p, -2.0), -p.tau_c - 2.0 * p.sigma2, 1e-15);
  EXPECT_EQ(mf::coulomb_viscous_torque(p, 0.0), 0.0);
}

// For a constant velocity the LuGre torque settles on the Stribeck curve, from any start.
TEST(Lugre, SteadyStateIsStribeckCurve) {
  for (const Params& p : {kTable1[0], kTable1[1], kTable1[2], kTypical}) {
    for (mf::LugreUpdate update : {mf::LugreUpdate::exact, mf::LugreUpdate::semi_implicit}) {
      for (double w : {-1.5, -0.08, -0.01, 0.002, 0.03, 0.0978, 0.6, 3.0}) {
        double z = -level_max(p) / p.sigma0;  // start at the opposite extreme
        double tau = 0;
        for (int k = 0; k < 20000; ++k) tau = mf::lugre_step(p, w, 1e-3, update, z);
        const double expected = mf::stribeck_torque(p, w);
        EXPECT_NEAR(tau, expected, 1e-9 * std::abs(expected)) << "w = " << w;
        EXPECT_NEAR(z, mf::stribeck_level(p, w) / p.sigma0 * (w > 0 ? 1 : -1), 1e-15);
      }
    }
  }
}

// The state stays within max(tau_c, tau_s)/s0 at the paper's dt = 8 ms with its stiff
// parameters, for arbitrary velocity sequences; explicit Euler (not offered) does not.
TEST(Lugre, StateBoundedAtEightMilliseconds) {
  std::mt19937_64 rng(42);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(-1, 1);
  const double dt = 0.008;
  for (const Params& p : {kTable1[0], kTable1[1], kTable1[2], kTypical}) {
    const double bound = level_max(p) / p.sigma0;
    for (mf::LugreUpdate update : {mf::LugreUpdate::exact, mf::LugreUpdate::semi_implicit}) {
      for (int sequence = 0; sequence < 20; ++sequence) {
        // Mixtures of scales: standstill noise, Stribeck-range and fast motion, sign flips.
        const double scale = std::pow(10.0, -4 + sequence % 6);
        double z = 0, euler_z = 0, worst = 0, euler_worst = 0;
        for (int k = 0; k < 2000; ++k) {
          const double w = (k % 97 == 0 ? 0.0 : scale * (sequence % 2 ? normal(rng) : uniform(rng)));
          const double tau = mf::lugre_step(p, w, dt, update, z);
          ASSERT_TRUE(std::isfinite(tau));
          worst = std::max(worst, std::abs(z));
          euler_z += dt * bristle_rate(p, w, euler_z);
          if (std::isfinite(euler_z)) euler_worst = std::max(euler_worst, std::abs(euler_z));
          else euler_worst = INFINITY;
        }
        EXPECT_LE(worst, bound * (1 + 1e-12)) << "sequence " << sequence;
        if (scale >= 1e-1) {
          EXPECT_GT(euler_worst, 10 * bound) << "explicit Euler stayed bounded?";
        }
      }
    }
  }
}

// The exact update equals a fine RK4 integration of eq. 12b for a constant velocity, and its
// dz/dt and torque are those of the ODE at the end of the step.
TEST(Lugre, ExactUpdateMatchesRk4) {
  for (const Params& p : {kTable1[0], kTypical}) {
    for (double w : {-0.7, -0.02, 0.001, 0.05, 0.4}) {
      for (double dt : {0.001, 0.008}) {
        for (double z0 : {0.0, -level_max(p) / p.sigma0, 0.5 * level_max(p) / p.sigma0}) {
          double z = z0;
          const double tau = mf::lugre_step(p, w, dt, mf::LugreUpdate::exact, z);
          const int n = 20000;
          const double h = dt / n;
          double y = z0;
          for (int i = 0; i < n; ++i) {
            const double k1 = bristle_rate(p, w, y);
            const double k2 = bristle_rate(p, w, y + 0.5 * h * k1);
            const double k3 = bristle_rate(p, w, y + 0.5 * h * k2);
            const double k4 = bristle_rate(p, w, y + h * k3);
            y += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
          }
          const double scale = level_max(p) / p.sigma0;
          EXPECT_NEAR(z, y, 1e-10 * scale) << "w " << w << " dt " << dt << " z0 " << z0;
          const double tau_rk4 = p.sigma0 * y + p.sigma1 * bristle_rate(p, w, y) + p.sigma2 * w;
          EXPECT_NEAR(tau, tau_rk4, 1e-8 * level_max(p));
        }
      }
    }
  }
}

// The semi-implicit option is the paper's eq. 13b-d, transcribed independently here.
TEST(Lugre, SemiImplicitIsPaperEquation13) {
  const Params& p = kTable1[1];
  const double dt = 0.008;
  double z = 0, z_paper = 0;
  for (int k = 0; k < 500; ++k) {
    const double w = 0.6 * 2 * M_PI * 0.2 * std::cos(2 * M_PI * 0.2 * k * dt);
    const double tau = mf::lugre_step(p, w, dt, mf::LugreUpdate::semi_implicit, z);
    const double s = p.tau_c + (p.tau_s - p.tau_c) * std::exp(-std::pow(w / p.w_s, 2));  // 13a
    const double zdot = (w - p.sigma0 / s * z_paper * std::abs(w)) /
                        (1 + p.sigma0 / s * dt * std::abs(w));                          // 13b
    z_paper += zdot * dt;                                                               // 13c
    const double tau_paper = p.sigma0 * z_paper + p.sigma1 * zdot + p.sigma2 * w;       // 13d
    ASSERT_NEAR(tau, tau_paper, 1e-12 * std::abs(tau_paper) + 1e-12);
  }
}

// Derivatives through a whole LuGre recursion (as the fitter takes them with ceres::Jet) match
// central finite differences of the double version, for each of the eight parameters (an
// asymmetric set, so that delta_c and delta_s matter).
TEST(Lugre, JetDerivativesMatchFiniteDifferences) {
  using Jet = ceres::Jet<double, 8>;
  struct Case {
    mf::LugreUpdate update;
    double dt;
    mf::Options options;
  };
  mf::Options filtered;
  filtered.velocity_cutoff_hz = 20;
  mf::Options exact_opts, semi_opts;
  semi_opts.update = mf::LugreUpdate::semi_implicit;
  filtered.update = mf::LugreUpdate::exact;
  // Velocity ranges where every parameter matters: slow reversals (bristles, Stribeck).
  const Params base = {2000.0, 8.0, 0.8, 2.0, 3.0, 0.05, 0.3, -0.4};  // asymmetric
  for (const Case& c : {Case{mf::LugreUpdate::exact, 0.001, exact_opts},
                        Case{mf::LugreUpdate::semi_implicit, 0.008, semi_opts},
                        Case{mf::LugreUpdate::exact, 0.004, filtered}}) {
    auto run = [&](auto params) {
      using T = typename decltype(params)::value_type;
      mf::Parameters<T> p = mf::Parameters<T>::from_array(params.data());
      mf::JointFriction<T> f(mf::Kind::lugre, p, c.options);
      T cost = T(0);
      for (int k = 0; k < 400; ++k) {
        const double t = k * c.dt;
        const double w = 0.1 * std::sin(2 * M_PI * 1.3 * t) + 0.004 * std::cos(2 * M_PI * 7 * t);
        const T tau = f.step(T(w), c.dt);
        cost += tau * tau;
      }
      return cost;
    };
    double x[8];
    base.to_array(x);
    std::vector<Jet> xj(8);
    for (int i = 0; i < 8; ++i) xj[i] = Jet(x[i], i);
    const Jet cost = run(xj);
    for (int i = 0; i < 8; ++i) {
      const double h = 1e-6 * std::abs(x[i]);
      std::vector<double> plus(x, x + 8), minus(x, x + 8);
      plus[i] += h;
      minus[i] -= h;
      const double fd = (run(plus) - run(minus)) / (2 * h);
      EXPECT_NEAR(cost.v[i], fd, 1e-6 * std::abs(fd) + 1e-7 * std::abs(cost.a))
          << mf::kParameterNames[i] << " update " << mf::update_name(c.update);
    }
    std::vector<double> xd(x, x + 8);
    EXPECT_NEAR(cost.a, run(xd), 1e-12 * std::abs(cost.a));
  }
}

TEST(JointFriction, StartsInSteadyStateAndStaticModels) {
  const Params& p = kTypical;
  mf::JointFriction<double> lugre(mf::Kind::lugre, p);
  EXPECT_NEAR(lugre.step(0.3, 0.0), mf::stribeck_torque(p, 0.3), 1e-12);
  // Next step at the same velocity stays on the curve (no start-up transient).
  EXPECT_NEAR(lugre.step(0.3, 0.001), mf::stribeck_torque(p, 0.3), 1e-9);
  lugre.reset();
  EXPECT_EQ(lugre.step(0.0, 0.001), 0.0);
  EXPECT_EQ(lugre.z(), 0.0);

  mf::JointFriction<double> stribeck(mf::Kind::stribeck, p);
  mf::JointFriction<double> cv(mf::Kind::coulomb_viscous, p);
  for (double w : {-1.0, -0.01, 0.0, 0.02, 2.0}) {
    EXPECT_EQ(stribeck.step(w, 0.001), mf::stribeck_torque(p, w));
    EXPECT_EQ(cv.step(w, 0.001), mf::coulomb_viscous_torque(p, w));
  }
}

// A deadband holds the bristle state through standstill noise; without it LuGre forgets the
// friction it held.
TEST(JointFriction, DeadbandHoldsPresliding) {
  const Params& p = kTypical;
  mf::Options hold;
  hold.velocity_deadband = 2e-3;
  mf::JointFriction<double> with(mf::Kind::lugre, p, hold), without(mf::Kind::lugre, p);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 3e-4);
  // Move forward, then stop with velocity noise.
  double tw = 0, two = 0;
  for (int k = 0; k < 200; ++k) tw = with.step(0.2, 0.001), two = without.step(0.2, 0.001);
  const double held = p.sigma0 * with.z();
  for (int k = 0; k < 2000; ++k) {
    const double w = noise(rng);
    tw = with.step(w, 0.001);
    two = without.step(w, 0.001);
  }
  EXPECT_NEAR(tw, held, 1e-9);  // the deadband kept z, so the friction stays at its held level
  EXPECT_NEAR(held, p.tau_c + (p.tau_s - p.tau_c) * std::exp(-16.0), 1e-6);
  EXPECT_LT(std::abs(two), 0.5 * held);  // noise drove the unfiltered model away from it
}

// The velocity low-pass is the exact first-order response to a step in velocity.
TEST(JointFriction, VelocityLowPass) {
  mf::Options options;
  options.velocity_cutoff_hz = 5;
  mf::JointFriction<double> f(mf::Kind::coulomb_viscous, {0, 0, 1.0, 0.0, 0, 1}, options);
  f.step(0.0, 0.0);
  double t = 0;
  for (int k = 0; k < 100; ++k) {
    const double dt = 0.001 * (1 + 0.5 * (k % 3));  // irregular steps
    t += dt;
    const double tau = f.step(1.0, dt);
    ASSERT_NEAR(tau, 1 - std::exp(-2 * M_PI * 5 * t), 1e-12);
  }
}

TEST(FrictionModel, JsonRoundTripAndErrors) {
  mf::FrictionModel model;
  model.kind = mf::Kind::lugre;
  model.options.update = mf::LugreUpdate::semi_implicit;
  model.options.velocity_deadband = 0.002;
  model.joints = {kTable1[0], kTable1[1], kTable1[2]};
  const nlohmann::json section = mf::to_json(model);
  EXPECT_EQ(section["model"], "lugre");
  EXPECT_EQ(section["update"], "semi-implicit");
  EXPECT_EQ(section["joints"][2]["w_s"], 0.0917);
  const mf::FrictionModel back = mf::friction_from_json(section);
  EXPECT_EQ(back.kind, model.kind);
  EXPECT_EQ(back.options.update, model.options.update);
  EXPECT_EQ(back.options.velocity_deadband, 0.002);
  ASSERT_EQ(back.joints.size(), 3u);
  EXPECT_EQ(back.joints[1].sigma1, kTable1[1].sigma1);

  auto error_of = [](const char* text) -> std::string {
    try {
      mf::friction_from_json(nlohmann::json::parse(text));
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(error_of(R"({"model": "maxwell-slip", "joints": []})"),
            "friction: unknown model \"maxwell-slip\" (expected lugre, stribeck, coulomb-viscous or dahl)");
  EXPECT_EQ(error_of(R"({"model": "stribeck", "joints": [{"sigma2": 1, "tau_c": 1, "tau_s": 2}]})"),
            "friction: joint 1: missing 'w_s' (needed by the stribeck model)");
  EXPECT_EQ(error_of(R"({"model": "coulomb-viscous", "joints": [{"sigma2": -1, "tau_c": 1}]})"),
            "friction: joint 1: sigma2 = -1 is negative");
  EXPECT_EQ(error_of(R"({"model": "lugre"})"), "friction: missing 'joints'");
  EXPECT_EQ(error_of(R"({"model": "lugre", "update": "euler", "joints": []})"),
            "friction: unknown update \"euler\" (expected exact or semi-implicit)");

  std::vector<std::string> warnings;
  const auto cv = mf::friction_from_json(
      nlohmann::json::parse(R"({"model": "coulomb-viscous", "colour": 1,
                                "joints": [{"sigma2": 0.5, "tau_c": 1, "tau_x": 3}]})"),
      &warnings);
  EXPECT_EQ(cv.joints[0].tau_c, 1.0);
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_EQ(warnings[0], "friction: unknown key 'colour'");
  EXPECT_EQ(warnings[1], "friction: joint 1: unknown key 'tau_x'");
}

TEST(SteadyFrictionSd, ClosedFormPerParameterAndTheStribeckVelocityByFiniteDifferences) {
  Params p;
  p.sigma2 = 1.2;
  p.tau_c = 2.2;
  p.tau_s = 2.9;
  p.w_s = 0.05;
  auto only = [](int parameter, double variance) {
    return mf::SteadyCovariance{{parameter}, {variance}};
  };
  const double e = std::exp(-0.25);  // at w = w_s / 2
  // tau_s: the whole static level at standstill, e^{-(w/w_s)^2} of it in motion, none at speed.
  EXPECT_NEAR(mf::steady_friction_sd(mf::Kind::lugre, p, only(4, 0.04 * 0.04), 0.0), 0.04, 1e-15);
  EXPECT_NEAR(mf::steady_friction_sd(mf::Kind::lugre, p, only(4, 0.04 * 0.04), -0.025), 0.04 * e, 1e-15);
  EXPECT_LT(mf::steady_friction_sd(mf::Kind::lugre, p, only(4, 0.04 * 0.04), 0.5), 1e-40);
  // tau_c: the complement; sigma2: |w| of it.
  EXPECT_NEAR(mf::steady_friction_sd(mf::Kind::stribeck, p, only(3, 0.01), 0.025), 0.1 * (1 - e), 1e-15);
  EXPECT_NEAR(mf::steady_friction_sd(mf::Kind::lugre, p, only(2, 0.25), -0.4), 0.5 * 0.4, 1e-15);
  EXPECT_NEAR(mf::steady_friction_sd(mf::Kind::coulomb_viscous, p, only(3, 0.01), 0.025), 0.1, 1e-15);
  // w_s: against a central difference of the Stribeck curve.
  const double w = 0.03, h = 1e-7;
  Params up = p, down = p;
  up.w_s += h;
  down.w_s -= h;
  const double slope = (mf::stribeck_torque(up, w) - mf::stribeck_torque(down, w)) / (2 * h);
  EXPECT_NEAR(mf::steady_friction_sd(mf::Kind::lugre, p, only(5, 1e-6), w), std::abs(slope) * 1e-3, 1e-9);
  // Two parameters perfectly anti-correlated at equal sizes cancel where their gradients are
  // equal: tau_c and tau_s at w_s sqrt(ln 2), where e^{-x^2} = 1/2.
  const double half = p.w_s * std::sqrt(std::log(2.0));
  const mf::SteadyCovariance opposed{{3, 4}, {0.01, -0.01, -0.01, 0.01}};
  EXPECT_NEAR(mf::steady_friction_sd(mf::Kind::lugre, p, opposed, half), 0.0, 1e-7);
  EXPECT_NEAR(mf::steady_friction_sd(mf::Kind::lugre, p, opposed, 0.0), 0.1, 1e-15);
}

TEST(FrictionModel, CovarianceRoundTripAndErrors) {
  mf::FrictionModel model;
  model.joints = {kTable1[0], kTable1[1]};
  model.covariance = {std::nullopt, mf::SteadyCovariance{{3, 4, 5}, {1e-4, 2e-5, 0, 2e-5, 4e-3, -1e-6, 0, -1e-6, 1e-6}}};
  const nlohmann::json section = mf::to_json(model);
  EXPECT_FALSE(section["joints"][0].contains("covariance"));
  EXPECT_EQ(section["joints"][1]["covariance"]["parameters"], nlohmann::json::parse(R"(["tau_c", "tau_s", "w_s"])"));
  std::vector<std::string> warnings;
  const mf::FrictionModel back = mf::friction_from_json(section, &warnings);
  EXPECT_TRUE(warnings.empty());
  ASSERT_EQ(back.covariance.size(), 2u);
  EXPECT_FALSE(back.covariance[0]);
  ASSERT_TRUE(back.covariance[1]);
  EXPECT_EQ(back.covariance[1]->parameters, model.covariance[1]->parameters);
  EXPECT_EQ(back.covariance[1]->matrix, model.covariance[1]->matrix);
  // Without any covariance the list stays empty.
  EXPECT_TRUE(mf::friction_from_json(mf::to_json(mf::FrictionModel{mf::Kind::lugre, {}, {kTable1[0]}, {}})).covariance.empty());

  auto error_of = [](const std::string& covariance) -> std::string {
    try {
      mf::friction_from_json(nlohmann::json::parse(
          R"({"model": "coulomb-viscous", "joints": [{"sigma2": 1, "tau_c": 1, "covariance": )" + covariance + "}]}"));
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(error_of(R"({"parameters": ["sigma0"], "matrix": [[1]]})"),
            "friction: joint 1: covariance: \"sigma0\" is not one of sigma2, tau_c, tau_s, w_s, delta_c, delta_s");
  EXPECT_EQ(error_of(R"({"parameters": ["tau_c", "tau_c"], "matrix": [[1, 0], [0, 1]]})"),
            "friction: joint 1: covariance: \"tau_c\" is given twice");
  EXPECT_EQ(error_of(R"({"parameters": ["tau_c", "sigma2"], "matrix": [[1, 0.5], [0, 1]]})"),
            "friction: joint 1: covariance: 'matrix' is not symmetric");
  // Near-zero covariances that differ in their leading digit but by far less than 1e-9 of the
  // variances' scale are rounding (a fit of the Panda at 1 kHz wrote such a pair).
  EXPECT_EQ(error_of(R"({"parameters": ["tau_c", "sigma2"], "matrix": [[1e-4, 3e-19], [-2e-19, 4e-6]]})"), "");
  EXPECT_EQ(error_of(R"({"parameters": ["tau_c", "sigma2"], "matrix": [[1e-4, 3e-14], [-2e-14, 4e-6]]})"),
            "friction: joint 1: covariance: 'matrix' is not symmetric");
  EXPECT_EQ(error_of(R"({"parameters": ["tau_c"], "matrix": [[-1]]})"), "friction: joint 1: covariance: a variance is negative");
  EXPECT_EQ(error_of(R"({"parameters": ["tau_c"], "matrix": [[1, 2]]})"), "friction: joint 1: covariance: 'matrix' is not 1 x 1");
  EXPECT_EQ(error_of(R"([1])"),
            "friction: joint 1: covariance: not {\"parameters\": [names], \"matrix\": [[...]]}");
}
