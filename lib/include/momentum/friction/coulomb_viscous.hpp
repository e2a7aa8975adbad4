// The Coulomb-viscous model, one unit (registry.hpp lists it):
//   tau_f = (tau_c + sign(w) delta_c) sign(w) + sigma2 w   (0 at w = 0).
// No internal state.
#pragma once

#include <cmath>
#include <string>

#include "momentum/friction/parameters.hpp"

namespace momentum::friction {

struct CoulombViscous {
  // Its name in the profile's JSON and for --model, and another spelling accepted.
  static constexpr const char* kName = "coulomb-viscous";
  static constexpr const char* kAlias = "coulomb_viscous";
  // The parameters it reads (array order: parameters.hpp), then the optional asymmetry one.
  static constexpr int kParameters[] = {2, 3};  // sigma2, tau_c
  static constexpr int kAsymmetry[] = {6};      // delta_c
  // No bristle state: the profile's "update" does not apply.
  static constexpr bool kHasState = false;

  // No parameter must be strictly positive (a zero Coulomb level is a viscous damper).
  static constexpr bool must_be_positive(int) { return false; }

  // Both directions' levels non-negative.
  template <class T>
  static bool feasible(const Parameters<T>& p) {
    using std::abs;
    return !(abs(p.delta_c) > p.tau_c);
  }

  // Finite parameters, sigma2 >= 0, tau_c >= 0, |delta_c| <= tau_c; false with the reason in
  // `why` (when non-null).
  static bool IsValid(const Parameters<double>& p, std::string* why);

  // The torque for velocity w, Nm (dt and the state z are not used).
  template <class T>
  static T step(const Parameters<T>& p, const T& w, double, LugreUpdate, T&) {
    return coulomb_viscous_torque(p, w);
  }
  // The first sample (no previous one), Nm.
  template <class T>
  static T start(const Parameters<T>& p, const T& w, T&) {
    return coulomb_viscous_torque(p, w);
  }
  // The sliding friction level at velocity w, Nm: the direction's Coulomb level.
  template <class T>
  static T sliding_level(const Parameters<T>& p, const T& w) {
    return coulomb_level(p, w);
  }
  // Friction at constant velocity w, Nm.
  template <class T>
  static T steady(const Parameters<T>& p, const T& w) {
    return coulomb_viscous_torque(p, w);
  }

  // d|F(w)|/d(parameter) of the steady friction in array order (8 values written), for the
  // direction of w (w = 0: the positive side).
  static void steady_gradient(const Parameters<double>&, double w, double* gradient) {
    for (int i = 0; i < Parameters<double>::kSize; ++i) gradient[i] = 0;
    gradient[2] = std::abs(w);
    gradient[3] = 1;
    gradient[6] = w < 0 ? -1.0 : 1.0;
  }
  // steady_gradient is affine in |w| everywhere: tau_c: 1, delta_c: direction, sigma2: |w|.
  static double affine_from(const Parameters<double>&, double direction, double* constant, double* slope) {
    for (int i = 0; i < Parameters<double>::kSize; ++i) constant[i] = slope[i] = 0;
    constant[3] = 1;
    constant[6] = direction;
    slope[2] = 1;
    return 0.0;
  }
};

}  // namespace momentum::friction
