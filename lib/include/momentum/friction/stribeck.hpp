// The static Stribeck model, one unit (registry.hpp lists it):
//   tau_f = g(w) sign(w) + sigma2 w,   g(w) = c + (s - c) exp(-(w/w_s)^2),
// with the direction's levels c = tau_c + sign(w) delta_c, s = tau_s + sign(w) delta_s
// (parameters.hpp). It is LuGre's steady state for a constant velocity. No internal state.
#pragma once

#include <cmath>
#include <string>

#include "momentum/friction/parameters.hpp"

namespace momentum::friction {

struct Stribeck {
  // Its name in the profile's JSON and for --model, and another spelling accepted (none).
  static constexpr const char* kName = "stribeck";
  static constexpr const char* kAlias = "";
  // The parameters it reads (array order: parameters.hpp), then the optional asymmetry ones.
  static constexpr int kParameters[] = {2, 3, 4, 5};  // sigma2, tau_c, tau_s, w_s
  static constexpr int kAsymmetry[] = {6, 7};         // delta_c, delta_s
  // No bristle state: the profile's "update" does not apply.
  static constexpr bool kHasState = false;

  // True when parameter i must be > 0, not merely >= 0: tau_c, tau_s, w_s.
  static constexpr bool must_be_positive(int i) { return i == 3 || i == 4 || i == 5; }

  // Both directions' levels positive: outside this the model is meaningless.
  template <class T>
  static bool feasible(const Parameters<T>& p) {
    using std::abs;
    return abs(p.delta_c) < p.tau_c && abs(p.delta_s) < p.tau_s;
  }

  // The checks that also hold for LuGre, whose steady state this is: sigma2 >= 0, tau_c > 0,
  // tau_s > 0, |delta_c| < tau_c, |delta_s| < tau_s, w_s > 0 (parameters finite already).
  static bool levels_valid(const Parameters<double>& p, std::string* why) {
    return check::not_negative(p, 2, why) && check::positive(p, 3, why) && check::positive(p, 4, why) &&
           check::below(p, 6, 3, why) && check::below(p, 7, 4, why) && check::positive(p, 5, why);
  }
  // Finite parameters and levels_valid; false with the reason in `why` (when non-null).
  static bool IsValid(const Parameters<double>& p, std::string* why);

  // The torque for velocity w after dt seconds, Nm (the state z is not used).
  template <class T>
  static T step(const Parameters<T>& p, const T& w, double, LugreUpdate, T&) {
    return stribeck_torque(p, w);
  }
  // The first sample (no previous one), Nm.
  template <class T>
  static T start(const Parameters<T>& p, const T& w, T&) {
    return stribeck_torque(p, w);
  }
  // The sliding friction level at velocity w, Nm: g(w).
  template <class T>
  static T sliding_level(const Parameters<T>& p, const T& w) {
    return stribeck_level(p, w);
  }
  // Friction at constant velocity w, Nm.
  template <class T>
  static T steady(const Parameters<T>& p, const T& w) {
    return stribeck_torque(p, w);
  }

  // d|F(w)|/d(parameter) of the steady friction F in array order (8 values written), for the
  // direction of w (w = 0: the positive side's limit, whose static level the joint holds at
  // breakaway).
  static void steady_gradient(const Parameters<double>& p, double w, double* gradient) {
    const double direction = w < 0 ? -1.0 : 1.0;
    const double speed = std::abs(w);
    for (int i = 0; i < Parameters<double>::kSize; ++i) gradient[i] = 0;
    gradient[2] = speed;
    const double x = speed / p.w_s;
    // Beyond 6 w_s the Stribeck term is under 1e-15 of the drop: no exp for the many rows at
    // speed (the detector asks on every row).
    const double stribeck = x < 6 ? std::exp(-x * x) : 0.0;
    const double drop = (p.tau_s + direction * p.delta_s) - (p.tau_c + direction * p.delta_c);
    gradient[3] = 1 - stribeck;
    gradient[4] = stribeck;
    gradient[5] = drop * stribeck * 2 * x * x / p.w_s;
    gradient[6] = direction * (1 - stribeck);
    gradient[7] = direction * stribeck;
  }
  // The speed from which steady_gradient is affine in |w|, rad/s: past 6 w_s (exp(-36): nothing
  // of the Stribeck term left) it is constant + slope |w| with tau_c: 1, delta_c: direction,
  // sigma2: |w| (8 values written to each).
  static double affine_from(const Parameters<double>& p, double direction, double* constant, double* slope) {
    for (int i = 0; i < Parameters<double>::kSize; ++i) constant[i] = slope[i] = 0;
    constant[3] = 1;
    constant[6] = direction;
    slope[2] = 1;
    return 6 * p.w_s;
  }
};

}  // namespace momentum::friction
