#include "momentum/observer/signal_check.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "momentum/core/error.hpp"
#include "momentum/core/lanes.hpp"
#include "momentum/core/number.hpp"

namespace momentum::observer {
namespace {

namespace lanes = core::lanes;

constexpr double kInf = std::numeric_limits<double>::infinity();
// 1.4826 median(|x|) is the standard deviation of zero-mean normal noise.
constexpr double kMadToSigma = 1.4826;
constexpr double kInvSqrt6 = 0.40824829046386301637;
constexpr double kSqrtHalf = 0.70710678118654752440;
// A second difference of three values each read to within half an ulp is off by at most two
// ulps of the largest; eight ulps of the sum of two of them leave a margin.
constexpr double kEpsilon = std::numeric_limits<double>::epsilon();
constexpr double kRoundingUlps = 8;

std::string joint_name(int j) { return "joint " + std::to_string(j + 1); }

// Takes |second difference| `curvature` of a signal whose last two values are a and b as its
// quantisation step when it is the smallest seen (0: none yet). One within the rounding of the
// values is 0: a signal logged in decimal steps is read into binary fractions, and its exact
// second differences come out as residues of a few ulps (4e-19 for velocities in steps of
// 1e-4), which would set the quantisation floor to nothing. For one joint (double) or two
// (Pair) at `quantum`; whether it lowered one.
template <class V>
inline bool lower_quantum(double* quantum, V curvature, V a, V b) {
  const V was = lanes::load<V>(quantum);
  const auto take = ((was == 0.0) | (curvature < was)) &
                    (curvature > kRoundingUlps * kEpsilon * (lanes::abs(a) + lanes::abs(b)));
  // Rarely: a quantum once found is seldom lowered.
  if (!lanes::any(take)) return false;
  lanes::store(quantum, lanes::select(take, curvature, was));
  return true;
}

// Three velocities rounded independently to steps of `quantum`: their second difference is off
// by an error of variance 6 quantum^2 / 12.
template <class V>
inline V velocity_quantisation_noise(V quantum) {
  return quantum * kSqrtHalf;
}

// The tolerance of a velocity's departure from its trend one step on, from the running scale
// of its |d2| (its median, or the median's lower bound) and the velocity's quantum.
template <class V>
inline V velocity_tolerance_for(double sigmas, V scale, V dq_quantum) {
  return sigmas * lanes::max(kMadToSigma * scale, velocity_quantisation_noise(dq_quantum));
}

// A joint's values within their physical bounds (beyond_limits()), and its position's move
// within the velocity limit (disagree()): the one definition that plainly_passes() shares, for
// one joint (double: a bool) or two (Pair: a mask).
template <class V>
inline auto position_within(V q, V lower, V upper) {
  return (q >= lower) & (q <= upper);
}
template <class V>
inline auto magnitude_within(V x, V bound) {
  return lanes::abs(x) <= bound;
}
template <class V>
inline auto move_within_velocity_limit(V moved, V velocity, double dt, V q_quantum) {
  return lanes::abs(moved) <= velocity * dt + q_quantum;
}

}  // namespace

bool SignalCheckOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(sigmas) && sigmas > 0)) return invalid(why, "signal check: sigmas must be a finite number > 0");
  if (!(std::isfinite(limit_factor) && limit_factor >= 1))
    return invalid(why, "signal check: limit_factor must be a finite number >= 1");
  return true;
}

SignalCheck::SignalCheck(const model::Model& model, const SignalCheckOptions& options)
    : model_(model),
      data_(model),
      mass_(model.nq, model.nq),
      options_(options),
      joints_(static_cast<std::size_t>(model.nq)),
      abs_error_(model.nq),
      abs_velocity_curvature_(model.nq),
      abs_torque_curvature_(model.nq),
      learnt_(3 * static_cast<std::size_t>(model.nq)) {
  std::string why;
  if (!options.IsValid(&why)) throw Error(why);
  const double f = options.limit_factor;
  for (int j = 0; j < model.nq; ++j) {
    const std::size_t k = static_cast<std::size_t>(j);
    const model::JointLimits& limits = model.joints[k].limits;
    if (std::isfinite(limits.lower) && std::isfinite(limits.upper) && limits.upper > limits.lower) {
      const double middle = 0.5 * (limits.lower + limits.upper), half = 0.5 * (limits.upper - limits.lower);
      joints_.lower[k] = middle - f * half;
      joints_.upper[k] = middle + f * half;
    } else {
      joints_.lower[k] = -kInf;
      joints_.upper[k] = kInf;
    }
    // A limit of 0 or none is no limit (the URDF parser turns both into +inf already).
    joints_.velocity[k] = limits.velocity > 0 ? f * limits.velocity : kInf;
    joints_.effort[k] = limits.effort > 0 ? f * limits.effort : kInf;
  }
}

int SignalCheck::beyond_limits(const double* q, const double* dq, const double* tau, std::string* why) const {
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    const int index = static_cast<int>(j);
    if (!position_within(q[j], joints_.lower[j], joints_.upper[j])) {
      if (why) *why = joint_name(index) + "'s position " + core::short_number(q[j]) + " is beyond " +
                      core::short_number(options_.limit_factor) + " times its range";
      return index;
    }
    if (!magnitude_within(dq[j], joints_.velocity[j])) {
      if (why) *why = joint_name(index) + "'s velocity " + core::short_number(dq[j]) + " is beyond " +
                      core::short_number(joints_.velocity[j]) + " (" + core::short_number(options_.limit_factor) +
                      " times its limit)";
      return index;
    }
    if (!magnitude_within(tau[j], joints_.effort[j])) {
      if (why) *why = joint_name(index) + "'s torque " + core::short_number(tau[j]) + " is beyond " +
                      core::short_number(joints_.effort[j]) + " (" + core::short_number(options_.limit_factor) +
                      " times its effort limit)";
      return index;
    }
  }
  return -1;
}

double SignalCheck::tolerance(int j, double interval, double typical_dt) {
  if (abs_error_.pushes_since_update(j) > 0) abs_error_.update(j);
  return tolerance_as_computed(j, interval, typical_dt);
}

double SignalCheck::tolerance_as_computed(int j, double interval, double typical_dt) const {
  if (!ready()) return kInf;
  const std::size_t k = static_cast<std::size_t>(j);
  const double q_quantum = joints_.q_quantum[k], dq_quantum = joints_.dq_quantum[k];
  // Quantisation alone: the difference of two positions rounded independently is off by an
  // error of variance quantum^2 / 6; the mean of two rounded velocities, times dt, by
  // dt^2 quantum^2 / 24.
  const double floor = std::sqrt(q_quantum * q_quantum / 6 + interval * interval * dq_quantum * dq_quantum / 24);
  // Over a longer interval (rows left out in between), velocity noise and lag add up.
  const double stretch = typical_dt > 0 ? std::max(1.0, interval / typical_dt) : 1.0;
  return options_.sigmas * std::max(kMadToSigma * abs_error_.value(j) * stretch, floor);
}

double SignalCheck::velocity_tolerance(int j) const {
  if (curvatures_ < static_cast<std::uint64_t>(kWarmUp)) return kInf;
  return velocity_tolerance_for(options_.sigmas, abs_velocity_curvature_.value(j),
                                joints_.dq_quantum[static_cast<std::size_t>(j)]);
}

namespace {

// Whether two consecutive intervals are about one step each: a controller's clock jitters
// (steps of 0.7 to 1.2 ms at 1 kHz), a lost sample doubles a step, and the trend is not
// extrapolated across more.
bool steps_apart(double dt, double last_dt) { return last_dt > 0 && dt > 0 && dt <= 2.5 * last_dt && last_dt <= 2.5 * dt; }

// A trend extended over m = (t_b - t_a) / last_dt steps: the departure of a signal x_b from
// it is x_b - x_a - m (x_a - x_prev), and its noise is larger than that of one step's second
// difference by `noise_ratio` (variance (1 + (m + 1)^2 + m^2) sigma^2 against 6 sigma^2).
struct Extension {
  double m;
  double noise_ratio;
  Extension(double last_dt, double t_a, double t_b)
      : m((t_b - t_a) / last_dt), noise_ratio(std::sqrt((1 + (m + 1) * (m + 1) + m * m) / 6)) {}
  template <class V>
  V departure(V last_step, V x_a, V x_b) const {
    return x_b - x_a - m * last_step;
  }
};

}  // namespace

double SignalCheck::torque_tolerance(int j) const {
  if (curvatures_ < static_cast<std::uint64_t>(kWarmUp)) return kInf;
  return options_.sigmas * kMadToSigma * abs_torque_curvature_.value(j);
}

bool SignalCheck::velocity_jumps(double t_a, const double* dq_a, const double* tau_a, double t_b,
                                 const double* q_b, const double* dq_b, const double* tau_b, std::string* why) {
  const double dt = t_b - t_a;
  if (!(t_a == last_t_ && steps_apart(dt, last_dt_))) return false;
  const Extension trend(last_dt_, t_a, t_b);
  bool have_mass = false;
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    const int index = static_cast<int>(j);
    const double d = trend.departure(joints_.last_dq_step[j], dq_a[j], dq_b[j]);
    // Within the tolerance on the scale's lower bound (see learn()), so within it on the scale.
    if (std::fabs(d) <= velocity_tolerance_for(options_.sigmas, abs_velocity_curvature_.lower_bound(index),
                                               joints_.dq_quantum[j]) *
                            trend.noise_ratio)
      continue;
    double tol = velocity_tolerance(index) * trend.noise_ratio;
    if (!std::isfinite(tol)) continue;
    // Beyond the scale as last computed: judged on it brought up to date.
    if (std::fabs(d) > tol && refresh(abs_velocity_curvature_, j)) tol = velocity_tolerance(index) * trend.noise_ratio;
    if (std::fabs(d) <= tol) continue;
    // The velocity left its trend: by a torque the motor shows, or one too small to matter?
    if (!have_mass) {
      mass_matrix(model_, data_, Eigen::Map<const Eigen::VectorXd>(q_b, model_.nq), mass_);
      have_mass = true;
    }
    const double implied = mass_(index, index) * std::fabs(d) / dt;
    // The motor torque's scale is needed here only: computed on demand, not on a schedule.
    if (abs_torque_curvature_.pushes_since_update(index) > 0) abs_torque_curvature_.update(index);
    const double motor = trend.departure(joints_.last_tau_step[j], tau_a[j], tau_b[j]);
    const double motor_tol = torque_tolerance(index) * trend.noise_ratio;
    if (!(implied > std::fabs(motor) + motor_tol)) continue;
    if (why) *why = joint_name(index) + "'s velocity " + core::short_number(dq_b[j]) + " left its trend by " +
                    core::short_number(d) + " in one row (tolerance " + core::short_number(tol) +
                    "), a torque of " + core::short_number(implied) + " Nm that the motor does not show";
    return true;
  }
  return false;
}

bool SignalCheck::refresh(core::RunningMedianBank<kWindow>& scales, std::size_t j) {
  const int k = static_cast<int>(j);
  // At rest on quantised signals a scale may be 0 and many rows beyond it (then judged on the
  // quantisation floor): recomputed at most every kRefreshJudged pushes, the cost stays bounded.
  if (scales.pushes_since_update(k) < kRefreshJudged) return false;
  scales.update(k);
  return true;
}

bool SignalCheck::velocity_on_trend(double t_a, const double* dq_a, double t_b, const double* dq_b, double t_c,
                                    const double* dq_c) const {
  if (!(t_a == last_t_ && last_dt_ > 0 && t_b > t_a && t_c > t_b)) return false;
  const Extension to_b(last_dt_, t_a, t_b), to_c(last_dt_, t_a, t_c);
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    const double step = joints_.last_dq_step[j];
    const double tol = velocity_tolerance(static_cast<int>(j));
    const double c = to_c.departure(step, dq_a[j], dq_c[j]);
    if (!(std::fabs(c) <= tol * to_c.noise_ratio)) return false;
    const double b = to_b.departure(step, dq_a[j], dq_b[j]);
    if (std::fabs(b) > tol * to_b.noise_ratio && !(std::fabs(c) < 0.5 * std::fabs(b))) return false;
  }
  return true;
}

MOMENTUM_WITH_AVX2_CLONE
bool SignalCheck::plainly_passes(double t_a, const double* q_a, const double* dq_a, double t_b, const double* q_b,
                                 const double* dq_b, const double* tau_b, double typical_dt) const {
  const double dt = t_b - t_a;
  const double stretch = typical_dt > 0 ? std::max(1.0, dt / typical_dt) : 1.0;
  const double sigmas = options_.sigmas;
  const double position_scale = sigmas * kMadToSigma * stretch;
  const bool judged = ready();
  // The velocity's trend, where velocity_jumps() would judge it: its scales once warmed up.
  const bool trend = t_a == last_t_ && steps_apart(dt, last_dt_) && curvatures_ >= static_cast<std::uint64_t>(kWarmUp);
  const Extension extension(trend ? last_dt_ : dt, t_a, t_b);
  const Joints& J = joints_;
  const double* error_bound = abs_error_.lower_bounds();
  const double* velocity_bound = abs_velocity_curvature_.lower_bounds();
  // Joints j (and j + 1 for a Pair): every test in every lane, without a branch.
  auto passes = [&]<class V>(std::size_t j) {
    auto at = [j](const double* values) { return lanes::load<V>(values + j); };
    const V q = at(q_b), dq = at(dq_b), q_quantum = at(J.q_quantum.data()), velocity = at(J.velocity.data());
    // As beyond_limits().
    lanes::Mask<V> ok = position_within(q, at(J.lower.data()), at(J.upper.data())) &
                        magnitude_within(dq, velocity) & magnitude_within(at(tau_b), at(J.effort.data()));
    // As disagree(), on the scale's lower bound, and the quantisation floor without its velocity
    // term (at rest, where the scale is 0).
    const V moved = q - at(q_a), dq_a_j = at(dq_a);
    ok = ok & move_within_velocity_limit(moved, velocity, dt, q_quantum);
    if (judged)
      ok = ok & (lanes::abs(moved - 0.5 * dt * (dq_a_j + dq)) <=
                 lanes::max(position_scale * at(error_bound), sigmas * q_quantum * kInvSqrt6));
    // As velocity_jumps(), on the scale's lower bound.
    if (trend) {
      const V d = extension.departure(at(J.last_dq_step.data()), dq_a_j, dq);
      ok = ok & (lanes::abs(d) <=
                 velocity_tolerance_for(sigmas, at(velocity_bound), at(J.dq_quantum.data())) * extension.noise_ratio);
    }
    return lanes::all(ok);
  };
  return lanes::all_joints(J.size(), passes);
}

bool SignalCheck::disagree(double t_a, const double* q_a, const double* dq_a, double t_b, const double* q_b,
                           const double* dq_b, double typical_dt, std::string* why) {
  const double dt = t_b - t_a;
  // As tolerance_as_computed() stretches the scale for the interval.
  const double stretch = typical_dt > 0 ? std::max(1.0, dt / typical_dt) : 1.0;
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    const int index = static_cast<int>(j);
    const double moved = q_b[j] - q_a[j];
    // Faster than the drive can move, whatever the velocity signal says.
    if (!move_within_velocity_limit(moved, joints_.velocity[j], dt, joints_.q_quantum[j])) {
      if (why) *why = joint_name(index) + "'s position moved " + core::short_number(moved) + " in " +
                      core::short_number(dt) + " s, beyond " + core::short_number(options_.limit_factor) +
                      " times its velocity limit";
      return true;
    }
    if (!ready()) continue;
    const double e = moved - 0.5 * dt * (dq_a[j] + dq_b[j]);
    // Within the learnt scale's lower bound (see learn()), so within the tolerance (the
    // quantisation floor being the other candidate of its max): agreed, without the median
    // and the floor's square root.
    if (std::fabs(e) <= options_.sigmas * (kMadToSigma * abs_error_.lower_bound(index) * stretch)) continue;
    // Beyond it: judged on the scale brought up to date, and on the position's step when this
    // move is one the velocity does not explain and the second of its size.
    if (std::fabs(0.5 * dt * (dq_a[j] + dq_b[j])) < 0.5 * std::fabs(moved)) note_unexplained_move(j, std::fabs(moved));
    refresh(abs_error_, j);
    const double tol = tolerance_as_computed(index, dt, typical_dt);
    if (!(std::fabs(e) <= tol)) {
      if (why) *why = joint_name(index) + "'s position moved " + core::short_number(moved) + ", its velocity says " +
                      core::short_number(0.5 * dt * (dq_a[j] + dq_b[j])) + " (tolerance " +
                      core::short_number(tol) + ")";
      return true;
    }
  }
  return false;
}

bool SignalCheck::velocity_change_explains(double t_a, const double* q_a, const double* dq_a, double t_b,
                                           const double* q_b, const double* dq_b, double t_c, const double* q_c,
                                           const double* dq_c, double typical_dt) {
  if (!(ready() && t_a < t_b && t_b < t_c)) return false;
  const double dt1 = t_b - t_a, dt2 = t_c - t_b;
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    const int index = static_cast<int>(j);
    const double change1 = dq_b[j] - dq_a[j], change2 = dq_c[j] - dq_b[j];
    const double e1 = q_b[j] - q_a[j] - 0.5 * dt1 * (dq_a[j] + dq_b[j]);
    const double e2 = q_c[j] - q_b[j] - 0.5 * dt2 * (dq_b[j] + dq_c[j]);
    const double tol1 = tolerance(index, dt1, typical_dt), tol2 = tolerance(index, dt2, typical_dt);
    // A joint whose rows agree needs no explanation (its velocity's noise may wiggle).
    if (std::fabs(e1) <= tol1 && std::fabs(e2) <= tol2) continue;
    if (change1 * change2 < 0) return false;
    // These bounds also keep each move within max(|v|) dt plus the tolerance: no faster than
    // the velocities, which the limits already bound.
    if (!(std::fabs(e1) <= 0.5 * dt1 * std::fabs(change1) + tol1)) return false;
    if (!(std::fabs(e2) <= 0.5 * dt2 * std::fabs(change2) + tol2)) return false;
  }
  return true;
}

void SignalCheck::note_unexplained_move(std::size_t j, double moved) {
  double& candidate = joints_.rest_candidate[j];
  double& rest_step = joints_.rest_step[j];
  if (candidate > 0 && std::fabs(moved - candidate) <= 0.1 * candidate) {
    const double step = std::min(moved, candidate);
    rest_step = rest_step > 0 ? std::min(rest_step, step) : step;
    candidate = 0;
    joints_.q_quantum[j] = std::max(joints_.q_curvature_quantum[j], rest_step);
  } else if (candidate == 0 || moved < candidate) {
    candidate = moved;
  }
}

MOMENTUM_WITH_AVX2_CLONE
void SignalCheck::learn(double t_a, const double* q_a, const double* dq_a, const double* tau_a, double t_b,
                        const double* q_b, const double* dq_b, const double* tau_b) {
  const double dt = t_b - t_a;
  if (!(dt > 0)) return;
  const bool continues = intervals_ > 0 && t_a == last_t_;
  // Only intervals of about one step continue a trend (as velocity_jumps() asks).
  const bool on_trend = continues && steps_apart(dt, last_dt_);
  if (on_trend) ++curvatures_;
  // The medians of the windows are what the tolerances scale, and a median of 128 values costs
  // a few thousand instructions: the tests accept on each window's lower bound, which a push
  // keeps for two comparisons, so a median is recomputed only through the warm-up, when the
  // bound fails (the scale fell by a quarter: an arm coming to rest), or when a row lies
  // beyond the bound (refresh()). A row is accepted on a scale larger than the window's only
  // when that scale was computed fewer than kRefreshJudged intervals before it.
  const bool warming = intervals_ < static_cast<std::uint64_t>(kWarmUp);
  const bool trend_warming = curvatures_ <= static_cast<std::uint64_t>(kWarmUp);
  const double stretch = on_trend ? dt / last_dt_ : 0;  // the last steps extended over dt
  const std::size_t n = joints_.size();
  double* abs_error = learnt_.data();
  double* abs_velocity_curvature = learnt_.data() + n;
  double* abs_torque_curvature = learnt_.data() + 2 * n;
  // The arrays' addresses held in registers: the stores below may alias the vectors' members.
  double* q_quantum = joints_.q_quantum.data();
  double* dq_quantum = joints_.dq_quantum.data();
  double* q_curvature_quantum = joints_.q_curvature_quantum.data();
  const double* rest_step = joints_.rest_step.data();
  double* last_q_step = joints_.last_q_step.data();
  double* last_dq_step = joints_.last_dq_step.data();
  double* last_tau_step = joints_.last_tau_step.data();
  // Joints j (and j + 1 for a Pair).
  auto learn_joints = [&]<class V>(std::size_t j) {
    auto at = [j](const double* values) { return lanes::load<V>(values + j); };
    const V qa = at(q_a), qb = at(q_b), dqa = at(dq_a), dqb = at(dq_b);
    const V last_moved = at(last_q_step), last_velocity_step = at(last_dq_step);
    const V moved = qb - qa;
    lanes::store(abs_error + j, lanes::abs(moved - 0.5 * dt * (dqa + dqb)));
    const V velocity_step = dqb - dqa;
    if (continues) {
      // q_quantum is the larger of the two, whichever changed (note_unexplained_move()).
      if (lower_quantum(q_curvature_quantum + j, lanes::abs(moved - last_moved), qa, qb))
        lanes::store(q_quantum + j, lanes::max(at(q_curvature_quantum), at(rest_step)));
      lower_quantum(dq_quantum + j, lanes::abs(velocity_step - last_velocity_step), dqa, dqb);
    }
    // The velocity's departure from the trend, as velocity_jumps() measures it.
    const V torque_step = at(tau_b) - at(tau_a);
    lanes::store(abs_velocity_curvature + j, lanes::abs(velocity_step - last_velocity_step * stretch));
    lanes::store(abs_torque_curvature + j, lanes::abs(torque_step - at(last_tau_step) * stretch));
    lanes::store(last_q_step + j, moved);
    lanes::store(last_dq_step + j, velocity_step);
    lanes::store(last_tau_step + j, torque_step);
  };
  lanes::for_joints(n, learn_joints);
  abs_error_.push(abs_error);
  if (warming || !abs_error_.bounds_held_at_push()) {
    for (int k = 0; k < abs_error_.windows(); ++k)
      if (warming || !abs_error_.bound_holds(k)) abs_error_.update(k);
  }
  if (on_trend) {
    abs_velocity_curvature_.push(abs_velocity_curvature);
    abs_torque_curvature_.push(abs_torque_curvature);
    if (trend_warming || !abs_velocity_curvature_.bounds_held_at_push()) {
      for (int k = 0; k < abs_velocity_curvature_.windows(); ++k)
        if (trend_warming || !abs_velocity_curvature_.bound_holds(k)) abs_velocity_curvature_.update(k);
    }
  }
  last_t_ = t_b;
  last_dt_ = dt;
  ++intervals_;
}

}  // namespace momentum::observer
