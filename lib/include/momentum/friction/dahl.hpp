// The Dahl model (Dahl 1968; the bristle model LuGre extends, used for joint and gear friction
// at small displacements), one unit (registry.hpp lists it), templated on the scalar T:
//   tau_f = sigma0 z + sigma2 w,   dz/dt = w (1 - sigma0 z sign(w) / c(w)) = w - sigma0 |w| z / c(w),
// with c(w) = tau_c + sign(w) delta_c the Coulomb level of the direction (parameters.hpp). It is
// LuGre without the Stribeck peak and the bristle damping: a pre-sliding spring of stiffness
// sigma0 that saturates at the Coulomb level after a travel of about c / sigma0. Advanced with
// the same exact (or semi-implicit) relaxation as LuGre (bristle_step), so |z| <= c_max / sigma0
// whatever the velocities and steps, and |tau_f - sigma2 w| <= c_max: the torque never exceeds
// the Coulomb level plus viscous friction. Steady state at constant w: Coulomb-viscous.
//
// Units: w rad/s (m/s for prismatic joints), torques Nm (N), z rad, dt s.
#pragma once

#include <string>

#include "momentum/friction/coulomb_viscous.hpp"
#include "momentum/friction/parameters.hpp"

namespace momentum::friction {

struct Dahl {
  // Its name in the profile's JSON and for --model, and another spelling accepted (none).
  static constexpr const char* kName = "dahl";
  static constexpr const char* kAlias = "";
  // The parameters it reads (array order: parameters.hpp), then the optional asymmetry one.
  static constexpr int kParameters[] = {0, 2, 3};  // sigma0, sigma2, tau_c
  static constexpr int kAsymmetry[] = {6};         // delta_c
  // A bristle state advanced by the profile's "update".
  static constexpr bool kHasState = true;

  // True when parameter i must be > 0, not merely >= 0: sigma0, tau_c.
  static constexpr bool must_be_positive(int i) { return i == 0 || i == 3; }

  // Both directions' Coulomb levels positive: outside this the rate would change sign.
  template <class T>
  static bool feasible(const Parameters<T>& p) {
    using std::abs;
    return abs(p.delta_c) < p.tau_c;
  }

  // Finite parameters, sigma2 >= 0, tau_c > 0, |delta_c| < tau_c, sigma0 > 0; false with the
  // reason in `why` (when non-null).
  static bool IsValid(const Parameters<double>& p, std::string* why);

  // The torque after dt seconds at velocity w, Nm, advancing z.
  template <class T>
  static T step(const Parameters<T>& p, const T& w, double dt, LugreUpdate update, T& z) {
    bristle_step(p.sigma0, coulomb_level(p, w), w, dt, update, z);
    return p.sigma0 * z + p.sigma2 * w;
  }
  // The first sample: the steady state for that velocity (z = c(w) sign(w) / sigma0).
  template <class T>
  static T start(const Parameters<T>& p, const T& w, T& z) {
    z = coulomb_level(p, w) * detail::sign(w) / p.sigma0;
    return coulomb_viscous_torque(p, w);
  }
  // The sliding friction level at velocity w, Nm: the direction's Coulomb level, which the
  // bristles saturate at.
  template <class T>
  static T sliding_level(const Parameters<T>& p, const T& w) {
    return coulomb_level(p, w);
  }
  // Friction at constant velocity w, Nm: Coulomb-viscous.
  template <class T>
  static T steady(const Parameters<T>& p, const T& w) {
    return coulomb_viscous_torque(p, w);
  }
  // The steady state's parameter gradient and where it is affine: Coulomb-viscous's.
  static void steady_gradient(const Parameters<double>& p, double w, double* gradient) {
    CoulombViscous::steady_gradient(p, w, gradient);
  }
  static double affine_from(const Parameters<double>& p, double direction, double* constant, double* slope) {
    return CoulombViscous::affine_from(p, direction, constant, slope);
  }
};

}  // namespace momentum::friction
