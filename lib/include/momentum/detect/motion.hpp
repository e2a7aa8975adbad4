#pragma once
// The motion state of one joint, decided row by row from its velocity, and the baseline of its
// residual while it rests. Calibration and detection use this one rule, so a threshold is
// always compared with the statistic it was measured on.
//
// Three states, like libfranka's separate thresholds per phase:
// - moving: |dq| at or above the rest velocity;
// - slow: below it, but not yet for the rest time, and for the hangover time after it rises
//   above it again: reversals, sticking, stopping, breakaway.
//   Friction changes sign or is held at an unknown level there, so the residual strays most;
//   giving these rows their own threshold keeps them from inflating the moving one;
// - rest: below it for the rest time, with every joint of the arm below it. A joint at rest holds an unknown part of its static
//   friction (anything in [-tau_s, tau_s]); a friction model driven by velocity noise cannot
//   know which, so the compensated residual sits somewhere in a band several Nm wide. It stays
//   there, though, until the joint moves or is pushed, so at rest the statistic can be the
//   change of the residual since the joint settled, which a push moves and static friction
//   held does not.

#include <cmath>
#include <limits>

#include "momentum/detect/thresholds.hpp"

namespace momentum::detect {

enum class MotionState { moving, slow, rest };

class RestTracker {
 public:
  RestTracker() = default;
  explicit RestTracker(RestRule rule) : rule_(rule) {}

  // One row: time t (s), joint velocity dq (rad/s; NaN = unknown, counts as moving) and the
  // residual x (Nm; a NaN residual does not enter the baseline). `may_rest` false keeps a
  // joint that is not already at rest from entering rest (used while the joint is part of an
  // open event). Returns the state for this row.
  //
  // `arm_still` false (another joint of the arm is moving) keeps the joint out of rest: its
  // residual then changes with the other joints' motion (coupling, and the model's errors
  // along it), which the rest state assumes it does not.
  MotionState update(double t, double dq, double x, bool may_rest = true, bool arm_still = true) {
    if (!(std::fabs(dq) < rule_.velocity)) {
      reset();
      // Still slow for the hangover after the joint picked up speed: the residual lags the
      // friction's change of sign through the observer's filter.
      return t - last_slow_ < rule_.hangover ? MotionState::slow : MotionState::moving;
    }
    last_slow_ = t;
    if (!arm_still) {
      reset();
      return MotionState::slow;
    }
    if (at_rest_) return MotionState::rest;
    if (!may_rest) {
      reset();
      return MotionState::slow;
    }
    if (std::isnan(since_)) since_ = t;
    if (std::isfinite(x)) {
      sum_ += x;
      ++count_;
    }
    if (count_ > 0 && t - since_ >= rule_.time) {
      at_rest_ = true;
      baseline_ = sum_ / static_cast<double>(count_);
      return MotionState::rest;
    }
    return MotionState::slow;
  }

  // Mean residual over the slow rows before rest, Nm; meaningful while at rest.
  double baseline() const { return baseline_; }
  bool at_rest() const { return at_rest_; }
  // Forgets everything, the hangover included (a new stream).
  void restart() {
    reset();
    last_slow_ = -std::numeric_limits<double>::infinity();
  }
  void reset() {
    at_rest_ = false;
    since_ = std::numeric_limits<double>::quiet_NaN();
    sum_ = 0;
    count_ = 0;
  }

 private:
  RestRule rule_;
  bool at_rest_ = false;
  double since_ = std::numeric_limits<double>::quiet_NaN();
  double sum_ = 0;
  long long count_ = 0;
  double baseline_ = 0;
  double last_slow_ = -std::numeric_limits<double>::infinity();
};

// The baseline of a resting joint's residual when it follows slow drift: a first-order low-pass
// of time constant `drift_time` (s) started at the settled mean. A position-controlled joint at
// rest holds torque against stiction and, after a push is released, unloads it over seconds;
// a frozen baseline takes that drift for a push. Following it, the rest statistic |x - baseline|
// sees what changes faster than the drift time (a push rising within a few tenths of a second)
// and forgets a level the joint settled at. drift_time <= 0 or infinite: frozen.
class DriftingBaseline {
 public:
  void start(double t, double value) {
    t_ = t;
    value_ = value;
  }
  void update(double t, double x, double drift_time) {
    if (std::isfinite(x) && drift_time > 0 && std::isfinite(drift_time) && t > t_)
      value_ -= std::expm1(-(t - t_) / drift_time) * (x - value_);
    t_ = t;
  }
  double value() const { return value_; }

 private:
  double t_ = 0, value_ = 0;
};

// Peak response of |x - baseline| to a ramp of the residual from 0 to 1 over `rise` seconds, with
// the baseline following at `drift_time`: what share of a contact's torque the rest statistic
// sees. 1 for a frozen baseline.
double drift_gain(double drift_time, double rise);

}  // namespace momentum::detect
