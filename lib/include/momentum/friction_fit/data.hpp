// The fitter's input: per joint, the observed residual r and the measured velocity dq of
// collision-free motion, with the places where the observer (re)started and the samples that
// count in the cost. Unlike every other stage, the fitter holds its data in memory.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "momentum/stream/reader.hpp"

namespace momentum::friction_fit {

// Positions of every joint, [k - 1][sample] for q<k>, rad.
using Positions = std::vector<std::vector<double>>;

// One joint's samples, in time order.
struct JointSeries {
  int joint = 0;                       // 1-based joint number
  std::vector<double> t;               // s, strictly increasing
  std::vector<double> dq;              // measured velocity, rad/s
  std::vector<double> r;               // observer residual, Nm
  // 1 where the observer started or restarted (after a gap, after invalid rows, or where the
  // stream's `restart` column says so): the model's filter starts at rest there, as the
  // observer's does, while the friction state carries on. 2 where a log starts (the first
  // sample, and each log appended): the friction model starts afresh too.
  std::vector<std::uint8_t> restart;
  std::vector<std::uint8_t> scored;    // 1 where the sample counts in the cost and the metrics
  std::string source;                  // the input's name, for messages
  // Every joint's position at each sample, (*positions)[k - 1][sample] for q<k>, rad, when the
  // stream has q1..qn columns (null otherwise): what a model error depends on (robustness.hpp).
  // Read-only and shared by the joints of a log that hold the same samples (the usual case):
  // one copy of the positions, not one per joint.
  std::shared_ptr<const Positions> positions;
  bool has_positions() const { return positions && !positions->empty(); }

  std::size_t size() const { return t.size(); }
  std::size_t scored_count() const;
  // Median sample interval, s (0 with fewer than two samples).
  double median_dt() const;
};

// Which samples a fit uses.
struct SelectOptions {
  std::vector<int> joints;          // 1-based joint numbers; empty: every joint with dq<j> and r<j>
  double skip = 0;                  // seconds after the first row that do not count, >= 0
  std::optional<double> window_begin;  // stream time (s) of the first counted sample
  std::optional<double> window_end;    // stream time (s) of the last sample read
  // A step longer than gap_factor times the median step restarts the observer (as
  // observer::ObserverOptions::gap_factor does), so the model's filter restarts there too. > 1.
  double gap_factor = 5.0;
  // Memory bound for long logs (0: keep every sample). A stream longer than this many samples
  // per joint is kept as windows of thin_window seconds spread evenly over it: every window at
  // first, every 2nd once the budget is reached, every 4th at the next, ... (constant memory,
  // decided while reading). Each kept window that follows a dropped one starts the model
  // afresh (restart 2), and its first thin_warmup seconds do not count: the observer's memory
  // of the samples that were dropped (5 of its slowest time constants). The first window is
  // always kept whole, even when it alone is over the budget.
  std::size_t max_samples = 0;
  double thin_window = 10.0;   // s, > 0
  double thin_warmup = 0.1;    // s, >= 0 and < thin_window

  // False (reason in `why`) for a negative skip, an empty or reversed window, joints < 1,
  // gap_factor <= 1, or thinning windows that are not longer than their warm-up.
  bool IsValid(std::string* why) const;
};

// Appends `more` (the same joint from another log) to `into`: its times are shifted to follow
// on one median step after the last sample, and its first sample restarts everything.
void append_series(JointSeries& into, const JointSeries& more);
// The same for every joint of a log (more[i] appended to into[i]), the positions shared by
// the joints that shared them before. Throws momentum::Error when the joint counts differ.
void append_log(std::vector<JointSeries>& into, const std::vector<JointSeries>& more);

// Holds logs appended by append_log to a budget of max_samples per joint (0: no bound), the
// way read_series holds one log: each joint's data are segments that start the model afresh
// (restart 2: each log, and each window that read_series's thinning kept), numbered in order,
// and while a joint holds more than the budget and more than one segment, only the segments
// whose number is a multiple of 2, then of 4, ... are kept. Each input's share of the budget
// is at least one window, so without this many short logs would hold a window each, and the
// fit's cost would grow with the number of logs. Joints that shared positions and keep the
// same samples still share them. Returns the samples removed from the first joint.
std::size_t thin_to_budget(std::vector<JointSeries>& series, std::size_t max_samples);

// Stops counting samples where the measured speed is below `min_speed` (rad/s, > 0), and the
// `settle` seconds after each of them (the observer filter's memory: about 3 / K1).
// At standstill and at slow reversals a joint sticks: its friction is set by the presliding
// displacement, which a measured velocity of noise around zero cannot resolve, so the model
// driven by it cannot follow and those samples would bias the sliding parameters. The model
// still runs through them. Returns the number of counted samples removed.
std::size_t exclude_slow_samples(JointSeries& series, double min_speed, double settle);

// Standard deviation of the white noise on the measured velocity, rad/s, estimated from the
// second differences of dq (robustly: median absolute value / 0.6745 / sqrt(6)); a smooth
// motion contributes its third derivative times dt^2, negligible at usual rates. 0 with fewer
// than three samples.
double estimate_velocity_noise(const JointSeries& series);

// Reads the whole stream: columns t, dq<j>, r<j> (and `restart` when present). Rows whose time
// does not increase are rejected through Reader::reject_row (skipped, or an error with
// --strict); a row with NaN/inf in t is skipped for every joint, in dq<j> or r<j> (or in any
// q<k>, when the stream has positions) for that joint only, and the joint's next good row is a
// restart. Positions q1..qn are kept in JointSeries::positions when the stream has them. Rows after window_end are not kept.
// Throws momentum::Error (`file: message`) when a column is missing, no joint has both dq<j>
// and r<j>, a requested joint is absent, or a joint has no sample left to count.
std::vector<JointSeries> read_series(stream::Reader& in, const SelectOptions& options);

}  // namespace momentum::friction_fit
