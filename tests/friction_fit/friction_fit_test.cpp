// Friction identification on synthetic observer output with known parameters (the paper's
// Table 1): recovery, identifiability flags, reproducibility, and the model's equality with
// the observer library's DisturbanceFilter.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>

#include "momentum/core/random.hpp"
#include "momentum/friction_fit/friction_fit.hpp"
#include "momentum/friction_fit/problem.hpp"
#include "synthetic.hpp"

namespace friction_fit = momentum::friction_fit;
namespace mf = momentum::friction;
using friction_fit::testing::kTable1;
using friction_fit::testing::make_synthetic;
using friction_fit::testing::SyntheticOptions;

namespace {

// A short search: enough for these well-posed problems, quick in a unit test.
friction_fit::FitOptions quick_options() {
  friction_fit::FitOptions o;
  o.global.genetic.population = 40;
  o.global.genetic.generations = 40;
  o.global.genetic.restarts = 1;
  o.global.genetic.seed = 11;
  return o;
}

// The fit's summary, printed when an assertion fails (SCOPED_TRACE).
std::string describe(const friction_fit::ModelFit& m) {
  std::string out;
  char line[512];
  std::snprintf(line, sizeof line, "%s: rms %.4g max %.4g R2 %.6f evals %llu (global %.4g -> %.4g) cond %.3g acf %.3g %s\n",
              mf::kind_name(m.kind), m.metrics.rms, m.metrics.max_abs, m.metrics.r_squared,
              static_cast<unsigned long long>(m.evaluations), m.global.cost, m.metrics.cost,
              m.condition_number, m.autocorrelation_factor, m.covariance_note.c_str());
  out += line;
  for (int i = 0; i < friction_fit::kParameterCount; ++i) {
    const auto& e = m.estimates[static_cast<std::size_t>(i)];
    if (!e.used) continue;
    std::snprintf(line, sizeof line, "  %-6s %12.6g +- %-10.3g shift %-10.3g %s\n", mf::kParameterNames[i],
                  e.value, e.standard_error, e.discretization_shift, e.note.c_str());
    out += line;
  }
  return out;
}

double value(const mf::Parameters<double>& p, int i) {
  double a[mf::Parameters<double>::kSize];
  p.to_array(a);
  return a[i];
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

const momentum::observer::Gains kFirstOrder{50.0, 0.0, 0.0};
const momentum::observer::Gains kSecondOrder{50.0, 5.0, 0.0};
constexpr int kStatic[] = {2, 3, 4, 5};  // sigma2, tau_c, tau_s, w_s


}  // namespace


// The fitter's model is the observer library's filter applied to the friction library's
// torque, sample for sample: equal to the bit, with jittered time and a restart.
TEST(FrictionModel, EqualsDisturbanceFilterOfJointFriction) {
  SyntheticOptions so;
  so.jitter = 0.001;
  so.restart_at = 600;
  for (const auto& gains : {kFirstOrder, kSecondOrder}) {
    const auto data = make_synthetic(kTable1[1], gains, so);
    std::vector<double> tau;
    const auto r = friction_fit::predict_residual(data.series, gains, mf::Kind::lugre, kTable1[1], {}, &tau);
    ASSERT_EQ(r.size(), data.clean_r.size());
    for (std::size_t k = 0; k < r.size(); ++k) {
      ASSERT_EQ(r[k], data.clean_r[k]) << "sample " << k;
      ASSERT_EQ(tau[k], data.true_friction[k]) << "sample " << k;
    }
    EXPECT_EQ(r[600], 0.0);  // the observer restarts at rest
    const auto m = friction_fit::evaluate_fit(data.series, gains, mf::Kind::lugre, kTable1[1], {});
    EXPECT_EQ(m.cost, 0.0);
    EXPECT_EQ(m.r_squared, 1.0);
    EXPECT_EQ(m.samples, 1251u);
  }
}

// Noise-free data of the paper's arm at 125 Hz: every joint's static parameters within 2%,
// and sigma0, sigma1 recovered within 2% or flagged.
TEST(FrictionFit, RecoversTable1NoiseFreeAt125Hz) {
  for (int joint = 0; joint < 3; ++joint) {
    const auto data = make_synthetic(kTable1[joint], kFirstOrder, SyntheticOptions{});
    const auto r = friction_fit::fit_joint(data.series, kFirstOrder, quick_options(), 1);
    SCOPED_TRACE(describe(r.model));
    for (int i : kStatic)
      EXPECT_NEAR(value(r.model.parameters, i), value(kTable1[joint], i), 0.02 * value(kTable1[joint], i))
          << mf::kParameterNames[i];
    for (int i : {0, 1}) {
      const auto& e = r.model.estimates[static_cast<std::size_t>(i)];
      if (e.identifiable) {
        EXPECT_NEAR(e.value, value(kTable1[joint], i), 0.02 * value(kTable1[joint], i)) << mf::kParameterNames[i];
      }
    }
    EXPECT_LT(r.model.metrics.rms, 1e-6);
    EXPECT_GT(r.model.metrics.r_squared, 0.999999);
    // LuGre explains what Stribeck cannot (the presliding behaviour at reversals).
    ASSERT_TRUE(r.static_model);
    EXPECT_GT(r.static_model->metrics.rms, 100 * r.model.metrics.rms);
  }
}

// White noise on r (0.2 Nm): static parameters within three reported standard errors, sigma0
// and sigma1 within three standard errors or flagged; the fitted friction (before the
// filter) matches the true friction to the noise level; the residual RMS is the noise.
TEST(FrictionFit, NoisyWithinConfidenceAt125Hz) {
  for (int joint = 0; joint < 3; ++joint) {
    SyntheticOptions so;
    so.r_noise = 0.2;
    so.seed = 100 + static_cast<std::uint64_t>(joint);
    const auto data = make_synthetic(kTable1[joint], kFirstOrder, so);
    const auto r = friction_fit::fit_joint(data.series, kFirstOrder, quick_options(), 2);
    SCOPED_TRACE(describe(r.model));
    ASSERT_TRUE(r.model.covariance_ok);
    for (int i : kStatic) {
      const auto& e = r.model.estimates[static_cast<std::size_t>(i)];
      EXPECT_TRUE(e.identifiable) << mf::kParameterNames[i];
      EXPECT_GT(e.standard_error, 0) << mf::kParameterNames[i];
      EXPECT_LT(std::abs(e.value - value(kTable1[joint], i)), 3 * e.standard_error) << mf::kParameterNames[i];
    }
    for (int i : {0, 1}) {
      const auto& e = r.model.estimates[static_cast<std::size_t>(i)];
      if (e.identifiable && !e.at_bound) {
        EXPECT_LT(std::abs(e.value - value(kTable1[joint], i)), 3 * e.standard_error) << mf::kParameterNames[i];
      } else {
        EXPECT_FALSE(e.note.empty());
      }
    }
    std::vector<double> tau;
    friction_fit::predict_residual(data.series, kFirstOrder, mf::Kind::lugre, r.model.parameters, {}, &tau);
    EXPECT_LT(friction_fit::testing::rms_difference(tau, data.true_friction), 0.2);
    EXPECT_NEAR(r.model.metrics.rms, 0.2, 0.02);
    EXPECT_LT(r.model.metrics.rms, r.static_model->metrics.rms);
  }
}

// At 125 Hz with noise the bristle parameters rest on the few samples after each reversal.
// The stiffness is flagged, and the report says why. The damping's uncertainty is mostly its
// sub-sample shift (refitted with the motion resolved within the intervals, it moves by more
// than its standard error), large, and it holds the truth. (Before the sandwich covariance, an
// autocorrelation factor inflated the standard errors past the flag; before the sub-sample
// shift was a refit, a first-order estimate of it flagged the damping and not the stiffness.)
TEST(FrictionFit, BristleParametersAt125HzAreFlaggedOrUncertain) {
  SyntheticOptions so;
  so.r_noise = 0.2;
  so.seed = 100;
  const auto data = make_synthetic(kTable1[0], kFirstOrder, so);
  const auto r = friction_fit::fit_joint(data.series, kFirstOrder, quick_options(), 2);
  SCOPED_TRACE(describe(r.model));
  const auto& s0 = r.model.estimates[0];
  EXPECT_FALSE(s0.identifiable);
  EXPECT_NE(s0.note.find("125 Hz"), std::string::npos) << s0.note;
  EXPECT_NE(s0.note.find("reversal"), std::string::npos) << s0.note;
  const auto& s1 = r.model.estimates[1];
  EXPECT_GT(std::abs(s1.discretization_shift), s1.standard_error);
  EXPECT_GT(s1.uncertainty, 0.25 * s1.value);
  EXPECT_LT(std::abs(s1.value - kTable1[0].sigma1), 2 * s1.uncertainty);
}

// Problem::resolve_slow, which the sub-sample shift refits with: on an interval slower than
// 4 w_s the observer's filter sees the interval's mean friction, here of the static Stribeck
// curve under a velocity rising linearly, whose mean has a closed form (erf); one step per
// sample (a ramp between the end points' friction) is off by the curve's curvature.
TEST(FrictionFitProblem, ResolvedIntervalFeedsTheFilterItsMeanFriction) {
  const mf::Parameters<double> p = kTable1[0];
  friction_fit::JointSeries series;
  series.joint = 1;
  const double dt = 0.008, acceleration = 1.0;  // 0.008 rad/s a sample, up to 0.33 < 4 w_s
  for (int k = 0; k <= 40; ++k) {
    series.t.push_back(k * dt);
    series.dq.push_back(0.001 + acceleration * dt * k);
    series.r.push_back(0.0);
    series.restart.push_back(k == 0 ? 2 : 0);
    series.scored.push_back(1);
  }
  friction_fit::FitOptions options;
  options.kind = mf::Kind::stribeck;
  friction_fit::Problem one_step(series, kFirstOrder, mf::Kind::stribeck, options);
  friction_fit::Problem resolved = one_step;
  resolved.resolve_slow = 16;
  auto outputs = [&](const friction_fit::Problem& problem) {
    std::vector<double> y;
    problem.simulate(p, [&](std::size_t, double r, double) { y.push_back(r); });
    return y;
  };
  const std::vector<double> y_one = outputs(one_step), y_resolved = outputs(resolved);
  // The reference: the filter fed each interval's exact mean friction as a constant.
  auto mean_friction = [&](double v0, double v1) {
    const double dip = (p.tau_s - p.tau_c) * p.w_s * std::sqrt(M_PI) / 2 *
                       (std::erf(v1 / p.w_s) - std::erf(v0 / p.w_s)) / (v1 - v0);
    return p.tau_c + dip + p.sigma2 * 0.5 * (v0 + v1);
  };
  const auto c = momentum::observer::discretize(kFirstOrder, dt);
  momentum::observer::FilterState<double> filter;
  double worst_resolved = 0, worst_one_step = 0;
  for (std::size_t k = 1; k < series.t.size(); ++k) {
    const double m = mean_friction(series.dq[k - 1], series.dq[k]);
    filter.advance(c, m, m);
    worst_resolved = std::max(worst_resolved, std::abs(y_resolved[k] - filter.output(c)));
    worst_one_step = std::max(worst_one_step, std::abs(y_one[k] - filter.output(c)));
  }
  std::printf("largest |r - r_exact|: %.3g Nm resolved, %.3g Nm one step per sample\n", worst_resolved,
              worst_one_step);
  EXPECT_LT(worst_resolved, 1e-4);
  EXPECT_GT(worst_one_step, 10 * worst_resolved);
}

// The second-order observer (high-pass K2) changes r completely; the fit follows it.
TEST(FrictionFit, SecondOrderObserver) {
  const auto data = make_synthetic(kTable1[2], kSecondOrder, SyntheticOptions{});
  const auto r = friction_fit::fit_joint(data.series, kSecondOrder, quick_options(), 3);
  SCOPED_TRACE(describe(r.model));
  for (int i : kStatic)
    EXPECT_NEAR(value(r.model.parameters, i), value(kTable1[2], i), 0.02 * value(kTable1[2], i))
        << mf::kParameterNames[i];
}

// Fitting without the observer's filter (a filter so fast it is none) biases the parameters:
// the reason the model includes the filter.
TEST(FrictionFit, IgnoringTheFilterBiasesTheFit) {
  const momentum::observer::Gains slow{10.0, 0.0, 0.0}, none{1e6, 0.0, 0.0};
  const auto data = make_synthetic(kTable1[0], slow, SyntheticOptions{});
  auto o = quick_options();
  o.compare_static = false;
  const auto right = friction_fit::fit_joint(data.series, slow, o, 4);
  const auto wrong = friction_fit::fit_joint(data.series, none, o, 4);
  EXPECT_LT(right.model.metrics.rms, 1e-6);
  EXPECT_GT(wrong.model.metrics.rms, 0.5);
  double worst = 0;
  for (int i : kStatic)
    worst = std::max(worst, std::abs(value(wrong.model.parameters, i) / value(kTable1[0], i) - 1));
  EXPECT_GT(worst, 0.05);
}

// The global search alone is reproducible to the bit; the Ceres polish improves on it.
TEST(FrictionFit, GlobalSearchReproducibleAndPolishImproves) {
  SyntheticOptions so;
  so.r_noise = 0.1;
  const auto data = make_synthetic(kTable1[0], kFirstOrder, so);
  auto o = quick_options();
  o.polish.enabled = false;
  o.compare_static = false;
  const auto a = friction_fit::fit_joint(data.series, kFirstOrder, o, 77);
  const auto b = friction_fit::fit_joint(data.series, kFirstOrder, o, 77);
  for (int i = 0; i < 6; ++i)
    EXPECT_TRUE(same_bits(value(a.model.parameters, i), value(b.model.parameters, i))) << i;
  EXPECT_TRUE(same_bits(a.model.metrics.cost, b.model.metrics.cost));
  EXPECT_EQ(a.model.evaluations, b.model.evaluations);
  EXPECT_EQ(a.model.metrics.cost, a.model.global.cost);
  const auto c = friction_fit::fit_joint(data.series, kFirstOrder, o, 78);
  EXPECT_FALSE(same_bits(a.model.metrics.cost, c.model.metrics.cost));

  o.polish.enabled = true;
  const auto p = friction_fit::fit_joint(data.series, kFirstOrder, o, 77);
  EXPECT_TRUE(same_bits(p.model.global.cost, a.model.global.cost));
  // It removes most of the cost the search left above the noise's own, 1/2 sigma^2 per sample
  // (how much is left above it depends on the search's draws).
  const double noise = 0.5 * so.r_noise * so.r_noise * static_cast<double>(a.model.metrics.samples);
  EXPECT_LT(p.model.metrics.cost - noise, 0.5 * (a.model.metrics.cost - noise)) << describe(p.model) << describe(a.model);
  EXPECT_GT(p.model.polish_iterations, 0);
}

namespace {

// The paper's three joints on its motion, 0.1 Nm of noise in r, seeds first_seed.. (joints 1..3).
std::vector<friction_fit::JointSeries> three_joints(std::uint64_t first_seed) {
  std::vector<friction_fit::JointSeries> series;
  for (int joint = 0; joint < 3; ++joint) {
    SyntheticOptions so;
    so.r_noise = 0.1;
    so.seed = first_seed + static_cast<std::uint64_t>(joint);
    auto d = make_synthetic(kTable1[joint], kFirstOrder, so).series;
    d.joint = joint + 1;
    series.push_back(d);
  }
  return series;
}

// quick_options() with a search too short to find anything: for tests of the scheduling.
friction_fit::FitOptions few_generations() {
  auto o = quick_options();
  o.global.genetic.population = 20;
  o.global.genetic.generations = 10;
  return o;
}

}  // namespace

// Joints fitted in parallel give the same bits as one after the other.
TEST(FrictionFit, ParallelJointsMatchSequential) {
  const auto series = three_joints(5);
  const std::vector<momentum::observer::Gains> gains(3, kFirstOrder);
  const auto o = few_generations();
  const auto one = friction_fit::fit_joints(series, gains, o, 1);
  const auto two = friction_fit::fit_joints(series, gains, o, 2);
  ASSERT_EQ(one.size(), 3u);
  for (std::size_t j = 0; j < 3; ++j) {
    EXPECT_EQ(one[j].joint, static_cast<int>(j) + 1);
    for (int i = 0; i < 6; ++i)
      EXPECT_TRUE(same_bits(value(one[j].model.parameters, i), value(two[j].model.parameters, i)));
    EXPECT_TRUE(same_bits(one[j].static_model->metrics.cost, two[j].static_model->metrics.cost));
    // And equal to fitting the joint alone with its derived seed.
    const auto alone = friction_fit::fit_joint(series[j], gains[j], o, momentum::core::derive_seed(o.global.genetic.seed, j + 1));
    EXPECT_TRUE(same_bits(alone.model.metrics.cost, two[j].model.metrics.cost));
    EXPECT_TRUE(same_bits(alone.static_model->metrics.cost, two[j].static_model->metrics.cost));
  }
}

// A joint fitted again (FitAgain) ends as a fit with its last options from the start would,
// whatever the threads and whenever the other joints finish; what the callback throws comes out.
TEST(FrictionFit, JointFittedAgainEqualsItsLastOptions) {
  const auto series = three_joints(15);
  const std::vector<momentum::observer::Gains> gains(3, kFirstOrder);
  const auto o = few_generations();
  // Joint 2 twice more, each time in a box with a lower upper bound on sigma2.
  auto narrowed = [&](int times) {
    auto n = o;
    for (int k = 0; k < times; ++k) n.bounds.upper[2] *= 0.5;
    return n;
  };
  std::vector<friction_fit::FitOptions> last{o, narrowed(2), o};
  const auto direct = friction_fit::fit_joints(series, gains, last, 2);
  for (int threads : {1, 2}) {
    std::vector<int> calls(3, 0);
    const auto again = [&](std::size_t i, const friction_fit::JointFit& fit, friction_fit::FitOptions& options) {
      EXPECT_EQ(fit.joint, static_cast<int>(i) + 1);
      if (i != 1 || calls[i]++ == 2) return false;
      options.bounds.upper[2] *= 0.5;
      return true;
    };
    const auto fits =
        friction_fit::fit_joints(series, gains, std::vector<friction_fit::FitOptions>(3, o), threads, {}, again);
    EXPECT_EQ(calls[1], 3) << threads << " threads";
    for (std::size_t j = 0; j < 3; ++j) {
      EXPECT_TRUE(same_bits(direct[j].model.metrics.cost, fits[j].model.metrics.cost)) << "joint " << j + 1;
      EXPECT_TRUE(same_bits(direct[j].static_model->metrics.cost, fits[j].static_model->metrics.cost));
    }
  }
  const auto fails = [](std::size_t i, const friction_fit::JointFit&, friction_fit::FitOptions&) -> bool {
    if (i == 2) throw std::runtime_error("joint 3 refused");
    return false;
  };
  EXPECT_THROW(
      {
        try {
          friction_fit::fit_joints(series, gains, std::vector<friction_fit::FitOptions>(3, o), 2, {}, fails);
        } catch (const std::runtime_error& e) {
          EXPECT_STREQ(e.what(), "joint 3 refused");
          throw;
        }
      },
      std::runtime_error);
}

// Static models recover their own parameters; Coulomb-viscous is linear and exact.
TEST(FrictionFit, StaticModels) {
  SyntheticOptions so;
  so.kind = mf::Kind::stribeck;
  const mf::Parameters<double> truth{0, 0, 1.5, 3.0, 4.5, 0.06};
  const auto data = make_synthetic(truth, kFirstOrder, so);
  auto o = quick_options();
  o.kind = mf::Kind::stribeck;
  const auto r = friction_fit::fit_joint(data.series, kFirstOrder, o, 5);
  SCOPED_TRACE(describe(r.model));
  EXPECT_FALSE(r.static_model);
  for (int i : kStatic) EXPECT_NEAR(value(r.model.parameters, i), value(truth, i), 1e-6 * value(truth, i));
  EXPECT_FALSE(r.model.estimates[0].used);
  EXPECT_FALSE(r.model.estimates[0].free);
  EXPECT_EQ(r.model.free, (std::vector<int>{2, 3, 4, 5}));

  so.kind = mf::Kind::coulomb_viscous;
  const auto cv = make_synthetic(truth, kFirstOrder, so);
  o.kind = mf::Kind::coulomb_viscous;
  const auto c = friction_fit::fit_joint(cv.series, kFirstOrder, o, 5);
  EXPECT_NEAR(c.model.parameters.tau_c, 3.0, 1e-9);
  EXPECT_NEAR(c.model.parameters.sigma2, 1.5, 1e-9);
}

// A fixed parameter stays at its value and leaves the problem.
TEST(FrictionFit, FixedParameter) {
  const auto data = make_synthetic(kTable1[0], kFirstOrder, SyntheticOptions{});
  auto o = quick_options();
  o.fixed[0] = kTable1[0].sigma0;
  o.compare_static = false;
  const auto r = friction_fit::fit_joint(data.series, kFirstOrder, o, 6);
  EXPECT_EQ(r.model.parameters.sigma0, kTable1[0].sigma0);
  EXPECT_FALSE(r.model.estimates[0].free);
  EXPECT_TRUE(r.model.estimates[0].used);
  EXPECT_EQ(r.model.free.size(), 5u);
  EXPECT_NEAR(r.model.parameters.tau_s, kTable1[0].tau_s, 1e-6);
}

// A true Stribeck velocity beyond the box ends at the bound, flagged.
TEST(FrictionFit, FlagsParameterAtBound) {
  mf::Parameters<double> truth = kTable1[0];
  truth.w_s = 0.15;
  const auto data = make_synthetic(truth, kFirstOrder, SyntheticOptions{});
  const auto r = friction_fit::fit_joint(data.series, kFirstOrder, quick_options(), 7);
  SCOPED_TRACE(describe(r.model));
  EXPECT_EQ(r.model.estimates[5].at_bound, +1);
  EXPECT_NE(r.model.estimates[5].note.find("upper bound"), std::string::npos);
}

// Motion that never reverses keeps the bristles in their steady state: sigma0 and sigma1 do
// not affect r at all, and are reported as such while the others keep standard errors.
TEST(FrictionFit, NoReversalMeansNoBristleParameters) {
  friction_fit::JointSeries s;
  s.joint = 1;
  mf::JointFriction<double> f(mf::Kind::lugre, kTable1[0]);
  momentum::observer::DisturbanceFilter<double> h(kFirstOrder);
  std::uint64_t state = 3;
  for (int k = 0; k < 1000; ++k) {
    const double t = k * 0.008;
    const double w = 0.05 + 0.5 * (1 - std::cos(2 * std::numbers::pi * 0.3 * t));  // always > 0
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    const double noise = 0.05 * (static_cast<double>(state >> 11) * 0x1.0p-53 - 0.5);
    s.t.push_back(t);
    s.dq.push_back(w);
    s.r.push_back(h.step(f.step(w, 0.008), 0.008) + noise);
    s.restart.push_back(k == 0 ? 2 : 0);
    s.scored.push_back(1);
  }
  const auto r = friction_fit::fit_joint(s, kFirstOrder, quick_options(), 8);
  SCOPED_TRACE(describe(r.model));
  for (int i : {0, 1}) {
    EXPECT_FALSE(r.model.estimates[static_cast<std::size_t>(i)].identifiable) << i;
    EXPECT_NE(r.model.estimates[static_cast<std::size_t>(i)].note.find("not identifiable"), std::string::npos);
  }
  EXPECT_TRUE(r.model.covariance_ok);
  EXPECT_TRUE(std::isfinite(r.model.estimates[2].standard_error));
  EXPECT_TRUE(r.model.estimates[2].identifiable);
}

TEST(FrictionFit, RejectsInvalidOptions) {
  friction_fit::FitOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.bounds.lower[5] = 0;  // w_s must stay positive
  EXPECT_FALSE(o.IsValid(&why));
  o = {};
  o.bounds.upper[3] = o.bounds.lower[3];
  EXPECT_FALSE(o.IsValid(&why));
  o = {};
  o.fixed[4] = -1.0;
  EXPECT_FALSE(o.IsValid(&why));
  o = {};
  o.kind = mf::Kind::coulomb_viscous;
  o.fixed[2] = 1.0;
  o.fixed[3] = 1.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("nothing to fit"), std::string::npos);
  const auto data = make_synthetic(kTable1[0], kFirstOrder, SyntheticOptions{});
  EXPECT_THROW(friction_fit::fit_joint(data.series, kFirstOrder, o, 1), std::invalid_argument);
  EXPECT_THROW(friction_fit::fit_joint(data.series, {-1.0, 0, 0}, friction_fit::FitOptions{}, 1), std::invalid_argument);
}

TEST(FrictionFit, ParameterNames) {
  EXPECT_EQ(friction_fit::parameter_index("sigma0"), 0);
  EXPECT_EQ(friction_fit::parameter_index("w_s"), 5);
  EXPECT_EQ(friction_fit::parameter_index("tau"), -1);
  const auto b = friction_fit::paper_bounds();
  EXPECT_EQ(b.lower[0], 6e4);
  EXPECT_EQ(b.upper[0], 1e5);
  EXPECT_EQ(b.upper[1], 500.0);
  EXPECT_EQ(b.upper[5], 0.1);
}

// A LuGre fit left in the corner without a Stribeck effect (w_s under every counted speed, tau_s
// at its lower bound: the cost is flat there, as a search on a subset of a long log can leave
// it) is worse than the Stribeck fit of the same data; refit_from_static starts from the
// Stribeck fit and recovers the true basin.
TEST(FrictionFit, LugreMissedBasinIsRefittedFromTheStribeckFit) {
  SyntheticOptions so;
  so.r_noise = 0.02;
  so.dt = 0.001;
  so.samples = 20000;
  const mf::Parameters<double> truth{6e4, 300, 1.2, 2.2, 2.9, 0.05};
  const auto data = make_synthetic(truth, kFirstOrder, so);
  const auto o = quick_options();
  friction_fit::JointFit r = friction_fit::fit_joint(data.series, kFirstOrder, o, 3);
  ASSERT_TRUE(r.static_model);
  const friction_fit::JointFit found = r;
  // The missed basin: what the search of the simulated day's joint 5 returned, in this box.
  r.model.parameters.tau_s = o.bounds.lower[4];
  r.model.parameters.w_s = o.bounds.lower[5];
  r.model.parameters.sigma1 = o.bounds.lower[1];
  r.model.metrics = friction_fit::evaluate_fit(data.series, kFirstOrder, mf::Kind::lugre, r.model.parameters, o.friction);
  ASSERT_GT(r.model.metrics.rms, r.static_model->metrics.rms) << describe(*r.static_model);
  friction_fit::refit_from_static(r, data.series, kFirstOrder, o, 3);
  SCOPED_TRACE(describe(r.model) + describe(*r.static_model));
  EXPECT_NE(r.model.polish_message.find("refitted from the Stribeck fit"), std::string::npos);
  EXPECT_LE(r.model.metrics.rms, 1.01 * found.model.metrics.rms);
  EXPECT_NEAR(r.model.parameters.tau_s, truth.tau_s, 0.05);
  EXPECT_NEAR(r.model.parameters.w_s, truth.w_s, 0.005);
  // A fit no worse than the Stribeck one is left alone.
  friction_fit::JointFit kept = found;
  friction_fit::refit_from_static(kept, data.series, kFirstOrder, o, 3);
  EXPECT_TRUE(same_bits(kept.model.metrics.cost, found.model.metrics.cost));
  EXPECT_EQ(kept.model.polish_message, found.model.polish_message);
}
