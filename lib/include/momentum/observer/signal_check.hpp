// Rows whose signals disagree: the redundancy of q, dq and tau_m, tested before the residual
// is formed (momentum(7), "Rows whose signals disagree").
//
// Positions and velocities come from the same joint: between two rows a and b (dt = t_b - t_a)
// the position change must match the trapezoidal integral of the velocity,
//
//   e = q_b - q_a - dt (dq_a + dq_b) / 2,
//
// up to the sensors' own noise and quantisation. A contact changes the currents and, through
// the dynamics, both q and dq together; it does not make them disagree. A velocity that jumps
// for one row while the positions do not move, or an encoder word that reads 1e6 rad, does.
//
// The tolerance comes from the data, per joint: a running robust scale of e over the last
// kWindow accepted intervals (1.4826 times the median of |e|, the standard deviation for normal
// noise), floored by the quantisation noise of the signals themselves (their steps: the smallest
// nonzero second differences of position and velocity seen; for the position at least its move
// at rest that the velocity does not explain, seen twice: Joints::rest_step), times `sigmas`; it
// grows in proportion with the interval when rows in between are left out. Besides, a value
// beyond the URDF's limits by more than `limit_factor` (positions about the middle of their
// range, velocities and efforts about 0), or a position change faster than limit_factor times
// the velocity limit, cannot be physical.
//
// At high sample rates the positions cannot see a velocity that is wrong for one row (a spike
// of 0.09 rad/s moves the trapezoid by 4.5e-5 rad at 1 kHz, half an encoder count of 2^16 per
// turn), yet the momentum jumps by M times it. The velocity has a redundancy of its own: an arm
// is driven by forces that cannot reverse within one sample, so its velocity is smooth on the
// scale of a row, and its second difference d2 = dq_c - 2 dq_b + dq_a is noise. A row whose
// velocity leaves its trend by more than `sigmas` robust standard deviations of d2 (learnt like
// e, floored by the velocity's quantisation) and that no motor torque shows is a jump: the
// torque its departure s implies, M_jj s / dt, must exceed the motor torque's own departure
// from its trend plus that torque's tolerance (learnt the same way). A jump is a fault when the
// next row's velocity is back on the trend of the rows before it, and real (an impact, which
// moves the velocity without the motor and leaves it moved) when it is not. A real robot's
// stick-slip at rest reverses its velocity within a row too, but with the current that drives
// it, and a departure of 1e-5 rad/s implies no torque worth a judgement.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "momentum/core/statistics.hpp"
#include "momentum/model/dynamics.hpp"
#include "momentum/model/model.hpp"

namespace momentum::observer {

struct SignalCheckOptions {
  // Off: every row is taken at its word (mo-observe --no-signal-check).
  bool enabled = true;
  // Tolerance of the position-velocity disagreement and of a velocity's (and motor torque's)
  // departure from its trend, in robust standard deviations of their own running
  // distributions (> 0). Real velocity signals are filtered and lag the positions a
  // little, so the distribution has heavier tails than a normal one: 10 leaves the ordinary
  // tail alone (on the UR10e development logs no row is excluded) and still sees a velocity
  // that jumps by a few hundredths of a rad/s for one row.
  double sigmas = 10.0;
  // Physical bounds: a velocity or effort beyond limit_factor times the URDF's limit, or a
  // position beyond limit_factor times the half range about the middle of the limits (>= 1).
  // Drives deliver short peaks above the rated effort the URDF states; twice it is beyond them.
  double limit_factor = 2.0;

  // False (with the reason in `why`, when non-null) for sigmas <= 0 or limit_factor < 1.
  bool IsValid(std::string* why) const;
};

// Per-joint tolerances learnt from the stream, and the tests. Constant memory.
class SignalCheck {
 public:
  // Accepted intervals in the running window of |e|.
  static constexpr int kWindow = 128;
  // Intervals needed before the disagreement test applies (the limits apply from the start).
  static constexpr int kWarmUp = 16;
  // The fewest pushes since a running scale was last computed for which a row beyond its lower
  // bound has it recomputed before judgement (see learn()).
  static constexpr int kRefreshJudged = 8;

  // `model` must outlive the check (its joint limits are read).
  SignalCheck(const model::Model& model, const SignalCheckOptions& options);

  const SignalCheckOptions& options() const { return options_; }
  bool ready() const { return intervals_ >= kWarmUp; }

  // The first joint (0-based) with a value beyond its physical limits, or -1; what is wrong
  // (e.g. "joint 2's position 1e+06 rad is beyond its limits -6.28..6.28 rad") in `why`.
  // q, dq, tau: nq values each (rad, rad/s, Nm; m, m/s, N for a prismatic joint).
  int beyond_limits(const double* q, const double* dq, const double* tau, std::string* why) const;

  // Whether row b (t_b > t_a) plainly passes every test against row a, the last good row, in
  // one pass over the joints and without recomputing a scale: within its limits
  // (beyond_limits() < 0), agreeing with row a (disagree() false) and its velocity on its trend
  // (velocity_jumps() false), each on the lower bounds of the running scales. True only where
  // those three say so; false says nothing (a row near a tolerance, or a row to judge in full).
  bool plainly_passes(double t_a, const double* q_a, const double* dq_a, double t_b, const double* q_b,
                      const double* dq_b, const double* tau_b, double typical_dt) const;

  // Whether the rows a and b (t_b > t_a) disagree: some joint's |e| beyond its tolerance for
  // the interval (`typical_dt`: the stream's median step, s, > 0), or a position change faster
  // than the velocity limit allows. Before ready(), only the velocity limit is tested. When
  // they disagree and `why` is non-null, it says on which joint and by how much.
  // Not const: a joint beyond its scale as last computed has it brought up to date first.
  bool disagree(double t_a, const double* q_a, const double* dq_a, double t_b, const double* q_b,
                const double* dq_b, double typical_dt, std::string* why);

  // Learns from an accepted interval a -> b: its |e| per joint enter the running scale, and,
  // when it continues the last interval learnt, the second differences of position and
  // velocity the quantisation estimate, and those of velocity and motor torque their scales.
  void learn(double t_a, const double* q_a, const double* dq_a, const double* tau_a, double t_b,
             const double* q_b, const double* dq_b, const double* tau_b);

  // Tolerance of joint j (0-based) over an interval of `interval` s, rad (m), on the window as it
  // is now (its scale brought up to date): +inf before ready().
  double tolerance(int j, double interval, double typical_dt);

  // Whether row b's velocity leaves the trend of the last interval learnt (which must end at
  // t_a, with b about one step later: within 2.5 times that interval and at least 0.4 times it) by more than its
  // tolerance on some joint, by a torque that the motor torque does not show (see above);
  // false when that is not so or cannot be judged (not ready, a gap, a row left out in
  // between). When it jumps and `why` is non-null, it says on which joint and by how much.
  // q, dq, tau: nq values each (rad, rad/s, Nm).
  bool velocity_jumps(double t_a, const double* dq_a, const double* tau_a, double t_b, const double* q_b,
                      const double* dq_b, const double* tau_b, std::string* why);

  // Whether row c's velocity is back on the trend of the last interval learnt (ending at t_a)
  // after row b jumped off it: every joint within the jump tolerance, grown for the longer
  // extrapolation, and nearer the trend than half of b's departure (an impact decelerates the
  // arm over several rows, each further off the trend than the last). Back on the trend, the
  // row in between was a fault of the velocity signal.
  bool velocity_on_trend(double t_a, const double* dq_a, double t_b, const double* dq_b, double t_c,
                         const double* dq_c) const;

  // Whether row b, which disagrees with row a, is explained by a velocity that changed
  // monotonically from a through b to c within the intervals (t_a < t_b < t_c): on every joint
  // whose rows disagree, the velocity at b lies between those at a and c, and each interval's
  // |e| is within half the interval times its velocity change plus the tolerance. A velocity
  // that changes monotonically within an interval moves the position by between dt v_a and
  // dt v_b, so the trapezoid is off by up to dt |v_b - v_a| / 2: at 125 Hz an arm that starts
  // a motion within a sample is off by ten tolerances. A velocity spike (b off the line between a and c) and a position glitch (a
  // large |e| with a small velocity change) are not explained. Before ready(), false.
  bool velocity_change_explains(double t_a, const double* q_a, const double* dq_a, double t_b, const double* q_b,
                                const double* dq_b, double t_c, const double* q_c, const double* dq_c,
                                double typical_dt);

  // Tolerance of the velocity's departure from its trend for joint j (0-based) one step on,
  // rad/s (m/s): +inf before ready().
  double velocity_tolerance(int j) const;

 private:
  // Per-joint state, an array per quantity (element j: joint j), so that the tests of most rows
  // and learn() take two joints at a time.
  struct Joints {
    explicit Joints(std::size_t n)
        : lower(n), upper(n), velocity(n), effort(n), q_quantum(n), dq_quantum(n), q_curvature_quantum(n),
          rest_step(n), rest_candidate(n), last_q_step(n), last_dq_step(n), last_tau_step(n) {}
    std::size_t size() const { return lower.size(); }
    // Bounds with limit_factor: the position's range, |velocity| (also what a position may move
    // in a second), |effort|.
    std::vector<double> lower, upper, velocity, effort;
    // Quantisation steps: the smallest nonzero second difference seen (of consecutive
    // intervals), which is a multiple of the step for a quantised signal and as small as the
    // motion's own curvature for a fine one; 0 none yet. rad, rad/s. For the position, the
    // larger of that (q_curvature_quantum) and rest_step.
    std::vector<double> q_quantum, dq_quantum, q_curvature_quantum;
    // A position quantised coarser than it is written (encoder counts of 1.2e-5 rad written
    // with 7 decimals) has second differences of a count plus or minus the writing's rounding,
    // and the rounding alone (1e-7) is the smallest: no measure of the count. Its moves that
    // the velocity does not explain (less than half of them: a count at rest) are a count
    // each. rest_step: the smallest such move seen twice (within a tenth), 0 none yet;
    // rest_candidate: the smallest seen once since, awaiting its second. A glitch's size does
    // not come twice.
    std::vector<double> rest_step, rest_candidate;
    std::vector<double> last_q_step, last_dq_step, last_tau_step;  // of the last interval learnt; Nm for tau
  };
  // tolerance() on the scale as last computed.
  double tolerance_as_computed(int j, double interval, double typical_dt) const;
  // Tolerance of the motor torque's departure from its trend one step on, Nm.
  double torque_tolerance(int j) const;
  // Notes a move of joint j's position that its velocity does not explain (see
  // Joints::rest_step).
  void note_unexplained_move(std::size_t j, double moved);
  // Recomputes window k of `scales` when kRefreshJudged values or more came in since it was
  // last: whether it did.
  static bool refresh(core::RunningMedianBank<kWindow>& scales, std::size_t j);

  const model::Model& model_;
  model::Data data_;           // scratch of the mass matrix
  Eigen::MatrixXd mass_;       // M(q) of the last row judged
  SignalCheckOptions options_;
  Joints joints_;
  // The running scales, a window per joint: |e| of the accepted intervals, and |d2| of the
  // velocity and of the motor torque (judged on its median only) over pairs of consecutive
  // intervals learnt.
  core::RunningMedianBank<kWindow> abs_error_;
  core::RunningMedianBank<kWindow> abs_velocity_curvature_;
  core::RunningMedianBank<kWindow, false> abs_torque_curvature_;
  std::vector<double> learnt_;  // learn()'s values for the three: nq each
  std::uint64_t intervals_ = 0;
  double last_t_ = 0;  // end of the last interval learnt: the next one continues it when equal
  double last_dt_ = 0;  // its length, s
  std::uint64_t curvatures_ = 0;  // pairs of consecutive intervals learnt
};

}  // namespace momentum::observer
