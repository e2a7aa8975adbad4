#pragma once
// Threshold calibration from collision-free motion (paper section 4: the largest compensated
// residual over a long undisturbed run, plus a safety margin), in constant memory: a log of any
// length goes through with a few histograms per joint.

#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "momentum/detect/motion.hpp"
#include "momentum/calibrate/tail.hpp"
#include "momentum/detect/friction_band.hpp"
#include "momentum/detect/thresholds.hpp"

namespace momentum::calibrate {

// Counts of non-negative values in log-spaced bins, for quantiles in constant memory.
// Bins: `bins_per_decade` per decade from `lowest` to `highest`, plus one bin below (values
// under `lowest`, zero included) and one above. With the default 1000 bins per decade a
// quantile is known within a relative 0.115% (half a bin).
class LogHistogram {
 public:
  LogHistogram(double lowest = 1e-6, double highest = 1e5, int bins_per_decade = 1000);
  // Adds one value; NaN is ignored, negative values count as 0.
  void add(double value);
  // The bin `value` (not NaN) counts in: 0 under `lowest` (negative values and 0 included),
  // the last at `highest` and above, else 1 + floor(log10(value / lowest) * bins_per_decade),
  // capped at the last inner bin.
  std::size_t bin(double value) const;
  std::uint64_t count() const { return count_; }
  // Nearest-rank quantile, p in [0,1]: the smallest x such that at least ceil(p * count) values
  // are <= x, as the geometric centre of its bin clamped to [min, max] of the values added.
  // Values under `lowest` read as min(lowest, max). NaN when empty.
  double quantile(double p) const;
  double max() const { return max_; }
  // Adds the counts of a histogram with the same bins. Throws momentum::Error otherwise.
  void merge(const LogHistogram& other);

 private:
  double lowest_, highest_;
  int per_decade_;
  std::vector<std::uint64_t> bins_;  // [0]: below lowest, [last]: above highest
  // The smallest value of each bin 1..size-2 by the bins' formula, 1 + floor(log10(value /
  // lowest) * bins_per_decade) (capped at the last inner bin): add() finds a value's bin from a
  // table estimate of its logarithm and one or two comparisons with these, the bin the formula
  // gives, for a tenth of the formula's cost. Shared by the histograms of the same bins.
  std::shared_ptr<const std::vector<double>> lower_;
  std::uint64_t count_ = 0;
  double min_ = INFINITY, max_ = -INFINITY;
};

// The largest few peaks of a signal that lie at least `window` seconds apart (or in different
// streams), in constant memory: enough to tell a lone excursion (a contact) from the largest
// of many similar peaks (noise, friction at every reversal).
class PeakTracker {
 public:
  explicit PeakTracker(double window = 1.0) : window_(window) {}
  void begin_stream() { ++stream_; }
  void add(double m, double t) {
    if (candidates_.size() == kKeep && m <= smallest_) return;
    add_slow(m, t);
  }
  // Median of the other peaks kept (up to 7), each at least `window` apart: what a usual
  // excursion reaches. 0 with fewer than 4 other peaks (too little data to tell).
  double typical() const;
  // Adds the peaks of another tracker (as from other streams).
  void merge(const PeakTracker& other);

 private:
  static constexpr std::size_t kKeep = 8;
  struct Peak {
    double m, t;
    std::uint64_t stream;
  };
  void add_slow(double m, double t);
  double window_;
  std::uint64_t stream_ = 0;
  std::vector<Peak> candidates_;
  double smallest_ = 0;
};

// Statistics of |signal| over the rows of one joint in one motion state.
struct MagnitudeSummary {
  std::uint64_t samples = 0;
  double seconds = 0;  // time spent in the state (sum of the rows' time steps), s
  double rms = 0, p99 = 0, p999 = 0, max = 0;  // Nm; NaN when no samples
  std::string where_max;  // `file:line` of the row holding the max
  double t_max = 0;       // its time, s
  // Median of up to 7 other peaks, 1 s or more apart (or in other streams), Nm; 0 with fewer
  // than 4 of them.
  double typical_peak = 0;
};

// Accumulates a MagnitudeSummary: RMS (compensated sum of squares), quantiles (LogHistogram),
// max and its place, and the peaks apart from it.
class MagnitudeStats {
 public:
  // `peak_window`: seconds that separate independent excursions for the tail (> 0).
  explicit MagnitudeStats(double peak_window = 0.2) : tail_(peak_window) {}
  // Rows after this belong to a new stream (peaks in different streams are apart).
  void begin_stream() {
    peaks_.begin_stream();
    tail_.begin_stream();
  }
  // Adds |value| for a row at time t lasting dt seconds. `where` is called only when the value
  // is a new maximum (it formats a location, which is too slow for every row). NaN values are
  // ignored.
  template <class Where>
  void add(double value, double t, double dt, Where&& where) {
    const double m = std::fabs(value);
    if (std::isnan(m)) return;
    ++samples_;
    seconds_ += dt;
    // Kahan summation: a 10^8-row log must not lose the small squares.
    const double y = m * m - compensation_;
    const double s = squares_ + y;
    compensation_ = (s - squares_) - y;
    squares_ = s;
    histogram_.add(m);
    peaks_.add(m, t);
    tail_.add(m, t, dt, where);
    if (m > max_) {
      max_ = m;
      t_max_ = t;
      where_max_ = where();
    }
  }
  MagnitudeSummary summary() const;
  std::uint64_t samples() const { return samples_; }
  // The declustered peaks, for the tail fit.
  const TailSampler& tail() const { return tail_; }
  // Adds the rows of another accumulator (another state's rows judged by this state's rule).
  void merge(const MagnitudeStats& other);

 private:
  std::uint64_t samples_ = 0;
  double seconds_ = 0, squares_ = 0, compensation_ = 0;
  double max_ = -1, t_max_ = 0;
  std::string where_max_;
  LogHistogram histogram_;
  PeakTracker peaks_;
  TailSampler tail_;
};

// Fits the velocity envelope a + b |dq| of points (|dq|, |x|): the LP
//   minimise sum_i (a + b v_i)  subject to  a + b v_i >= m_i for every point, b >= 0,
// i.e. the lowest line above every point on average over the data. The optimum is the support
// line of the upper convex hull at the mean velocity. Memory: per velocity bin (width
// `bin_width`) the smallest v and the largest m seen, which stand for the bin conservatively
// (b >= 0), so the line covers every point added exactly, not just the bins.
class EnvelopeFitter {
 public:
  explicit EnvelopeFitter(double bin_width = 1e-3) : bin_width_(bin_width) {}
  // Adds one point; v, m >= 0 (absolute values are taken). Non-finite points are ignored.
  void add(double v, double m);
  // The fitted line, or nullopt when no point was added. Guarantees a + b * v >= m in floating
  // point for every point added.
  std::optional<detect::JointThreshold::Envelope> fit() const;
  std::uint64_t count() const { return count_; }
  // Mean threshold the line gives over the points added: a + b * mean(v).
  double mean_level(const detect::JointThreshold::Envelope& e) const;

 private:
  double bin_width_;
  struct Bin {
    double v_min, m_max;
  };
  std::map<long long, Bin> bins_;
  std::uint64_t count_ = 0;
  double sum_v_ = 0;
};

// How a threshold follows from the collision-free data of a joint and state.
enum class ThresholdRule {
  // The level crossed `false_alarms_per_hour` times an hour of that state, from the generalised
  // Pareto tail of the declustered peaks (tail.hpp), never below the largest peak that is not
  // an outlier plus the margin. Outliers (a glitch, an unmarked bump) are named and left out.
  rate,
  // The paper's: the largest value plus the margin, whatever it is.
  max,
};
// "rate" or "max"; throws momentum::Error otherwise.
ThresholdRule parse_threshold_rule(std::string_view name);

struct CalibrationOptions {
  ThresholdRule rule = ThresholdRule::rate;
  // The false-alarm rate a threshold stands for under the rate rule, per hour of the state's
  // motion, > 0: 0.01 is one false alarm per 100 hours.
  double false_alarms_per_hour = 0.01;
  // Seconds that separate independent excursions of the residual (> 0): the detector's hold
  // time (mo-detect --hold), after which a second excursion is a second event.
  double peak_window = 0.2;
  TailFitOptions tail;
  // Safety margin added to the largest residual (not an outlier under the rate rule): in Nm,
  // or in percent of it. Exactly one is used; margin_nm wins when both are set. Both >= 0.
  std::optional<double> margin_nm;
  double margin_percent = 10.0;
  detect::RestRule rest_rule;
  // Use the motion states (needs dq): slow rows and rows at rest get their own thresholds.
  // Off: every row counts as moving.
  bool rest_state = true;
  // Fit the velocity envelope of the moving rows (needs dq columns).
  bool envelope = false;
  double envelope_bin = 1e-3;  // rad/s
  // The max looks like a contact, not noise, when it exceeds contact_ratio times the typical
  // peak of the same joint and state (the median of up to 7 other peaks 1 s or more apart:
  // usual excursions recur, a contact does not), or, with 1000 s or more of that state (so that
  // 0.1% of it outlasts a contact), contact_ratio times its p99.9.
  double contact_ratio = 2.0;
  // Seconds at the start of each stream that do not count (the observer settles), >= 0. The
  // motion states advance through them all the same.
  double skip = 0;
  // Check the thresholds out of sample when the data hold two or more stretches (OutOfSample).
  bool out_of_sample = true;
  // Fewest rows for a slow or rest threshold; with fewer, those rows are judged by the next
  // rule down (rest -> slow -> moving) and calibrated with it.
  std::uint64_t min_state_samples = 100;
  // The rest baseline's drift time (motion.hpp): the candidates measured, s (each > 0, or 0 for
  // a frozen baseline). Per joint the one that sees the smallest contact rising over
  // `contact_rise` seconds wins: its threshold divided by drift_gain(drift, contact_rise).
  std::vector<double> rest_drift_candidates = {0.5, 1, 2};
  // Rise time of the slowest contact the rest state must see at close to its full size, s > 0:
  // a push by hand rises within a few tenths of a second. Drift slower than the chosen drift
  // time does not count as a contact; a contact rising slower is seen smaller.
  double contact_rise = 0.3;
  // Signal::mu: the friction model's uncertainty (friction_band.hpp). A moving row counts by how
  // far |mu| lies beyond the band at its speed; the thresholds record the band's sigmas, and the
  // detector widens the moving threshold by the same band. Empty: none.
  detect::FrictionBand friction_band;
  bool IsValid(std::string* why) const;
};

// How one state's threshold was decided.
struct ThresholdBasis {
  bool from_tail = false;  // the tail's level at the target rate set it (else max + margin)
  TailFit tail;            // the tail fit (tail.ok false when too few peaks; see tail.why)
  // False alarms per hour the threshold stands for under the fitted tail; NaN without a fit.
  double per_hour = NAN;
  // The same, but never below the rarest rate the data vouch for (tail.supported_per_hour):
  // a rarer figure is the tail's extrapolation, not a statement the data back. Without a fit,
  // the largest peak's own rate (once per exposure). NaN without data.
  double vouched_per_hour = NAN;
};

// The declustered peaks and row counts of one joint's motion states, from some of the rows:
// what its thresholds are decided from (see decide_joint).
struct JointTails {
  // `window`: seconds between independent excursions (> 0); `drifts`: rest drift candidates.
  JointTails(double window, std::size_t drifts);
  TailSampler moving, slow, rest_absolute;
  std::vector<TailSampler> rest;  // |x - baseline| at rest, per drift-time candidate
  std::uint64_t moving_rows = 0, slow_rows = 0, rest_rows = 0;
  // Rows after this belong to a new stream.
  void begin_stream();
  // Adds the peaks and rows of another part of the data (other streams).
  void merge(const JointTails& other);
};

// One joint's thresholds as decided from its tails, and how.
struct JointDecision {
  detect::JointThreshold threshold;  // moving, slow, rest, rest_absolute, rest_drift (no bands)
  ThresholdBasis moving_basis, slow_basis, rest_basis;
  std::size_t rest_drift_index = 0;  // the chosen drift candidate (when rest, not absolute)
  // Per drift candidate: the threshold it needs and the smallest contact it sees, Nm.
  std::vector<std::pair<double, double>> rest_drift_costs;
  bool rest_judged_slow = false;    // too few rest rows: judged (and calibrated) by the slow rule
  bool slow_judged_moving = false;  // too few slow rows: judged by the moving rule
  bool never_moved = false;
};

// Per-joint results of a calibration.
struct JointCalibration {
  ThresholdBasis moving_basis, slow_basis, rest_basis;
  MagnitudeSummary moving;         // |x| while moving
  MagnitudeSummary slow;           // |x| while slow (under the rest velocity, not yet at rest)
  MagnitudeSummary rest;           // |x - baseline| at rest, baseline following at rest_drift
  double rest_drift = 0;           // the chosen drift time, s
  // Per candidate drift time: the threshold it needs and the smallest contact it sees, Nm.
  std::vector<std::pair<double, double>> rest_drift_costs;
  MagnitudeSummary rest_absolute;  // |x| at rest: what a rest-blind threshold would need
  std::optional<detect::JointThreshold::Envelope> envelope_raw;  // before the margin
  double envelope_mean = NAN;  // mean envelope threshold over the moving rows (margin incl.)
  bool moving_contact = false;  // moving max looks like a contact
  bool slow_contact = false;    // slow max looks like a contact
  bool rest_contact = false;    // rest max looks like a contact
};

// The calibration's promise checked out of sample: each stretch of the data (a log, or the part
// of a log after a clock step or a long gap) in turn is left out, the others are calibrated
// with the same options, and the left-out stretch's excursions over those thresholds are
// counted (declustered peaks over a threshold with the signal under it since the peak before:
// each one an excursion the detector would raise an event for), against the
// rate the left-out calibration states for that stretch's time in each state.
struct OutOfSample {
  struct State {
    std::size_t joint = 0;  // 0-based
    std::string state;      // moving, slow, rest (rows at rest, whichever statistic)
    std::uint64_t crossings = 0;  // left-out excursions over the left-out calibration's threshold
    double seconds = 0;           // left-out time in the state, s
    double expected = 0;          // crossings the left-out calibrations state for that time
    bool at_least = false;        // more peaks crossed than were kept: crossings is a bound
    std::vector<TailPeak> first;  // the largest few crossings, for the report
    // Held-out time in this state that the left-out calibration had no rows of its own for
    // (every such row was in the stretch left out) while the full calibration has: judged by
    // another state's threshold, it tests no statement, and is counted apart.
    double unchecked_seconds = 0;
    std::uint64_t unchecked_crossings = 0;  // excursions there over the borrowed threshold
  };
  std::size_t stretches = 0;    // stretches left out in turn (0: fewer than 2, no check)
  std::uint64_t crossings = 0;  // summed over joints and states (an upper bound on events)
  double seconds = 0;           // the data's time, s
  double expected = 0;          // the crossings the calibrations stated for it
  double unchecked_seconds = 0;  // joint-state seconds not checked (State::unchecked_seconds), summed
  std::vector<State> states;    // per joint and state with time in it
  // Per hour of logs: seen, and as stated by the left-out calibrations (NaN without a check).
  double seen_per_hour() const { return seconds > 0 ? crossings / (seconds / 3600) : NAN; }
  double stated_per_hour() const { return seconds > 0 ? expected / (seconds / 3600) : NAN; }
  // P(N >= crossings) for N Poisson with mean `expected`: under 0.05 the promise failed.
  double chance() const;
};

struct CalibrationResult {
  detect::Thresholds thresholds;
  std::vector<JointCalibration> joints;
  std::uint64_t rows = 0;
  std::vector<std::string> streams;  // names of the streams, in order
  bool have_velocity = false;
  bool states = true;  // motion states used (CalibrationOptions::rest_state)
  ThresholdRule rule = ThresholdRule::rate;
  double false_alarms_per_hour = 0;  // the rate rule's target
  std::vector<double> rest_drift_candidates;  // s
  // Per joint, the friction band's half-width near standstill, Nm (empty without a band).
  std::vector<double> friction_band_static;
  // Human-readable notes (a joint never at rest, no dq columns, ...), one line each.
  std::vector<std::string> notes;
  // Maxima that look like a contact (see CalibrationOptions::contact_ratio), one line each.
  std::vector<std::string> warnings;
  // The promise checked out of sample (stretches 0 when the data are one stretch).
  OutOfSample out_of_sample;
  // True when any joint's max looks like a contact.
  bool any_contact() const;
  // False alarms the thresholds stand for, per hour of logs whose motion is like the
  // calibration's: every joint's states, each at the rate its tail gives over its threshold
  // (the target rate where no tail was fitted) and weighted by its share of the joint's time.
  // A sum over joints, so an upper bound on events (one event may cross several joints). NaN
  // when no joint has rows.
  double expected_false_alarms_per_hour() const;
  // The same with every state at the rate its data vouch for (ThresholdBasis::vouched_per_hour):
  // what the thresholds can be held to where the data are too short for the rate asked. This
  // is the rate the report and the profile state ("false alarms stated"), never rarer than
  // expected_false_alarms_per_hour().
  double vouched_false_alarms_per_hour() const;
};

// Accumulates collision-free rows of one signal over one or more streams.
class Calibrator {
 public:
  // `joints` >= 1. Throws momentum::Error when options are invalid.
  Calibrator(detect::Signal signal, std::size_t joints, CalibrationOptions options);

  // Starts a stream: the motion state and the time step restart. `have_velocity`: whether
  // this stream gives dq (then add() takes non-null dq).
  void begin_stream(const std::string& name, bool have_velocity);

  // One row: time t (s), residuals x[0..n) (Nm), velocities dq[0..n) (rad/s) or nullptr.
  // `where()` returns the row's location (`file:line`); it is called only for new maxima.
  // `x_rest` (n, or nullptr): the residual judged at rest when it differs from x (the raw r
  // beside mu, see Thresholds::rest_raw; give it on every row or on none).
  template <class Where>
  void add(double t, const double* x, const double* dq, Where&& where, const double* x_rest = nullptr) {
    if (x_rest) rest_raw_ = true;
    if (parts_.empty()) begin_part("");
    const double dt = std::isnan(t_prev_) || !(t > t_prev_) ? 0.0 : t - t_prev_;
    t_prev_ = t;
    if (std::isnan(t_start_)) t_start_ = t;
    const bool counted = !(t - t_start_ < options_.skip);
    rows_ += counted;
    bool arm_still = dq != nullptr;
    if (dq)
      for (std::size_t j = 0; j < joints_.size(); ++j) arm_still = arm_still && std::fabs(dq[j]) < options_.rest_rule.velocity;
    for (std::size_t j = 0; j < joints_.size(); ++j) {
      auto& J = joints_[j];
      JointTails& P = parts_.back().joints[j];
      detect::MotionState state = detect::MotionState::moving;
      const double xr = x_rest ? x_rest[j] : x[j];
      if (dq && options_.rest_state) state = J.tracker.update(t, dq[j], xr, true, arm_still);
      if (state == detect::MotionState::rest) {
        // The baselines follow through the skipped rows too, as the detector's does.
        if (!J.was_rest)
          for (auto& b : J.drifting) b.start(t, J.tracker.baseline());
        for (std::size_t d = 0; d < J.drifting.size(); ++d) {
          if (counted) {
            J.rest[d].add(xr - J.drifting[d].value(), t, dt, where);
            P.rest[d].add(std::fabs(xr - J.drifting[d].value()), t, dt, where);
          }
          J.drifting[d].update(t, xr, options_.rest_drift_candidates[d]);
        }
      }
      J.was_rest = state == detect::MotionState::rest;
      if (!counted) continue;
      if (state == detect::MotionState::rest) {
        J.rest_absolute.add(xr, t, dt, where);
        P.rest_absolute.add(std::fabs(xr), t, dt, where);
        P.rest_rows += !std::isnan(xr);
      } else if (state == detect::MotionState::slow) {
        J.slow.add(x[j], t, dt, where);
        P.slow.add(std::fabs(x[j]), t, dt, where);
        P.slow_rows += !std::isnan(x[j]);
      } else {
        // Beyond the friction model's own uncertainty at this speed (0 without a band).
        const double widen = signal_ == detect::Signal::mu && dq ? options_.friction_band.width(j, dq[j]) : 0.0;
        const double beyond = widen > 0 && !std::isnan(x[j]) ? std::max(0.0, std::fabs(x[j]) - widen) : x[j];
        J.moving.add(beyond, t, dt, where);
        P.moving.add(std::fabs(beyond), t, dt, where);
        P.moving_rows += !std::isnan(beyond);
        if (dq && options_.envelope) J.envelope.add(std::fabs(dq[j]), std::fabs(beyond));
      }
    }
  }

  // Rows after this count as a new stretch of the same stream for the out-of-sample check
  // (a long gap: what follows was recorded apart); the motion states restart as for a stream.
  void begin_stretch(const std::string& name);

  // Thresholds and report from everything added. Throws momentum::Error when a joint has no
  // finite sample, or its threshold would be 0 (an all-zero residual with a percent margin).
  CalibrationResult result() const;

  // One joint's thresholds from its tails, by the rules result() applies (the threshold rule,
  // the margin, the rest statistic and drift time, the fallback of states with too few rows).
  // `corroborated` (may be empty): the peaks judged as outliers at the tail options'
  // corroborated_probability (see decide_joints).
  JointDecision decide_joint(const JointTails& tails,
                             const std::function<bool(const TailPeak&)>& corroborated = {}) const;
  // Every joint's decision (tails[j] for joint j), with outliers corroborated across joints: a
  // peak within peak_window of a peak left out on another joint, in the same stream, is judged
  // at the corroborated level. One round: the joints are decided alone, then again with the
  // outliers the first round left out.
  std::vector<JointDecision> decide_joints(const std::vector<JointTails>& tails) const;

 private:
  struct Joint {
    detect::RestTracker tracker;
    MagnitudeStats moving, slow;
    std::vector<MagnitudeStats> rest;        // per drift-time candidate
    std::vector<detect::DriftingBaseline> drifting;  // per drift-time candidate
    bool was_rest = false;
    MagnitudeStats rest_absolute;
    EnvelopeFitter envelope;
  };
  // The tails of one stretch of the data, for the out-of-sample check.
  struct Part {
    std::string name;
    std::vector<JointTails> joints;
  };
  void begin_part(const std::string& name);
  // Every joint's peak tails and rest state start afresh (a new log or stretch).
  void begin_joint_streams();
  OutOfSample check_out_of_sample() const;
  detect::Signal signal_;
  CalibrationOptions options_;
  std::vector<Joint> joints_;
  std::vector<Part> parts_;
  std::vector<std::string> streams_;
  bool have_velocity_ = true;
  bool rest_raw_ = false;
  std::uint64_t rows_ = 0;
  double t_prev_ = NAN;
  double t_start_ = NAN;  // first row of the current stream
};

// The report mo-calibrate prints: one header comment, one row per joint and state (moving,
// rest, rest_abs), whitespace-aligned so that awk can read it, then the notes and warnings
// as '#' lines. Columns: signal joint state samples seconds rms p99 p99.9 max t_max where
// threshold.
std::string format_calibration_report(const CalibrationResult& result);

// The '#' lines of the out-of-sample check (OutOfSample), part of the report:
//   # mu out of sample: 9 stretches, each left out in turn: 3 false alarms in 0.25 h (12 per h),
//   stated 1.2 (4.8 per h); as many or more by chance: 0.12
// then one line per joint and state with crossings, naming the largest few.
std::string format_out_of_sample(const CalibrationResult& result);

// '#' lines comparing the thresholds in place (`old`, or nullptr when the profile has none for
// the signal) with the new ones, one per joint and state, for awk:
//   # change mu1 moving 2.5 -> 2.28 Nm -8.8%
// ("-" for a state without a threshold, then no percentage).
std::string format_threshold_changes(const detect::Thresholds* old, const detect::Thresholds& updated);

// The thresholds of `updated` that exceed `factor` times the same joint's and state's in `old`,
// one line each ("mu2 moving 7.1 -> 31 Nm, 4.4 times"), for a nightly recalibration that must
// not make the robot blind without saying so. Empty when none, or when the joint counts differ.
std::vector<std::string> threshold_rises(const detect::Thresholds& old, const detect::Thresholds& updated, double factor);

}  // namespace momentum::calibrate
