// Synthetic observer output for friction-fit tests and benchmarks: the paper's motion
// (y = 0.6 sin(2 pi 0.2 t), entered from rest by a quintic blend), its true friction from the
// friction library's JointFriction, and the observer's residual of friction-only motion,
// r = H(s) tau_f, from the observer library's DisturbanceFilter, plus optional white noise on
// r and on the measured velocity.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include "momentum/friction_fit/data.hpp"
#include "momentum/friction/friction.hpp"
#include "momentum/observer/filter.hpp"

namespace momentum::friction_fit::testing {

// The paper's Table 1 (Zhang et al. 2020), joints 1..3 (sigma0, sigma1, sigma2, tau_c, tau_s,
// w_s). Note tau_c > tau_s there.
inline const friction::Parameters<double> kTable1[3] = {
    {98467.9088, 314.0483, 6.4865, 7.8322, 4.0033, 0.0978},
    {95487.8562, 499.4331, 6.1838, 8.1855, 4.5407, 0.0996},
    {94546.6673, 489.1297, 5.3929, 7.0023, 4.9450, 0.0917},
};

struct Synthetic {
  JointSeries series;                 // what the fitter sees (r and dq possibly noisy)
  std::vector<double> true_friction;  // tau_f from the true velocity, Nm
  std::vector<double> clean_r;        // H(s) tau_f without noise, Nm
};

struct SyntheticOptions {
  double dt = 0.008;          // s
  int samples = 1251;
  double blend = 1.0;         // s, quintic entry from rest
  double amplitude = 0.6;     // rad
  double frequency = 0.2;     // Hz
  double r_noise = 0.0;       // Nm, standard deviation of white noise on r
  double dq_noise = 0.0;      // rad/s, on the measured velocity
  double jitter = 0.0;        // s, uniform +- jitter on each sample time (0: regular)
  int restart_at = -1;        // sample index where the observer restarts (-1: none)
  std::uint64_t seed = 1;
  friction::Kind kind = friction::Kind::lugre;
  friction::Options friction;
};

// Velocity of y = S(t / blend) a sin(w t) with the quintic smoothstep S.
inline double paper_velocity(double t, const SyntheticOptions& o) {
  const double w = 2 * std::numbers::pi * o.frequency;
  double s = 1, ds = 0;
  if (t < o.blend) {
    const double x = t / o.blend;
    s = x * x * x * (10 - 15 * x + 6 * x * x);
    ds = 30 * x * x * (1 - x) * (1 - x) / o.blend;
  }
  return o.amplitude * (w * std::cos(w * t) * s + std::sin(w * t) * ds);
}

inline Synthetic make_synthetic(const friction::Parameters<double>& truth,
                                const observer::Gains& gains, const SyntheticOptions& o) {
  std::mt19937_64 rng(o.seed);
  auto uniform = [&] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
  auto normal = [&] {
    const double u1 = 1.0 - uniform(), u2 = uniform();
    return std::sqrt(-2 * std::log(u1)) * std::cos(2 * std::numbers::pi * u2);
  };
  Synthetic s;
  s.series.joint = 1;
  s.series.source = "synthetic";
  friction::JointFriction<double> f(o.kind, truth, o.friction);
  observer::DisturbanceFilter<double> h(gains);
  double t_previous = 0;
  for (int k = 0; k < o.samples; ++k) {
    double t = k * o.dt;
    if (o.jitter > 0 && k > 0) t += (2 * uniform() - 1) * o.jitter;
    const double dt = k ? t - t_previous : 0.0;
    t_previous = t;
    const double w = paper_velocity(t, o);
    const double tau = f.step(w, dt);
    if (k == o.restart_at) h.reset();
    const double r = h.step(tau, dt);
    s.true_friction.push_back(tau);
    s.clean_r.push_back(r);
    s.series.t.push_back(t);
    s.series.dq.push_back(w + (o.dq_noise > 0 ? o.dq_noise * normal() : 0.0));
    s.series.r.push_back(r + (o.r_noise > 0 ? o.r_noise * normal() : 0.0));
    s.series.restart.push_back(k == 0 ? 2 : (k == o.restart_at ? 1 : 0));
    s.series.scored.push_back(1);
  }
  return s;
}

// The paper arm's observer (its profile): second order, K1 = 50, K2 = 0.2 1/s.
inline const observer::Gains kPaperObserver{50.0, 0.2, 0.0};

// 100 s of the paper's motion at 125 Hz, with the fit's usual noise levels.
inline SyntheticOptions long_motion(std::uint64_t seed) {
  SyntheticOptions so;
  so.samples = 12500;
  so.r_noise = 0.2;
  so.seed = seed;
  return so;
}

inline double rms_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double sum = 0;
  for (std::size_t k = 0; k < a.size(); ++k) sum += (a[k] - b[k]) * (a[k] - b[k]);
  return std::sqrt(sum / static_cast<double>(a.size()));
}

}  // namespace momentum::friction_fit::testing
