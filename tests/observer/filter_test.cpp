// The disturbance filter against an independent reference: a fine RK4 integration of the
// transfer function's controllable canonical form, driven by the linearly interpolated input.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <random>
#include <vector>

#include "momentum/observer/filter.hpp"

namespace mo = momentum::observer;

namespace {

// H(s) = (K1+K3) s / (s^2 + (K1+K2) s + K1 K2) as xi1' = xi2, xi2' = -K1K2 xi1 - (K1+K2) xi2 + x,
// y = (K1+K3) xi2; integrated with RK4 at `substeps` steps per sample interval.
std::vector<double> rk4_reference(const mo::Gains& g, const std::vector<double>& t,
                                  const std::vector<double>& x, int substeps) {
  std::vector<double> y(t.size(), 0.0);
  double xi1 = 0, xi2 = 0;
  const double a0 = g.k1 * g.k2, a1 = g.k1 + g.k2;
  for (std::size_t k = 1; k < t.size(); ++k) {
    const double h = (t[k] - t[k - 1]) / substeps;
    const double slope = (x[k] - x[k - 1]) / (t[k] - t[k - 1]);
    auto input = [&](double tau) { return x[k - 1] + slope * tau; };
    for (int i = 0; i < substeps; ++i) {
      const double tau = i * h;
      auto f1 = [&](double u1, double u2, double in) { return std::pair{u2, -a0 * u1 - a1 * u2 + in}; };
      const auto [k11, k12] = f1(xi1, xi2, input(tau));
      const auto [k21, k22] = f1(xi1 + 0.5 * h * k11, xi2 + 0.5 * h * k12, input(tau + 0.5 * h));
      const auto [k31, k32] = f1(xi1 + 0.5 * h * k21, xi2 + 0.5 * h * k22, input(tau + 0.5 * h));
      const auto [k41, k42] = f1(xi1 + h * k31, xi2 + h * k32, input(tau + h));
      xi1 += h / 6 * (k11 + 2 * k21 + 2 * k31 + k41);
      xi2 += h / 6 * (k12 + 2 * k22 + 2 * k32 + k42);
    }
    y[k] = (g.k1 + g.k3) * xi2;
  }
  return y;
}

}  // namespace

TEST(DisturbanceFilter, MatchesFineIntegrationOnIrregularSamples) {
  struct Case {
    mo::Gains gains;
    double dt;
  };
  const Case cases[] = {
      {{50, 0, 0}, 0.001},      // first order
      {{50, 5, 0}, 0.001},      // paper's second order
      {{50, 5, 20}, 0.008},     // with feed-forward K3, 125 Hz
      {{30, 30, 0}, 0.004},     // repeated pole
      {{30, 30 * (1 + 1e-8), 0}, 0.004},  // nearly repeated: handled as repeated
      {{30, 30.01, 7}, 0.004},  // close poles, distinct form
      {{5, 60, 0}, 0.002},      // K2 > K1
      {{2000, 0, 0}, 0.008},    // K dt = 16: the sample interval dwarfs the time constant
      {{2000, 1500, 0}, 0.008},
      {{0.05, 0.01, 0}, 0.001}, // K dt = 5e-5: series branch
  };
  for (const Case& c : cases) {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> jitter(0.5, 1.5), value(-5, 5);
    std::vector<double> t{0.0}, x{value(rng)};
    for (int k = 1; k < 300; ++k) {
      t.push_back(t.back() + c.dt * jitter(rng));
      x.push_back(k % 50 < 25 ? value(rng) : 3.0 + 0.01 * k);  // noise, then a slow ramp
    }
    const std::vector<double> ref = rk4_reference(c.gains, t, x, 400);
    mo::DisturbanceFilter<double> filter(c.gains);
    double scale = 0;
    for (double v : ref) scale = std::max(scale, std::abs(v));
    for (std::size_t k = 0; k < t.size(); ++k) {
      const double y = filter.step(x[k], k ? t[k] - t[k - 1] : 0.0);
      ASSERT_NEAR(y, ref[k], 1e-9 * scale + 1e-12)
          << "k1 " << c.gains.k1 << " k2 " << c.gains.k2 << " k3 " << c.gains.k3 << " sample " << k;
    }
  }
}

// In steady state a sine comes out scaled by |H(j w)|, including the K3 gain (K1+K3)/K1 of the
// feed-forward variant's transfer function (eq. 11).
TEST(DisturbanceFilter, SineGainIsTransferFunction) {
  for (const mo::Gains& g : {mo::Gains{50, 0, 0}, mo::Gains{50, 5, 0}, mo::Gains{50, 5, 25},
                             mo::Gains{40, 40, 10}}) {
    for (double f : {0.5, 3.0, 20.0}) {
      const double w = 2 * M_PI * f;
      const std::complex<double> s(0, w);
      const double gain = std::abs((g.k1 + g.k3) * s / ((s + g.k1) * (s + g.k2)));
      mo::DisturbanceFilter<double> filter(g);
      const double dt = 1e-4;
      double peak = 0;
      const int settle = static_cast<int>(20.0 / dt);  // > 40 time constants of the slowest pole
      for (int k = 0; k < settle + static_cast<int>(2.0 / f / dt); ++k) {
        const double y = filter.step(std::sin(w * k * dt), dt);
        if (k > settle) peak = std::max(peak, std::abs(y));
      }
      EXPECT_NEAR(peak, gain, 2e-4 * gain) << "f " << f << " k2 " << g.k2 << " k3 " << g.k3;
    }
  }
}

// The fitter differentiates through the filter: with Jet inputs the values equal the double
// filter's and the derivative with respect to an input scale is the filter of the input.
TEST(DisturbanceFilter, JetIsLinearInTheInput) {
  using Jet = ceres::Jet<double, 2>;
  const mo::Gains g{40, 4, 10};
  mo::DisturbanceFilter<double> plain(g), constant(g);
  mo::DisturbanceFilter<Jet> jet(g);
  const Jet scale(2.0, 0), offset(0.5, 1);
  for (int k = 0; k < 500; ++k) {
    const double dt = 0.001 * (1 + 0.3 * std::sin(k));
    const double x = std::sin(0.05 * k) + 0.2 * std::cos(0.31 * k);
    const double y = plain.step(x, dt);
    const double y1 = constant.step(1.0, dt);
    const Jet yj = jet.step(scale * x + offset, dt);
    ASSERT_NEAR(yj.a, 2.0 * y + 0.5 * y1, 1e-12);
    ASSERT_NEAR(yj.v[0], y, 1e-12);   // d/d scale
    ASSERT_NEAR(yj.v[1], y1, 1e-12);  // d/d offset
  }
}

// The coefficients found in the cache are those discretizing afresh gives, bit for bit: a
// filter fed the intervals of t = k / 1000 rounded (a few values alternating, and more than
// the cache's four slots over the run) gives the output of a state advanced with coefficients
// discretized anew at every sample. The cache finds exactly the intervals it holds, the four
// last ones filled, and not an interval one ulp away.
TEST(IntervalCache, CoefficientsAreThoseDiscretizedAfresh) {
  const mo::Gains gains{50.0, 5.0, 0.0};
  mo::DisturbanceFilter<double> filter(gains);
  mo::FilterState<double> reference;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 1.0);
  double t_previous = 0, x_previous = noise(rng);
  filter.step(x_previous, 0.0);
  for (int k = 1; k < 20000; ++k) {
    const double t = k * 0.001 + 1e4;  // far from 0: dt varies in more ulps
    const double x = noise(rng);
    const mo::FilterCoefficients c = mo::discretize(gains, t - t_previous);
    reference.advance(c, x_previous, x);
    ASSERT_EQ(filter.step(x, t - t_previous), reference.output(c)) << "sample " << k;
    t_previous = t;
    x_previous = x;
  }
  mo::IntervalCache<int> cache;
  EXPECT_EQ(cache.find(0.001), nullptr);
  for (int k = 1; k <= 5; ++k) cache.insert(0.001 * k) = k;
  EXPECT_EQ(cache.find(0.001), nullptr);  // the oldest of five went
  for (int k = 2; k <= 5; ++k) {
    ASSERT_NE(cache.find(0.001 * k), nullptr);
    EXPECT_EQ(*cache.find(0.001 * k), k);
  }
  EXPECT_EQ(cache.find(std::nextafter(0.002, 1.0)), nullptr);
}
