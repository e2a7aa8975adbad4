// The parameters every joint friction model is written in, and the pieces of friction the models
// share (the direction-dependent levels, the Stribeck curve). A model (lugre.hpp, stribeck.hpp,
// coulomb_viscous.hpp, ...) says which of these parameters it reads and what it does with them;
// registry.hpp lists the models.
//
// Units: w rad/s (m/s for prismatic joints), torques Nm (N), dt s.
#pragma once

#include <cmath>
#include <string>

namespace momentum::friction {

// Eight parameters per joint, in this order everywhere a vector of them is used (fitter, JSON):
// sigma0, sigma1, sigma2, tau_c, tau_s, w_s, delta_c, delta_s. A model ignores what it does not
// read (its `parameters` and `asymmetry` lists).
//
// Direction asymmetry (real gearboxes): delta_c and delta_s are half the difference between the
// levels for positive and for negative velocity, so the Coulomb level is tau_c + delta_c moving
// forward and tau_c - delta_c moving backward (tau_c is their mean), and likewise tau_s +-
// delta_s. A constant torque offset o during sliding (a current-sensor bias, a cable pulling one
// way) is the special case delta_c = delta_s = o. Both default to 0 (symmetric friction), so
// parameter sets written without them keep their meaning; every model reads the levels through
// coulomb_level() and stribeck_level() only.
template <class T>
struct Parameters {
  T sigma0 = T(0);  // bristle stiffness, Nm/rad, > 0 (LuGre)
  T sigma1 = T(0);  // bristle (micro) damping, Nm s/rad, >= 0 (LuGre)
  T sigma2 = T(0);  // viscous coefficient, Nm s/rad, >= 0
  T tau_c = T(0);   // Coulomb level (mean of both directions), Nm, > 0 (>= 0 for Coulomb-viscous)
  T tau_s = T(0);   // static (breakaway) level (mean of both directions), Nm, > 0
  T w_s = T(1);     // Stribeck velocity, rad/s, > 0
  T delta_c = T(0); // Coulomb asymmetry, Nm, |delta_c| < tau_c (<= for Coulomb-viscous)
  T delta_s = T(0); // static-level asymmetry, Nm, |delta_s| < tau_s

  static constexpr int kSize = 8;

  // From / to a plain array of kSize values in the order above.
  static Parameters from_array(const T* x) { return {x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7]}; }
  void to_array(T* x) const {
    x[0] = sigma0; x[1] = sigma1; x[2] = sigma2; x[3] = tau_c; x[4] = tau_s; x[5] = w_s;
    x[6] = delta_c; x[7] = delta_s;
  }
  // Converts every parameter to another scalar type (double -> Jet for the fitter).
  template <class U>
  Parameters<U> cast() const {
    return {U(sigma0), U(sigma1), U(sigma2), U(tau_c), U(tau_s), U(w_s), U(delta_c), U(delta_s)};
  }
};

// Names of the parameters in array order, as used in the profile's JSON.
inline constexpr const char* kParameterNames[8] = {"sigma0", "sigma1", "sigma2", "tau_c",
                                                   "tau_s",  "w_s",    "delta_c", "delta_s"};
// Their units (rotary joints), in array order.
inline constexpr const char* kParameterUnits[8] = {"Nm/rad", "Nm s/rad", "Nm s/rad", "Nm",
                                                   "Nm",     "rad/s",    "Nm",       "Nm"};
// Index of the first signed parameter: delta_c and delta_s may be negative, the others not.
inline constexpr int kFirstSignedParameter = 6;

// What a parameter measures. It decides how the fitter's default search box scales to a robot
// (friction_fit::scaled_bounds: to the torques and speeds of the joint's data) and which end
// of the box is a physical limit rather than a choice (physical_lower_bound).
enum class Quantity {
  stiffness,  // Nm/rad, the bristles' sigma0: the paper's box, not scaled
  damping,    // Nm s/rad, the bristles' sigma1: the paper's box, not scaled, >= 0
  viscous,    // Nm s/rad, sigma2: [0, torque scale / speed scale]
  level,      // Nm, tau_c and tau_s: (0, torque scale]
  velocity,   // rad/s, w_s: (0, min(0.1, velocity limit)]
  asymmetry,  // Nm, signed, delta_c and delta_s: [-0.3, 0.3] x torque scale
};
// In array order.
inline constexpr Quantity kParameterQuantities[8] = {Quantity::stiffness, Quantity::damping, Quantity::viscous,
                                                     Quantity::level,     Quantity::level,   Quantity::velocity,
                                                     Quantity::asymmetry, Quantity::asymmetry};

// The default search box of each parameter, in array order: the paper's (Zhang et al. 2020,
// sect. 4): sigma0 [6e4, 1e5] Nm/rad, sigma1 [0, 500] and sigma2 [0, 10] Nm s/rad, tau_c and
// tau_s (0, 10] Nm, w_s (0, 0.1] rad/s; the open lower ends of the parameters that must be
// positive are 1e-6 of the upper end. Not in the paper: the asymmetries in [-3, 3] Nm (30% of
// the paper's largest levels). Every model that reads a parameter searches the same box, which
// the fitter scales to the robot unless told not to (mo-friction-fit --paper-bounds).
struct SearchRange {
  double lower, upper;
};
inline constexpr SearchRange kDefaultSearchBox[8] = {{6e4, 1e5},   {0.0, 500.0},  {0.0, 10.0}, {1e-5, 10.0},
                                                     {1e-5, 10.0}, {1e-7, 0.1},   {-3.0, 3.0}, {-3.0, 3.0}};

// True when the lower end of parameter i's box is a physical limit the search may not pass
// (sigma1, sigma2 >= 0; tau_c, tau_s, w_s > 0), not a choice like sigma0's 6e4 or the
// asymmetries' -3; no upper end is.
constexpr bool physical_lower_bound(int i) {
  const Quantity q = kParameterQuantities[i];
  return q == Quantity::damping || q == Quantity::viscous || q == Quantity::level || q == Quantity::velocity;
}

// How a model with an internal state (a bristle deflection z) advances it over one sample
// interval.
enum class LugreUpdate {
  exact,          // exponential relaxation for a velocity constant over the step (default)
  semi_implicit,  // the paper's eq. 13b (backward Euler in z)
};

namespace detail {
template <class T>
T sign(const T& w) {
  if (w > T(0)) return T(1);
  if (w < T(0)) return T(-1);
  return T(0);
}
}  // namespace detail

// The Coulomb level of the direction of w, Nm: tau_c + sign(w) delta_c.
template <class T>
T coulomb_level(const Parameters<T>& p, const T& w) {
  return p.tau_c + detail::sign(w) * p.delta_c;
}

// The Stribeck level g(w) = c + (s - c) exp(-(w/w_s)^2), Nm, with c = tau_c + sign(w) delta_c
// and s = tau_s + sign(w) delta_s: the sliding friction magnitude at velocity w. Positive
// whenever the levels of both directions are (see IsValid()).
template <class T>
T stribeck_level(const Parameters<T>& p, const T& w) {
  using std::exp;
  const T x = w / p.w_s;
  const T direction = detail::sign(w);
  const T c = p.tau_c + direction * p.delta_c;
  // Past 6 w_s the Stribeck term is under 2.4e-16 of the drop: c alone (no exp for the many
  // samples at speed; the observer steps this on every row of every joint).
  if (x * x > T(36)) return c;
  const T s = p.tau_s + direction * p.delta_s;
  return c + (s - c) * exp(-x * x);
}

// Static Stribeck friction, Nm: g(w) sign(w) + sigma2 w (0 at w = 0). This is the LuGre steady
// state for a constant velocity.
template <class T>
T stribeck_torque(const Parameters<T>& p, const T& w) {
  return stribeck_level(p, w) * detail::sign(w) + p.sigma2 * w;
}

// Coulomb-viscous friction, Nm: (tau_c + sign(w) delta_c) sign(w) + sigma2 w (0 at w = 0).
template <class T>
T coulomb_viscous_torque(const Parameters<T>& p, const T& w) {
  const T direction = detail::sign(w);
  return (p.tau_c + direction * p.delta_c) * direction + p.sigma2 * w;
}

// Advances a bristle state z (rad) over a step of dt seconds (>= 0) during which the velocity
// is w, for dz/dt = w - sigma0 |w| z / level with a level > 0 constant over the step (LuGre:
// g(w); Dahl: the Coulomb level), and returns dz/dt at the end of the step, rad/s. For a
// velocity held constant over a step, z relaxes exponentially to z_ss = level sign(w) / sigma0
// with rate lambda = sigma0 |w| / level; `exact` uses that, `semi_implicit` is the paper's eq.
// 13b. Both keep z a convex combination of its previous value and z_ss, so |z| <= level_max /
// sigma0 forever once it holds (it holds for z = 0), whatever the velocities and the steps.
// Always inlined: the observer steps it on every row of every joint, and as a call of its own
// (LuGre and Dahl share it) it cost 0.4% of mo-observe's instructions.
template <class T>
[[gnu::always_inline]] inline T bristle_step(const T& sigma0, const T& level, const T& w, double dt, LugreUpdate update, T& z) {
  using std::abs;
  const T rate = sigma0 * abs(w) / level;  // lambda, 1/s
  T dz;
  if (update == LugreUpdate::exact) {
    // z(dt) = z e^{-x} + w dt (1 - e^{-x}) / x with x = lambda dt; dz/dt(dt) = (w - lambda z) e^{-x}.
    // One expm1 gives both e^{-x} (absolute error ~1e-16, which is what z needs) and an accurate
    // (1 - e^{-x}) / x; a series takes over near x = 0 so that Jets keep their derivatives.
    const T x = rate * dt;
    T decay, relaxed;
    if (x < T(1e-4)) {
      decay = T(1) - x * (T(1) - x * (T(0.5) - x * T(1.0 / 6)));
      relaxed = T(1) - x * (T(0.5) - x * (T(1.0 / 6) - x * T(1.0 / 24)));
    } else {
      using std::expm1;
      const T m = expm1(-x);
      decay = T(1) + m;
      relaxed = -m / x;
    }
    dz = (w - rate * z) * decay;
    z = z * decay + w * dt * relaxed;
  } else {
    dz = (w - rate * z) / (T(1) + rate * dt);
    z = z + dz * dt;
  }
  return dz;
}

// Checks shared by the models' IsValid: each returns false with the reason in `why` (when
// non-null) naming the parameter and its value.
namespace check {
// Every parameter listed (indices into the array order) is a finite number.
bool finite(const Parameters<double>& p, const int* first, const int* last, std::string* why);
// Parameter i is >= 0 ("is negative").
bool not_negative(const Parameters<double>& p, int i, std::string* why);
// Parameter i is > 0 ("is not positive").
bool positive(const Parameters<double>& p, int i, std::string* why);
// |asymmetry| < level (strictly: the level of one direction stays positive).
bool below(const Parameters<double>& p, int asymmetry, int level, std::string* why);
// |asymmetry| <= level (the level of one direction stays non-negative).
bool not_above(const Parameters<double>& p, int asymmetry, int level, std::string* why);
}  // namespace check

// "exact", "semi-implicit".
const char* update_name(LugreUpdate update);
// Inverse of update_name (also accepts "semi_implicit"); false when unknown.
bool parse_update(const std::string& name, LugreUpdate* update);

}  // namespace momentum::friction
