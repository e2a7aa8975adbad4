// Identification of corrections to a chain's inertial parameters from collision-free motion,
// in the momentum observer's filtered form, so that no acceleration is ever differentiated:
//
//   tau_m - tau_f = dp/dt + beta,   p = Y_p theta + B dq,   beta = Y_b theta      (regressor.hpp)
//
// Both sides go through the observer's unit-gain low-pass F = K/(s+K) (first-order hold, each
// interval's own dt, as observer/filter.hpp), with F[dp/dt] = K (p - F[p]):
//
//   F[tau_m] - K (B dq - F[B dq]) = (K (Y_p - F[Y_p]) + F[Y_b]) theta + F[tau_f]
//
// The friction tau_f is a smoothed Coulomb plus viscous term per joint, fitted jointly:
// tau_f,j = c_j tanh(dq_j / coulomb_speed) + v_j dq_j. The unknown is the correction delta =
// theta - theta_nominal of the nominal URDF's parameters. Normal equations are accumulated per
// sample (memory independent of the log length); friction is eliminated (Schur complement);
// the rest is column-scaled and eigen-decomposed: directions with singular value above
// rank_tolerance times the largest are the identifiable (base) combinations, the others keep
// the nominal value (the minimum-norm correction, i.e. regularised toward zero).
//
// Held-out data: the log is cut into segments of holdout_segment seconds, and every
// holdout_every-th one is not used for fitting; per joint the RMS of the filtered equation
// error there is reported before correction (nominal model, friction fitted alone) and after.
//
// Long logs: past a sample budget (IdentifyOptions::max_samples, with the logs' samples counted
// ahead by the caller, Identifier::plan()), only whole stretches spread evenly over the logs
// are taken, the filters restarting at each; the others cost a comparison each, so that the
// cost is set by the budget, not by the hours.
//
// Uncertainty: the filtered equation errors are correlated in time (the filter's memory, and
// friction-model error), so the covariance is the cluster-robust sandwich over blocks of the
// log (at least block seconds; neighbouring blocks are merged to keep at most 64 of them).
// Noise in the measured velocity enters the regressor itself (errors in variables) and biases
// the fit by an amount the sandwich does not see; it grows with the noise variance. So the
// identifier also fits copies of the data with as much noise again (white, of the level
// estimated from the velocity's second differences over the first samples) and reports the
// mean shift as a velocity-noise term beside the standard error (SIMEX's first step: Cook and
// Stefanski 1994). And the Coulomb + viscous model is least true just above min_speed (the
// Stribeck dip, the bristles): a second fit with min_speed doubled gives a friction-model
// shift. uncertainty = sqrt(standard_error^2 + velocity-noise shift^2 + friction shift^2).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "momentum/model/dynamics.hpp"
#include "momentum/model/model.hpp"
#include "momentum/observer/filter.hpp"

namespace momentum::inertia {

struct IdentifyOptions {
  // Gain K of the low-pass F = K / (s + K), 1/s (> 0): the observer's k1 is the natural choice.
  double filter_gain = 50.0;
  // Identify only mass and first moment (m, m c) of each body; rotational inertias stay
  // nominal. For logs of slow motion, where only gravity is excited.
  bool gravity_only = false;
  // Fit Coulomb + viscous friction per joint jointly with the inertial parameters. Off: the
  // inputs are assumed to be friction-compensated already.
  bool fit_friction = true;
  // The motor torque is held over the drive's control cycle, one cycle per sample (a drive that
  // applies each cycle's command for the whole cycle, as mo-sim's controller does), and a
  // sample reports the torque in effect at its instant: the ticks are a regular grid fitted to
  // the sample times, which may jitter around them. Otherwise the torque is taken as linear
  // between samples, like every other signal.
  bool torque_held = false;
  // Speed scale of the smoothed Coulomb term tanh(dq / coulomb_speed), rad/s (> 0).
  double coulomb_speed = 0.02;
  // Relative singular value below which a combination counts as not identifiable (0 < tol < 1).
  double rank_tolerance = 1e-3;
  // Samples within settle_time_constants / K seconds of a (re)start do not count (>= 0): the
  // filters start in steady state, which is wrong by the filtered dp/dt of that instant.
  double settle_time_constants = 8.0;
  // A step longer than gap_factor times the typical step restarts the filters (> 1).
  double gap_factor = 5.0;
  // Held-out validation: segments of holdout_segment seconds (> 0), every holdout_every-th
  // (>= 2) held out; 0 holds nothing out.
  double holdout_segment = 10.0;
  int holdout_every = 5;
  // A joint's equation does not count while the joint is slower than min_speed (rad/s, >= 0;
  // 0 counts everything): there friction sticks and shows Stribeck and presliding effects the
  // Coulomb + viscous model does not have. When it is fast again, its row's filters restart
  // from rest, so that nothing of the slow phase stays in the filtered equation.
  double min_speed = 0.0;
  // Shortest block of the sandwich covariance, s (> 0).
  double block = 1.0;
  // Rows counted per time constant 1/K of the filter (>= 0; 0: every row). The filtered
  // equation's error is correlated over about 1/K, so rows much closer together repeat what
  // their neighbours say: at 1 kHz and K = 10 1/s, 20 per time constant counts every 5th row
  // (the filters still run on every sample) and costs a fifth; at 125 Hz it counts them all.
  double rows_per_time_constant = 20.0;
  // Fits with doubled velocity noise for the errors-in-variables term (>= 0; 0: none), the
  // samples that estimate the noise level first (>= 10), and the seed of the added noise.
  int velocity_noise_draws = 2;
  int velocity_noise_samples = 2000;
  // Seconds of log the copies run over (>= 0; 0: all of it). Their shift is measured against
  // the fit of the same rows, so a longer log costs one fit, not 1 + draws, past this.
  double velocity_noise_seconds = 600;
  std::uint64_t seed = 1;
  // Fit again with min_speed doubled (at least 0.1 rad/s) for the friction-model term, over
  // the first friction_probe_seconds of log (>= 0; 0: all of it). With a limit, its shift is
  // measured against the fit of the same rows (a snapshot there), as the velocity-noise
  // copies' is: cheaper on long logs, but the shift then carries the scatter of those rows
  // (on 8 h of the simulated UR5 with 3600: uncertainties 0.3 to 6 times those of the full
  // probe, median 1.3), so all of the log is the default.
  bool friction_probe = true;
  double friction_probe_seconds = 0;
  // Threads (>= 1): with 2 or more, the friction probe runs on a second thread, fed the same
  // samples in batches. The results are the same, bit for bit, for any number.
  int threads = 1;
  // Sample budget: at most this many samples are taken, fitted or held out (0: all; else at
  // least velocity_noise_samples). Logs that hold more (Identifier::plan() says how many) are
  // thinned to whole stretches spread evenly over them: stretches of whole held-out periods
  // (holdout_segment x holdout_every s, and at least 20 settling times of the filter, so that
  // at most 5% of a stretch is lost to its start), the filters restarting at each, the
  // segments held out those of the whole logs. A sample thinned out costs only its reading.
  // The default, 30 min at 1 kHz: past it, more samples no longer make the stated uncertainty
  // smaller. Its standard error falls with the samples, but slower than 1 / sqrt(samples) (the
  // equation errors are model errors, correlated over the logs: on 4 h of the simulated UR5,
  // 1/8 of the samples gave standard errors 1.5 times those of all of them, not 2.8), and the
  // velocity-noise term (measured over velocity_noise_seconds of what is taken, whatever the
  // budget) and the friction-model term, most of the uncertainty on long logs, do not fall at
  // all. On the two halves of a simulated UR5 day (4 h each, 14.4 M samples), with the
  // velocity-noise term held: at 1.8 M samples the uncertainties of the base parameters grew
  // by a median of 0.1 and 0.4%, 90th percentile 4 and 12%, and every one stayed within 0.75
  // of its uncertainty of the fit of all samples; at 0.9 M the 90th percentile was 16 and 28%
  // and one left it; 3.6 M was no better within the scatter of the two terms' estimates.
  std::uint64_t max_samples = 1'800'000;

  // False (with the reason in `why`, when non-null) for values outside the ranges above.
  bool IsValid(std::string* why) const;
};

// One identifiable combination: value = direction . theta (theta: all 10 nq parameters).
struct BaseParameter {
  Eigen::VectorXd direction;     // 10 nq, in 1 / parameter unit
  double nominal = 0;            // direction . theta_nominal
  double value = 0;              // direction . (theta_nominal + delta), before projection
  double standard_error = 0;
  double velocity_noise_shift = 0;  // mean shift of value when the velocity noise doubles
  double friction_shift = 0;     // shift of value when min_speed doubles
  double uncertainty = 0;        // sqrt(standard_error^2 + both shifts^2)
  double singular_value = 0;     // relative to the largest (1 for the best excited)
};

// One standard parameter (body, index 0..9).
struct ParameterEstimate {
  int body = 0;                  // 0-based
  int index = 0;                 // into parameter_names()
  double nominal = 0;
  double value = 0;              // nominal + delta, after projection
  double standard_error = 0;     // of the unprojected estimate (0 when not fitted)
  double velocity_noise_shift = 0;  // as BaseParameter's
  double friction_shift = 0;
  double uncertainty = 0;
  // Share of the parameter that the identified combinations determine: 1 identified on its
  // own, 0 not excited (kept at nominal), in between: only in combination with others.
  double identifiability = 0;
  bool fitted = false;           // false: not a column of this fit (e.g. inertias, gravity-only)
};

struct IdentifySummary {
  int nq = 0;
  bool gravity_only = false;
  bool fit_friction = true;
  Eigen::VectorXd nominal;       // 10 nq standard parameters of the nominal model
  Eigen::VectorXd delta;         // 10 nq correction, physically consistent (after projection)
  Eigen::VectorXd delta_unprojected;
  Eigen::MatrixXd covariance;    // of delta_unprojected, 10 nq square (zero where not fitted)
  std::vector<BaseParameter> base;
  std::vector<ParameterEstimate> parameters;
  int rank = 0;                  // identified combinations
  int columns = 0;               // inertial columns fitted
  double condition_number = 0;   // of the column-scaled regressor over the identified part
  double smallest_singular_value = 0;  // relative, over all fitted columns (rank deficiency)
  // Friction per joint: Coulomb (Nm) and viscous (Nm s/rad) with standard errors, fitted
  // jointly with the correction.
  Eigen::VectorXd coulomb, viscous, coulomb_se, viscous_se;
  // The standard errors combined with the velocity-noise and friction-model shifts, as the
  // base parameters' uncertainty (set by solve(); equal to the standard errors without them).
  Eigen::VectorXd coulomb_uncertainty, viscous_uncertainty;
  // Bodies whose estimate was not physical, and what was done.
  std::vector<std::string> projections;
  // How far physical consistency moved the identified combinations, in their standard errors
  // (the largest; 0 without a projection). Far means the data ask for a body no physics allows:
  // a sign or a torque constant wrong, or friction the model cannot follow.
  double projection_shift = 0;
  // Bodies that kept their nominal parameters for an identified mass that was not positive
  // (gravity-only fits).
  int bodies_reset = 0;
  // RMS per joint of the filtered equation error, Nm: before = nominal model with friction
  // fitted alone; after = corrected model with the joint fit; current = a correction passed to
  // solve() (e.g. the profile's) with friction fitted alone. On held-out data when there is
  // any (held_out true), else on the fitting data.
  bool held_out = false;
  Eigen::VectorXd rms_before, rms_after, rms_current;
  Eigen::VectorXd rms_unprojected;  // after, with the correction before projection
  std::uint64_t samples_fit = 0, samples_held_out = 0, samples_skipped = 0;
  // Samples given to the identifier, and those of them it took: all, or the stretches of
  // stretch_seconds kept to the sample budget (stretches_kept of them; IdentifyOptions::
  // max_samples). samples_fit and samples_held_out count rows of the samples taken.
  std::uint64_t samples_read = 0, samples_taken = 0;
  bool thinned = false;
  double stretch_seconds = 0;
  int stretches_kept = 0;
  double seconds_fit = 0, seconds_held_out = 0;
  int restarts = 0;              // filter restarts (logs, gaps, bad values)
  // Estimated white noise of the measured velocity per joint, rad/s, and the number of fits
  // with it doubled that the velocity-noise shifts average (0: none).
  Eigen::VectorXd velocity_noise;
  int velocity_noise_draws = 0;
  // The min_speed of the friction-model probe (0: no probe, e.g. friction not fitted).
  double friction_probe_min_speed = 0;
  int blocks = 0;                // clusters of the covariance
};

// Accumulates samples of one or more logs and solves. Memory: O((10 nq)^2) for each of
// 1 + velocity_noise_draws fits, independent of the number of samples.
class Identifier {
 public:
  // Throws momentum::Error when the options are invalid.
  Identifier(const model::Model& nominal, const IdentifyOptions& options);
  ~Identifier();
  Identifier(const Identifier&) = delete;
  Identifier& operator=(const Identifier&) = delete;

  // One sample: t (s, increasing), q (rad), dq (rad/s), tau_m (Nm), nq each. A non-finite
  // value or a time that does not increase skips the sample and restarts the filters.
  void add(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq,
           const Eigen::VectorXd& tau_m);
  // The next sample begins a new log: filters restart, time may start anew.
  void restart();
  // The logs to come hold about `samples` samples in all (a caller that can count them ahead,
  // before the first add()). With more than options.max_samples, only stretches spread evenly
  // over them are fitted (see IdentifyOptions::max_samples); add() passes over the others at
  // the cost of a comparison. Without a plan, every sample is fitted.
  void plan(std::uint64_t samples);

  std::uint64_t samples_fit() const;
  std::uint64_t samples_held_out() const;

  // Solves. `current` (10 nq, may be null): another correction to evaluate on the held-out
  // data (IdentifySummary::rms_current). Throws momentum::Error when no sample was counted.
  IdentifySummary solve(const Eigen::VectorXd* current = nullptr) const;

 private:
  struct Block {
    Eigen::MatrixXd A;
    Eigen::VectorXd b;
  };
  struct JointStats {
    Eigen::MatrixXd G;
    Eigen::VectorXd c;
    double s = 0;
    std::uint64_t count = 0;
  };
  void begin_block();
  void accumulate(const Eigen::MatrixXd& Z, const Eigen::VectorXd& e, bool held_out);
  // Rows wait in per-joint buffers and are added in batches (a rank-k update runs several times
  // faster than k rank-1 updates); a block's fitting rows go to its own per-joint sums first,
  // which are folded into the block and the joints' totals when it closes. flush() adds every
  // waiting row (and closes the block's sums, the block staying open): before any of the sums
  // is read. The batches depend on the samples alone, so the results do too.
  struct RowBuffer {
    Eigen::MatrixXd Z;  // kRows x columns_
    Eigen::VectorXd e;
    int rows = 0;
    Eigen::Index first = 0;  // the first column any buffered row has nonzero
  };
  void flush_rows(std::size_t joint, bool held_out) const;
  void flush() const;
  mutable std::vector<RowBuffer> fit_rows_, held_rows_;
  mutable std::vector<JointStats> block_joint_;
  // The fit itself, without the velocity-noise copies.
  // Yp, Yb: the regressor at (q, dq) as another fit evaluated it (n x 10 n each, column-major),
  // or null to evaluate it here where it is needed; then the friction probe is fed the sample.
  void add_sample(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq, const Eigen::VectorXd& tau_m,
                  const double* Yp = nullptr, const double* Yb = nullptr);
  void fit_sample(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq, const Eigen::VectorXd& tau_m,
                  const double* Yp, const double* Yb);
  // Yp_, Yb_ at (q, dq): copied from Yp, Yb when given, else evaluated; sets regressed_.
  void regressor(const Eigen::VectorXd& q, const Eigen::VectorXd& dq, const double* Yp, const double* Yb);
  bool regressed_ = false;  // fit_sample() evaluated Yp_, Yb_ at its sample
  void restart_sample();
  IdentifySummary solve_one(const Eigen::VectorXd* current) const;
  // Velocity-noise copies: the first velocity_noise_samples samples are kept; from them the
  // noise level (median absolute second difference of dq), then the copies start with them
  // and take every later sample with noise added.
  std::vector<std::unique_ptr<Identifier>> replay_kept(Eigen::VectorXd* noise_level) const;
  // The velocity noise added to copy `copy` at sample `index`, joint `joint`: a standard
  // normal from (seed, copy, index, joint) alone, so that the copies replay identically.
  // `noisy` is scratch for the perturbed velocity.
  void add_to_copy(Identifier& copy, std::size_t which, std::uint64_t index, const Eigen::VectorXd& noise, double t,
                   const Eigen::VectorXd& q, const Eigen::VectorXd& dq, const Eigen::VectorXd& tau_m,
                   Eigen::VectorXd& noisy) const;
  struct KeptSample {
    std::uint64_t index = 0;
    double t = 0;
    Eigen::VectorXd q, dq, tau_m;
    bool restart = false;  // a restart() came before this sample
    // Not a sample: the last of a run of samples thinned out (pass_sample(t)).
    bool pass = false;
  };
  std::uint64_t sample_index_ = 0;
  std::vector<KeptSample> kept_;
  std::size_t kept_samples_ = 0;  // in kept_, not counting the passes
  bool restart_pending_ = false;
  // Thinning (plan()): the share of stretches kept (0: all are), their length in s, the
  // samples given and taken, and the stretch last kept.
  double keep_share_ = 0, stretch_ = 0;
  std::uint64_t samples_read_ = 0, samples_taken_ = 0;
  long long last_stretch_ = -1;
  int stretches_kept_ = 0;
  // The stretch (index from the first log's start) of a sample at t; whether it is thinned
  // out: in a stretch that is not kept, or past the budget.
  double stretch_of(double t) const;
  bool thinned_out(double t) const;
  // Samples thinned out, the last of a run at t: the log's time goes on to t (so that the
  // held-out segments stay those of the whole logs) and the next sample fitted restarts the
  // filters. end_pass() applies the run (passing_, up to pass_t_) here, to the probe and to
  // the velocity-noise copies, before the next sample taken or restart.
  void pass_sample(double t);
  void end_pass();
  bool passing_ = false;
  double pass_t_ = 0;
  // Log time of the samples thinned out (0 without thinning): the time limits of the copies
  // and the probe count the time fitted.
  double thinned_seconds_ = 0;
  bool copies_started_ = false;
  std::vector<std::unique_ptr<Identifier>> noisy_;
  // This fit's normal equations when the copies stopped (velocity_noise_seconds), what their
  // shift is measured against; null while they run.
  std::unique_ptr<Identifier> noise_reference_;
  std::unique_ptr<Identifier> snapshot() const;
  Eigen::VectorXd velocity_noise_, noisy_dq_;
  // The friction-model probe: a second fit, at its higher min_speed, of the same samples
  // (its own regressor, at its own rows).
  std::unique_ptr<Identifier> friction_probe_;
  // Its samples, on a second thread (threads >= 2); null: it is fed here, sample by sample.
  // Drained (every sample handed over processed) before the probe is read.
  class ProbeFeed;
  mutable std::unique_ptr<ProbeFeed> probe_feed_;
  // This fit's normal equations when the probe stopped (friction_probe_seconds), what its
  // shift is measured against; null while it runs.
  std::unique_ptr<Identifier> probe_reference_;
  // regressed: Yp_, Yb_ hold this sample's regressor, which the probe takes instead of its own.
  void probe_add(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq, const Eigen::VectorXd& tau_m,
                 bool regressed);
  void probe_restart();
  void probe_pass(double t);

  const model::Model& model_;
  IdentifyOptions options_;
  model::Data data_;
  int n_ = 0, fitted_ = 0, columns_ = 0;
  std::vector<int> selected_;            // inertial columns fitted (indices into theta)
  Eigen::VectorXd theta_nominal_;
  // Filter states and previous inputs.
  bool started_ = false, have_time_ = false;
  double t_previous_ = 0, t_start_ = 0, t_log_ = 0, typical_dt_ = 0;
  // The next time the regressor is evaluated and a row may count (rows_per_time_constant),
  // and the time since the last one.
  double next_regression_ = 0, since_regression_ = 0;
  // The filter's coefficients for the last interval seen, per use: most logs have one step.
  struct CachedCoefficients {
    double dt = -1;
    observer::FilterCoefficients c;
  };
  CachedCoefficients sample_coefficients_, regression_coefficients_;
  static const observer::FilterCoefficients& coefficients(const observer::Gains& gains, double dt,
                                                          CachedCoefficients& cache);
  Eigen::MatrixXd Yp_, Yb_, Fp_, Fb_, Yp_prev_, Yb_prev_;
  Eigen::MatrixXd friction_, friction_prev_, Ff_;  // n x 2: tanh, dq
  Eigen::VectorXd y_, y_prev_, Fy_;                 // tau_m - K B dq part handled separately
  Eigen::VectorXd pk_, pk_prev_, Fpk_;              // known momentum B dq
  // Normal equations (mutable: flush() completes them from the row buffers).
  mutable std::vector<Block> blocks_;
  double block_length_ = 0, block_start_ = 0;
  mutable std::vector<JointStats> fit_joint_, held_joint_;
  Eigen::MatrixXd W_, Z_;  // add_sample()'s scratch
  Eigen::VectorXd ey_, e_;
  // Per joint: its rows do not count before this time (a log's settling, or its restart), nor
  // while it is slower than min_speed.
  std::vector<double> count_from_;
  std::vector<bool> slow_;
  // The drive's control cycle (torque_held): a regular grid t = t_first + origin + k period,
  // fitted by least squares to the log's sample times against their cycle numbers k.
  struct Grid {
    double n = 0, sk = 0, st = 0, skk = 0, skt = 0;  // sums over (k, t - t_first)
    double t_first = 0, k = 0, period = 0, origin = 0;
    void add(double k, double t);
  };
  Grid grid_;
  // The tick of the control cycle at or before time t (t itself before the grid is known).
  double cycle_start(double t) const;
  std::uint64_t skipped_ = 0;
  int restarts_ = 0;
  double seconds_fit_ = 0, seconds_held_ = 0;
};

}  // namespace momentum::inertia
