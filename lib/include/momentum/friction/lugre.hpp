// The LuGre model, one unit (registry.hpp lists it), templated on the scalar T (double, or
// ceres::Jet so that the fitter differentiates through it), with a stable discrete update.
//
// LuGre (Zhang et al. 2020, eq. 12):  tau_f = s0 z + s1 dz/dt + s2 w,
//   dz/dt = w - s0 |w| z / g(w),   g(w) = tau_c + (tau_s - tau_c) exp(-(w/w_s)^2).
// The bristle equation is stiff (s0 ~ 1e5 Nm/rad): explicit Euler diverges at dt = 8 ms, so it
// is not offered. For a velocity held constant over a step, z relaxes exponentially to
// z_ss = g(w) sign(w) / s0 with rate lambda = s0 |w| / g(w); the exact update uses that. The
// paper's semi-implicit update (eq. 13b) is offered for comparison. Both keep z a convex
// combination of its previous value and z_ss, so |z| <= max(tau_c, tau_s) / s0 forever once it
// holds (it holds for z = 0), whatever the velocity sequence and the step (bristle_step).
// Its steady state is the Stribeck model (stribeck.hpp).
//
// Units: w rad/s (m/s for prismatic joints), torques Nm (N), z rad, dt s.
#pragma once

#include <string>

#include "momentum/friction/parameters.hpp"
#include "momentum/friction/stribeck.hpp"

namespace momentum::friction {

// Advances the LuGre bristle state z (rad) over a step of dt seconds (>= 0) during which the
// velocity is w, and returns the friction torque at the end of the step, Nm:
// sigma0 z + sigma1 dz/dt + sigma2 w, with dz/dt = w - s0 |w| z / g(w) evaluated at the new z.
// Requires sigma0 > 0 and g(w) > 0 (see IsValid()); no other failure case.
template <class T>
T lugre_step(const Parameters<T>& p, const T& w, double dt, LugreUpdate update, T& z) {
  const T dz = bristle_step(p.sigma0, stribeck_level(p, w), w, dt, update, z);
  return p.sigma0 * z + p.sigma1 * dz + p.sigma2 * w;
}

struct Lugre {
  // Its name in the profile's JSON and for --model, and another spelling accepted (none).
  static constexpr const char* kName = "lugre";
  static constexpr const char* kAlias = "";
  // The parameters it reads (array order: parameters.hpp), then the optional asymmetry ones.
  static constexpr int kParameters[] = {0, 1, 2, 3, 4, 5};  // sigma0, sigma1, sigma2, tau_c, tau_s, w_s
  static constexpr int kAsymmetry[] = {6, 7};               // delta_c, delta_s
  // A bristle state advanced by the profile's "update".
  static constexpr bool kHasState = true;

  // True when parameter i must be > 0, not merely >= 0: sigma0, tau_c, tau_s, w_s.
  static constexpr bool must_be_positive(int i) { return i == 0 || Stribeck::must_be_positive(i); }

  // Both directions' levels positive: outside this the rate would change sign.
  template <class T>
  static bool feasible(const Parameters<T>& p) {
    return Stribeck::feasible(p);
  }

  // Finite parameters, the Stribeck checks (sigma2 >= 0, levels positive in both directions,
  // w_s > 0), sigma0 > 0, sigma1 >= 0; false with the reason in `why` (when non-null).
  static bool IsValid(const Parameters<double>& p, std::string* why);

  // The torque after dt seconds at velocity w, Nm, advancing z (lugre_step).
  template <class T>
  static T step(const Parameters<T>& p, const T& w, double dt, LugreUpdate update, T& z) {
    return lugre_step(p, w, dt, update, z);
  }
  // The first sample: the steady state for that velocity (z = g(w) sign(w) / s0), so that a log
  // that starts in motion has no start-up transient.
  template <class T>
  static T start(const Parameters<T>& p, const T& w, T& z) {
    z = Stribeck::sliding_level(p, w) * detail::sign(w) / p.sigma0;
    return Stribeck::steady(p, w);
  }
  // The sliding level the bristles saturate at, and the friction at constant velocity: LuGre's
  // steady state is the Stribeck model, so both are Stribeck's.
  template <class T>
  static T sliding_level(const Parameters<T>& p, const T& w) {
    return Stribeck::sliding_level(p, w);
  }
  template <class T>
  static T steady(const Parameters<T>& p, const T& w) {
    return Stribeck::steady(p, w);
  }
  // The steady state's parameter gradient and where it becomes affine: Stribeck's.
  static void steady_gradient(const Parameters<double>& p, double w, double* gradient) {
    Stribeck::steady_gradient(p, w, gradient);
  }
  static double affine_from(const Parameters<double>& p, double direction, double* constant, double* slope) {
    return Stribeck::affine_from(p, direction, constant, slope);
  }
};

}  // namespace momentum::friction
