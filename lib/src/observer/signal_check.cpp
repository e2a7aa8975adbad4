#include "momentum/observer/signal_check.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "momentum/core/number.hpp"
#include "momentum/stream/error.hpp"

namespace momentum::observer {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// 1.4826 median(|x|) is the standard deviation of zero-mean normal noise.
constexpr double kMadToSigma = 1.4826;

bool fail(std::string* why, std::string message) {
  if (why) *why = std::move(message);
  return false;
}

std::string joint_name(int j) { return "joint " + std::to_string(j + 1); }

}  // namespace

bool SignalCheckOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(sigmas) && sigmas > 0)) return fail(why, "signal check: sigmas must be a finite number > 0");
  if (!(std::isfinite(limit_factor) && limit_factor >= 1))
    return fail(why, "signal check: limit_factor must be a finite number >= 1");
  return true;
}

SignalCheck::SignalCheck(const model::Model& model, const SignalCheckOptions& options)
    : options_(options), joints_(static_cast<std::size_t>(model.nq)) {
  std::string why;
  if (!options.IsValid(&why)) throw Error(why);
  const double f = options.limit_factor;
  for (int j = 0; j < model.nq; ++j) {
    const model::JointLimits& limits = model.joints[static_cast<std::size_t>(j)].limits;
    Joint& J = joints_[static_cast<std::size_t>(j)];
    if (std::isfinite(limits.lower) && std::isfinite(limits.upper) && limits.upper > limits.lower) {
      const double middle = 0.5 * (limits.lower + limits.upper), half = 0.5 * (limits.upper - limits.lower);
      J.lower = middle - f * half;
      J.upper = middle + f * half;
    } else {
      J.lower = -kInf;
      J.upper = kInf;
    }
    // A limit of 0 or none is no limit (the URDF parser turns both into +inf already).
    J.velocity = limits.velocity > 0 ? f * limits.velocity : kInf;
    J.effort = limits.effort > 0 ? f * limits.effort : kInf;
    J.velocity_limit = J.velocity;
  }
}

int SignalCheck::beyond_limits(const double* q, const double* dq, const double* tau, std::string* why) const {
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    const Joint& J = joints_[j];
    const int index = static_cast<int>(j);
    if (!(q[j] >= J.lower && q[j] <= J.upper)) {
      if (why) *why = joint_name(index) + "'s position " + core::short_number(q[j]) + " is beyond " +
                      core::short_number(options_.limit_factor) + " times its range";
      return index;
    }
    if (!(std::fabs(dq[j]) <= J.velocity)) {
      if (why) *why = joint_name(index) + "'s velocity " + core::short_number(dq[j]) + " is beyond " +
                      core::short_number(J.velocity) + " (" + core::short_number(options_.limit_factor) +
                      " times its limit)";
      return index;
    }
    if (!(std::fabs(tau[j]) <= J.effort)) {
      if (why) *why = joint_name(index) + "'s torque " + core::short_number(tau[j]) + " is beyond " +
                      core::short_number(J.effort) + " (" + core::short_number(options_.limit_factor) +
                      " times its effort limit)";
      return index;
    }
  }
  return -1;
}

double SignalCheck::tolerance(int j, double interval, double typical_dt) const {
  if (!ready()) return kInf;
  const Joint& J = joints_[static_cast<std::size_t>(j)];
  // Quantisation alone: the difference of two positions rounded independently is off by an
  // error of variance quantum^2 / 6; the mean of two rounded velocities, times dt, by
  // dt^2 quantum^2 / 24.
  const double floor = std::sqrt(J.q_quantum * J.q_quantum / 6 +
                                 interval * interval * J.dq_quantum * J.dq_quantum / 24);
  // Over a longer interval (rows left out in between), velocity noise and lag add up.
  const double stretch = typical_dt > 0 ? std::max(1.0, interval / typical_dt) : 1.0;
  return options_.sigmas * std::max(kMadToSigma * J.abs_error.value() * stretch, floor);
}

bool SignalCheck::disagree(double t_a, const double* q_a, const double* dq_a, double t_b, const double* q_b,
                           const double* dq_b, double typical_dt, std::string* why) const {
  const double dt = t_b - t_a;
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    const Joint& J = joints_[j];
    const int index = static_cast<int>(j);
    const double moved = q_b[j] - q_a[j];
    // Faster than the drive can move, whatever the velocity signal says.
    if (!(std::fabs(moved) <= J.velocity_limit * dt + J.q_quantum)) {
      if (why) *why = joint_name(index) + "'s position moved " + core::short_number(moved) + " in " +
                      core::short_number(dt) + " s, beyond " + core::short_number(options_.limit_factor) +
                      " times its velocity limit";
      return true;
    }
    if (!ready()) continue;
    const double e = moved - 0.5 * dt * (dq_a[j] + dq_b[j]);
    const double tol = tolerance(index, dt, typical_dt);
    if (!(std::fabs(e) <= tol)) {
      if (why) *why = joint_name(index) + "'s position moved " + core::short_number(moved) + ", its velocity says " +
                      core::short_number(0.5 * dt * (dq_a[j] + dq_b[j])) + " (tolerance " +
                      core::short_number(tol) + ")";
      return true;
    }
  }
  return false;
}

void SignalCheck::learn(double t_a, const double* q_a, const double* dq_a, double t_b, const double* q_b,
                        const double* dq_b) {
  const double dt = t_b - t_a;
  if (!(dt > 0)) return;
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    Joint& J = joints_[j];
    const double moved = q_b[j] - q_a[j];
    J.abs_error.push(std::fabs(moved - 0.5 * dt * (dq_a[j] + dq_b[j])));
    const double velocity_step = dq_b[j] - dq_a[j];
    if (intervals_ > 0 && t_a == last_t_) {
      const double q_curvature = std::fabs(moved - J.last_q_step);
      const double dq_curvature = std::fabs(velocity_step - J.last_dq_step);
      if (q_curvature > 0 && (J.q_quantum == 0 || q_curvature < J.q_quantum)) J.q_quantum = q_curvature;
      if (dq_curvature > 0 && (J.dq_quantum == 0 || dq_curvature < J.dq_quantum)) J.dq_quantum = dq_curvature;
    }
    J.last_q_step = moved;
    J.last_dq_step = velocity_step;
  }
  last_t_ = t_b;
  ++intervals_;
  // The median of the window moves slowly: recomputing it every 8 intervals (and through the
  // warm-up) keeps the hot path cheap.
  if (intervals_ <= kWarmUp || ++since_update_ >= 8) {
    since_update_ = 0;
    for (Joint& J : joints_) J.abs_error.update();
  }
}

}  // namespace momentum::observer
