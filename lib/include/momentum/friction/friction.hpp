// Per-joint friction as the rest of the suite uses it: a FrictionModel (model kind, update
// options and parameters per joint, read from and written to the profile's "friction" section)
// and a stateful evaluator, JointFriction, that turns a velocity sample into a friction torque.
// The observer (mo-observe), the simulator (mo-sim) and the fitter (mo-friction-fit) all go through
// JointFriction::step, so they agree sample for sample.
//
// Profile section (man 5 momentum-profile):
//   "friction": {"model": "lugre",                 // or another model of registry.hpp
//                "update": "exact",                // or "semi-implicit" (LuGre only)
//                "velocity_deadband": 0.0,         // rad/s, optional
//                "velocity_cutoff_hz": 0.0,        // Hz, optional, 0 = no low-pass
//                "joints": [{"sigma0": 98467.9, "sigma1": 314.0, "sigma2": 6.49,
//                            "tau_c": 7.83, "tau_s": 4.00, "w_s": 0.0978,
//                            "delta_c": 0.4, "delta_s": 0.2}, ...]}   // optional asymmetry
// The parameters a joint holds are those its model reads (registry.hpp); delta_c and delta_s
// (parameters.hpp) are optional, 0 when absent.
// A joint may carry the covariance its fit reports for the parameters that set the steady-state
// friction (mo-friction-fit writes it; absent: unknown):
//   "covariance": {"parameters": ["sigma2", "tau_c", "tau_s", "w_s"],
//                  "matrix": [[6.6e-7, ...], ...]}          // in the parameters' units squared
#pragma once

#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "momentum/friction/registry.hpp"

namespace momentum::friction {

// How the velocity that drives the model is conditioned, and how LuGre is advanced.
//
// Standstill: a resting joint's measured velocity is noise around zero. Driven by it, LuGre
// keeps relaxing its bristle state towards +-g(w)/s0 and loses the friction it held, so the
// compensated residual of a resting joint wanders. A deadband (|w| below it counts as rest, so
// LuGre holds z and a static model gives 0) and/or a first-order low-pass on the velocity
// reduce that; both default to off because they also delay or remove genuine slow motion.
struct Options {
  LugreUpdate update = LugreUpdate::exact;
  // Velocities with |w| < velocity_deadband are treated as 0, rad/s (after the low-pass). >= 0.
  double velocity_deadband = 0.0;
  // Cutoff of a first-order low-pass on the velocity, Hz; 0 disables it. >= 0.
  double velocity_cutoff_hz = 0.0;

  // False (with the reason in `why`, when non-null) for negative or non-finite values.
  bool IsValid(std::string* why) const;
};

// The covariance of the parameters that set a joint's steady-state friction (sigma2, tau_c,
// tau_s, w_s, delta_c, delta_s: any subset; sigma0 and sigma1 shape only the transients), as
// the fit reports it. One-sigma units squared (Nm^2, Nm^2 s^2/rad^2, ...).
struct SteadyCovariance {
  std::vector<int> parameters;  // indices into kParameterNames, each in 2..7, no repeats
  std::vector<double> matrix;   // parameters.size()^2, row-major, symmetric, diagonal >= 0
};

// A friction model for every joint of a chain, in chain order (joint 1 nearest the root).
struct FrictionModel {
  Kind kind = Kind::lugre;
  Options options;
  std::vector<Parameters<double>> joints;
  // Empty, or one per joint: the steady-state parameters' covariance when known.
  std::vector<std::optional<SteadyCovariance>> covariance;

  // Checks options and every joint's parameters (see IsValid(Kind, ...)); the reason names
  // the joint (1-based).
  bool IsValid(std::string* why) const;
};

// Reads a profile's "friction" section. Throws momentum::Error ("friction: joint 2: missing
// 'tau_s'", ...; the caller adds the file name) when the section is not an object, the model
// name is unknown, "joints" is missing or not an array of objects, a parameter the model needs
// is missing or not a finite number, or the result fails FrictionModel::IsValid. Keys it does
// not know (in the section or a joint) are listed in `warnings` (when non-null), not errors.
FrictionModel friction_from_json(const nlohmann::json& section,
                                 std::vector<std::string>* warnings = nullptr);

// The section for a model: "model", "update" (LuGre), the velocity options when non-zero, and
// per joint the parameters that the model uses (delta_c, delta_s only when non-zero) and the
// covariance when known.
nlohmann::json to_json(const FrictionModel& model);
// A joint's "covariance" entry.
nlohmann::json covariance_to_json(const SteadyCovariance& covariance);

// One joint's friction with its state (LuGre bristle deflection, velocity filter).
template <class T>
class JointFriction {
 public:
  JointFriction(Kind kind, const Parameters<T>& parameters, const Options& options = {})
      : kind_(kind), p_(parameters), options_(options) {}

  // Forgets the state; the next step() is a first sample again.
  void reset() { started_ = false; }

  // Friction torque (Nm) for the sample with measured velocity w (rad/s), dt seconds (> 0)
  // after the previous sample. On the first sample after construction or reset() dt is
  // ignored and LuGre starts in its steady state for that velocity (z = g(w) sign(w) / s0), so
  // a log that starts in motion has no start-up transient.
  T step(const T& w_measured, double dt) {
    using std::abs;
    if (!started_) {
      w_ = w_measured;
    } else if (options_.velocity_cutoff_hz > 0) {
      const double alpha = -std::expm1(-2.0 * std::numbers::pi * options_.velocity_cutoff_hz * dt);
      w_ = w_ + alpha * (w_measured - w_);
    } else {
      w_ = w_measured;
    }
    const T w = abs(w_) < T(options_.velocity_deadband) ? T(0) : w_;
    return visit(kind_, [&](auto model) {
      using Model = decltype(model);
      if (!started_) {
        started_ = true;
        return Model::start(p_, w, z_);
      }
      return Model::step(p_, w, dt, options_.update, z_);
    });
  }

  // The model's state after the last step (LuGre's bristle deflection, rad; 0 for static models).
  const T& z() const { return z_; }
  // The conditioned velocity of the last step (before the deadband), rad/s.
  const T& filtered_velocity() const { return w_; }
  Kind kind() const { return kind_; }
  const Parameters<T>& parameters() const { return p_; }

 private:
  Kind kind_;
  Parameters<T> p_;
  Options options_;
  bool started_ = false;
  T z_ = T(0);
  T w_ = T(0);
};

// One-sigma uncertainty of the steady-state friction torque at constant velocity w (rad/s), Nm:
// the first-order propagation of `covariance` through |F(w)|, where F is the Stribeck curve
// plus viscous term (LuGre and Stribeck) or Coulomb plus viscous term. At w = 0 the limit from
// either side (the static level's uncertainty).
double steady_friction_sd(Kind kind, const Parameters<double>& p, const SteadyCovariance& covariance, double w);

// One evaluator per joint of `model`, in chain order.
std::vector<JointFriction<double>> make_joint_frictions(const FrictionModel& model);

}  // namespace momentum::friction
