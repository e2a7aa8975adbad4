// The momentum observer's disturbance filter: the transfer function H(s) from the disturbance
// torque tau_d to the residual r, discretized exactly for inputs that are linear between
// samples (first-order hold), with each interval's own dt.
//
//   first order (K2 = 0, K3 = 0):  H(s) = K1 / (s + K1)
//   second order (paper eq. 9):    H(s) = K1 s / ((s + K1)(s + K2))
//   with feed-forward K3 (eq. 11): H(s) = (K1 + K3) s / ((s + K1)(s + K2))
//
// Realization: with LP_K = K/(s+K) (unit-gain low-pass),
//   K1 != K2:  H = (K1+K3)/(K1-K2) (LP_K1 - LP_K2)     (K2 = 0 gives (K1+K3)/K1 LP_K1)
//   K1 == K2:  H = (K+K3)/K (LP_K - LP_K^2)            (repeated pole)
// Two states per joint: s1 = LP_K1 x and s2 = LP_K2 x (or LP_K^2 x), output gain (s1 - s2).
// Gains within a relative 1e-6 of each other use the repeated-pole form at their mean (error
// of order 1e-12; the distinct form would lose up to 6 digits to cancellation there).
//
// The same code serves three uses, so they agree to rounding:
//  - the observer (observer.hpp) feeds tau_d = u - dp/dt with u = tau_m - beta linear and p
//    linear between samples, i.e. per interval x_start = u_k - dp/dt, x_end = u_k+1 - dp/dt
//    with dp/dt = (p_k+1 - p_k)/dt. For the first order this is the classic observer
//    r = K (p - p(0) - integral(u - r)), exact when u and p are linear between samples;
//  - friction compensation: the observer applied to u - tau_f, which equals r - F(tau_f);
//  - the fitter compares r with F(LuGre(dq)) through DisturbanceFilter<ceres::Jet>.
// Coefficients depend only on the gains and dt (doubles); states and inputs are templated.
#pragma once

#include <algorithm>
#include <string>

namespace momentum::observer {

// Observer gains of one joint, 1/s. K1 = 2 pi f for a cutoff frequency f in Hz.
struct Gains {
  double k1 = 50.0;  // low-pass gain, > 0
  double k2 = 0.0;   // high-pass gain of the second-order observer, >= 0 (0 = first order)
  double k3 = 0.0;   // feed-forward gain (paper eq. 10-11), >= 0

  // False (with the reason in `why`, when non-null) for non-finite or out-of-range gains.
  bool IsValid(std::string* why) const;
};

// Coefficients of one sample interval:
//   s1' = a1 s1 + b10 x_start + b11 x_end
//   s2' = a2 s2 + c21 s1 + b20 x_start + b21 x_end     (s1 before the update)
//   output = gain (s1 - s2)
struct FilterCoefficients {
  double a1 = 1, b10 = 0, b11 = 0;
  double a2 = 1, c21 = 0, b20 = 0, b21 = 0;
  double gain = 0;
};

// Exact first-order-hold coefficients for gains `gains` (assumed valid) over an interval of
// dt seconds (> 0, finite).
FilterCoefficients discretize(const Gains& gains, double dt);

// The coefficients of one interval for two joints at once (V = core::lanes::Pair), or for one
// (V = double): what FilterState<V>::advance() takes in place of FilterCoefficients.
template <class V>
struct FilterCoefficientLanes {
  V a1, b10, b11, a2, c21, b20, b21, gain;
};

// Values computed for the last few intervals (the filter coefficients), found by the interval
// bit for bit. The intervals of a steady rate are not one value: t = k / rate rounds, so dt is
// 1/rate plus a few ulps of t, 2 or 3 values alternating in any stretch of a stream (about 20
// over an hour at 1 kHz). With one slot most rows would discretize again; with four nearly
// every row finds its coefficients, and they are those discretizing afresh gives, bit for bit.
template <class T, int Slots = 4>
class IntervalCache {
 public:
  IntervalCache() { std::fill(dt_, dt_ + Slots, -1.0); }
  // What is stored for exactly dt (s), or nullptr.
  T* find(double dt) {
    for (int k = 0; k < Slots; ++k)
      if (dt_[k] == dt) return &value_[k];
    return nullptr;
  }
  // The slot for dt, in place of the one filled longest ago; the caller fills it.
  T& insert(double dt) {
    const int k = next_;
    next_ = (next_ + 1) % Slots;
    dt_[k] = dt;
    return value_[k];
  }

 private:
  double dt_[Slots];
  T value_[Slots] = {};
  int next_ = 0;
};

// The filter's state for one joint (two numbers). Starts at rest (output 0).
template <class T>
struct FilterState {
  T s1 = T(0);
  T s2 = T(0);

  void reset() { s1 = T(0); s2 = T(0); }
  // Advances over one interval whose input goes linearly from x_start to x_end. `c`: a
  // FilterCoefficients, or a FilterCoefficientLanes of T's lanes.
  template <class Coefficients>
  void advance(const Coefficients& c, const T& x_start, const T& x_end) {
    const T s1_before = s1;
    s1 = c.a1 * s1 + c.b10 * x_start + c.b11 * x_end;
    s2 = c.a2 * s2 + c.c21 * s1_before + c.b20 * x_start + c.b21 * x_end;
  }
  // The filter output at the end of the last interval, in the input's unit.
  template <class Coefficients>
  T output(const Coefficients& c) const { return c.gain * (s1 - s2); }
};

// H(s) applied to any sampled torque signal, sample by sample: the filter the fitter passes
// LuGre's prediction through before comparing it with the observer's r. Starts at rest: the
// first sample after construction or reset() gives 0, as the observer's r does.
template <class T>
class DisturbanceFilter {
 public:
  explicit DisturbanceFilter(const Gains& gains) : gains_(gains) {}

  void reset() { started_ = false; state_.reset(); }

  // Filter output for the sample x, taken dt seconds (> 0) after the previous one (dt is
  // ignored on the first sample). The signal is linear between samples.
  T step(const T& x, double dt) {
    if (!started_) {
      started_ = true;
      previous_ = x;
      return T(0);
    }
    const FilterCoefficients* c = coefficients_.find(dt);
    if (!c) c = &(coefficients_.insert(dt) = discretize(gains_, dt));
    state_.advance(*c, previous_, x);
    previous_ = x;
    return state_.output(*c);
  }

  const Gains& gains() const { return gains_; }

 private:
  Gains gains_;
  FilterState<T> state_;
  IntervalCache<FilterCoefficients> coefficients_;
  T previous_ = T(0);
  bool started_ = false;
};

}  // namespace momentum::observer
