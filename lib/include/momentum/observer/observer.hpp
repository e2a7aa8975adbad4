// The generalized-momentum observer (design notes, "Physics and conventions").
//
//   dp/dt = u - tau_d,   u = tau_m - beta(q, dq),   p = M(q) dq,   r = H(s) tau_d
//
// with H(s) the first- or second-order transfer function of filter.hpp. r has the sign of
// tau_d: friction on a joint moving forward gives a positive r. With a friction model, the
// model torque tau_f (from the measured velocity) is subtracted from u as a known torque, so
// the compensated residual mu = H(s) (tau_d - tau_f) = r - F(tau_f) sees the same filter as r.
//
// Two layers:
//  - ResidualObserver: model-free, per joint, fed p and u (and dq for friction) per sample;
//  - MomentumObserver: adds the rigid-body model (p and beta from q, dq) and the handling of
//    time: each sample's own dt, restart after a gap or a sample with NaN/inf, and rejection
//    of samples whose time does not increase.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "momentum/core/statistics.hpp"
#include "momentum/friction/friction.hpp"
#include "momentum/model/dynamics.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/momentum_batch.hpp"
#include "momentum/observer/filter.hpp"
#include "momentum/observer/signal_check.hpp"

namespace momentum::observer {

// The model side of the friction fit, in one call: the friction torque of `kind`/`parameters`
// driven by the velocities w[0..n) at times t[0..n), passed through the observer's filter H(s)
// with `gains` (the same discretization and the same per-joint evaluator as mo-observe uses),
// written to out[0..n). On a collision-free log, out matches the observer's r where the model
// is right, and r - out is exactly what mo-observe writes as mu. Start: out[0] = 0, the friction
// starting in its steady state, as at every observer (re)start; split logs at restarts (the
// `restart` column of mo-observe --restart-column) and call this per segment. Times must
// increase. T is double or ceres::Jet (parameters differentiated; t and w are data).
template <class T>
void filtered_friction(friction::Kind kind, const friction::Parameters<T>& parameters,
                       const friction::Options& options, const Gains& gains, const double* t,
                       const double* w, std::size_t n, T* out) {
  friction::JointFriction<T> model(kind, parameters, options);
  DisturbanceFilter<T> filter(gains);
  for (std::size_t k = 0; k < n; ++k) {
    const double dt = k ? t[k] - t[k - 1] : 0.0;
    out[k] = filter.step(model.step(T(w[k]), dt), dt);
  }
}

// Observer settings, from the profile's "observer" section and the command line.
struct ObserverOptions {
  int order = 1;  // 1 or 2
  // Gains in 1/s, one value for every joint or one per joint. Order 1 ignores k2 and k3.
  std::vector<double> k1{50.0};
  std::vector<double> k2{0.0};
  std::vector<double> k3{0.0};
  // Lost samples. A step longer than 1.5 running-median steps is a gap. A gap of at most
  // gap_factor median steps is bridged (the observer integrates across it, exactly for inputs
  // linear over the gap) when the motion allows: for every joint, the measured position change
  // across the gap agrees with the trapezoidal integral of the measured velocity,
  // |q1 - q0 - dt (dq0 + dq1) / 2| <= bridge_tolerance. Otherwise, and for any longer gap, the
  // observer restarts. gap_factor > 1 (<= 1.5: never bridge); bridge_tolerance >= 0, rad (m for
  // a prismatic joint).
  double gap_factor = 5.0;
  double bridge_tolerance = 1e-3;
  // Rows whose signals disagree (signal_check.hpp): left out and bridged by the stream
  // observer (observe_stream.hpp), within the same gap_factor.
  SignalCheckOptions signals;

  // False (with the reason in `why`, when non-null) for an order other than 1 or 2, empty
  // lists, invalid gains (see Gains::IsValid), gap_factor <= 1, a negative or non-finite
  // bridge_tolerance, or invalid signal check options.
  bool IsValid(std::string* why) const;

  // The gains of each of `joints` joints. Throws momentum::Error ("observer: k1 has 3 values
  // for 6 joints") when a list has neither one value nor one per joint.
  std::vector<Gains> joint_gains(int joints) const;
};

// Reads the profile's "observer" section:
//   {"order": 2, "k1": 50 or [..per joint..], "k2": 5, "k3": 0, "cutoff_hz": 8, "gap_factor": 5,
//    "bridge_tolerance": 0.001, "signal_check": true, "signal_sigmas": 10, "limit_factor": 2}
// "cutoff_hz" (number or list) sets k1 = 2 pi cutoff_hz; giving both k1 and cutoff_hz is an
// error. Missing keys keep ObserverOptions' defaults. Throws momentum::Error ("observer: ...";
// the caller adds the file name) for wrong types or invalid values. Unknown keys are listed in
// `warnings` (when non-null).
ObserverOptions observer_options_from_json(const nlohmann::json& section,
                                           std::vector<std::string>* warnings = nullptr);

// The model-free observer for n joints: per sample, the momentum p and u = tau_m - beta.
class ResidualObserver {
 public:
  // `gains`: one per joint, each valid. `friction`: nullptr, or a model with gains.size()
  // joints (otherwise std::invalid_argument).
  ResidualObserver(std::vector<Gains> gains, const friction::FrictionModel* friction);

  int joints() const { return static_cast<int>(gains_.size()); }
  bool has_friction() const { return !friction_.empty(); }

  // Forgets the state; the next sample starts the observer again (r = 0 there).
  void reset() { started_ = false; }

  // One sample, dt seconds (> 0) after the previous one (ignored on the first sample after
  // construction or reset()). p: momentum (Nms), u: tau_m - beta (Nm), dq: velocity (rad/s,
  // read only with friction); all of joints() values. Writes r (Nm) and, with friction,
  // tau_f and mu (Nm); tau_f and mu may be nullptr without friction.
  void step(double dt, const double* p, const double* u, const double* dq, double* r,
            double* tau_f, double* mu);

 private:
  // Per joint, an array of joints() values per quantity, joints side by side, so that the loop
  // over the joints takes two at a time (core/lanes.hpp).
  enum JointArray {
    kResidualS1, kResidualS2,        // the residual's filter state (FilterState)
    kCompensatedS1, kCompensatedS2,  // the friction-compensated one's
    kPreviousP, kPreviousU, kPreviousTauF,
    kJointArrays
  };
  std::vector<Gains> gains_;
  std::vector<bool> same_gains_as_previous_;  // joints sharing coefficients with joint j-1
  // Per interval, FilterCoefficients' eight members in their order, an array of joints() each.
  IntervalCache<std::vector<double>> coefficients_;
  std::vector<friction::JointFriction<double>> friction_;
  std::vector<double> state_;  // kJointArrays arrays
  bool started_ = false;
};

// What MomentumObserver::step did with a sample.
enum class SampleStatus {
  started,             // first good sample of the stream: r = 0
  ok,                  // the observer advanced
  bridged,             // a gap (dt > 1.5 median dt) integrated across: the observer advanced
  restarted_after_gap, // a gap too long (> gap_factor median dt) or whose positions do not
                       // agree with the velocities (see ObserverOptions): started again, r = 0
  restarted_after_bad, // first good sample after samples with NaN/inf: started again, r = 0
  invalid,             // NaN or inf among t, q, dq, tau_m: outputs NaN, restart at the next
  time_not_increasing, // t <= previous t: nothing computed or written; state unchanged
};

// The observer on a robot model, with time handling. Constant memory.
class MomentumObserver {
 public:
  // `model` must outlive the observer. `friction`: nullptr or a model with model.nq joints.
  // Throws momentum::Error when the options are invalid or the gain lists do not fit nq,
  // std::invalid_argument for a friction model of the wrong size.
  MomentumObserver(const model::Model& model, const ObserverOptions& options,
                   const friction::FrictionModel* friction);

  int joints() const { return model_.nq; }
  bool has_friction() const { return residual_.has_friction(); }

  // One sample at time t (s) with q, dq, tau_m (each nq values; rad, rad/s, Nm). Writes r and,
  // with friction, tau_f and mu (nq each; NaN for an invalid sample; untouched when the time
  // does not increase).
  SampleStatus step(double t, const double* q, const double* dq, const double* tau_m, double* r,
                    double* tau_f, double* mu);

  // Computes p and beta ahead, together, for up to model::MomentumBatch::kLanes samples the
  // caller expects to step next (rows it has already read), where the CPU makes that cheaper
  // (model::MomentumBatch::accelerated()); otherwise, or for fewer than two samples, does
  // nothing. A hint: step() takes a precomputed result only for a sample whose q and dq are
  // bit for bit those given here, and the result is bit for bit what it would compute, so the
  // outputs are the same either way. q[k] and dq[k] point at sample k's nq values, which must
  // stay as they are until the next precompute() (step() compares its samples with them).
  void precompute(int count, const double* const q[], const double* const dq[]);
  // Whether precompute() does anything here (model::MomentumBatch::accelerated()).
  bool can_precompute() const { return batch_.accelerated(); }
  // Samples precomputed that step() has neither taken nor passed over.
  int precomputed() const { return ahead_count_ - ahead_next_; }
  // Samples whose p and beta step() took from precompute().
  std::uint64_t precomputed_taken() const { return ahead_taken_; }

  // Forgets the time line after a clock step back (stream::TimeMark::clock_step): the next
  // sample starts the observer again (SampleStatus::started, r = 0), keeping the median step.
  void restart_clock() {
    have_time_ = false;
    restart_pending_ = false;
    bad_run_ = 0;
  }

  // Running median of the recent sample intervals (the last 16), s; 0 before two samples.
  double median_dt() const { return median_dt_; }
  // True when a sample at time t would come after a gap (more than 1.5 running-median steps
  // after the last good sample).
  bool is_gap(double t) const { return median_dt_ > 0 && t - t_previous_ > kLostSamples * median_dt_; }
  // The interval of the last gap (bridged or restarted_after_gap), s.
  double last_gap() const { return last_gap_; }
  // Why the last restarted_after_gap restarted: true when the gap was short enough but the
  // motion failed the check; then mismatch_joint() (0-based) and mismatch() (rad or m, the
  // largest |q1 - q0 - dt (dq0 + dq1) / 2|) say where.
  bool last_gap_mismatched() const { return last_gap_mismatched_; }
  int mismatch_joint() const { return mismatch_joint_; }
  double mismatch() const { return mismatch_; }
  // Time of the last good sample, s.
  double last_time() const { return t_previous_; }
  // Number of invalid samples before the last restarted_after_bad (for the restart message).
  std::uint64_t last_bad_run() const { return last_bad_run_; }

 private:
  void record_interval(double dt, bool gap);
  // The largest |q1 - q0 - dt (dq0 + dq1) / 2| over the joints (q0, dq0: the previous sample,
  // in q_ and dq_), into mismatch_ and mismatch_joint_.
  void measure_mismatch(double dt, const double* q, const double* dq);
  const model::Model& model_;
  model::Data data_;
  double gap_factor_;
  double bridge_tolerance_;
  ResidualObserver residual_;
  Eigen::VectorXd q_, dq_, p_, beta_, u_;
  bool have_time_ = false;  // a good sample has been seen (t_previous_ valid)
  bool restart_pending_ = false;
  std::uint64_t bad_run_ = 0;
  std::uint64_t last_bad_run_ = 0;
  double t_previous_ = 0;
  double median_dt_ = 0;
  double last_gap_ = 0;
  bool last_gap_mismatched_ = false;
  int mismatch_joint_ = 0;
  double mismatch_ = 0;
  // A step this much longer than the median means lost samples (or a jitter of more than a
  // quarter period each way): such a step is checked before it is integrated.
  static constexpr double kLostSamples = 1.5;
  core::RunningMedian<16> step_median_;
  int since_median_ = 0;
  // The index of the precomputed result for (q, dq) (its p and beta at k * nq in ahead_p_ and
  // ahead_beta_), if one is pending; -1 otherwise, and then the pending ones are dropped (the
  // stream has gone another way).
  int take_precomputed(const double* q, const double* dq);
  model::MomentumBatch batch_;
  // Precomputed samples (precompute()): their q and dq where the caller keeps them, p and beta
  // (kLanes x nq values each), and the next one step() may take.
  const double* ahead_q_[model::MomentumBatch::kLanes] = {};
  const double* ahead_dq_[model::MomentumBatch::kLanes] = {};
  std::vector<double> ahead_p_, ahead_beta_;
  int ahead_next_ = 0, ahead_count_ = 0;
  std::uint64_t ahead_taken_ = 0;
};

}  // namespace momentum::observer
