#pragma once
// The detector state machine of mo-detect: joints fire when their residual stays over its
// threshold, events open on the first firing and close when every joint is quiet again, and
// the collided link is the most distal joint that fired (paper section 4, fault signature
// eta = [1..1, 0..0]). Semantics in mo-detect(1).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "momentum/detect/events.hpp"
#include "momentum/detect/motion.hpp"
#include "momentum/detect/thresholds.hpp"

namespace momentum::detect {

struct DetectorOptions {
  // Consecutive rows over the threshold for a joint to fire, >= 1.
  int min_samples = 1;
  // An event ends when every joint has stayed below release * threshold for `hold` seconds.
  double release = 0.8;  // in (0, 1]
  double hold = 0.2;     // s, >= 0
  // Band for the onset estimate as a fraction of the threshold, in (0, 1]; nullopt: the
  // calibrated band of the profile (band, rest_band), or 0.5 when that is 0.
  std::optional<double> onset_band;
  // Use the velocity envelope of a joint when the thresholds hold one and dq is given.
  bool use_envelope = true;
  // Seconds from the first row during which no joint fires (the observer settles), >= 0.
  double skip = 0;
  bool IsValid(std::string* why) const;
};

class Detector {
 public:
  // `thresholds` for n joints; `have_velocity`: whether step() receives dq (rest state and
  // envelopes need it). Throws momentum::Error when the options or thresholds are invalid.
  Detector(Thresholds thresholds, DetectorOptions options, bool have_velocity);

  // One row at time t (s): residuals x[0..n) (Nm) and velocities dq[0..n) (rad/s; ignored
  // when constructed without velocity). Rows must come in time order. Returns the event row
  // this row produced (an onset or an end), or nullptr; valid until the next call. A NaN
  // residual neither fires nor keeps an event open.
  const Event* step(double t, const double* x, const double* dq);

  // Closes an open event at the last row seen (end of input or a signal). Returns its end
  // row, or nullptr when no event is open.
  const Event* finish(EndReason reason);

  // Link of the open event (0 when none): the value of mo-detect --pass's collision column.
  int open_link() const { return open_ ? current_.link : 0; }
  std::uint64_t events() const { return next_id_ - 1; }
  std::size_t joints() const { return joints_.size(); }
  // Rows in which joint j (0-based) was at rest.
  std::uint64_t rest_rows(std::size_t j) const { return joints_[j].rest_rows; }
  std::uint64_t rows() const { return rows_; }

  // The acceptance band of joint j (0-based) in signal units on the last row: the joint is
  // over its threshold when its residual leaves [lower, upper]. Moving: -/+ threshold (the
  // envelope's value at that row's speed); at rest: baseline -/+ rest threshold, or -/+ rest
  // threshold for the absolute statistic. For plots.
  struct Bounds {
    double lower = 0, upper = 0;
    bool rest = false;
  };
  const Bounds& bounds(std::size_t j) const { return bounds_[j]; }

 private:
  struct Joint {
    RestTracker tracker;
    int over = 0;            // consecutive rows over the threshold
    bool in_band = true;     // previous row inside the onset band
    double rise_start = 0;   // first row of the current out-of-band run, s
    double run_peak = 0;     // peak |x| over that run
    bool fired = false;      // fired during the open event
    std::uint64_t rest_rows = 0;
  };
  Thresholds thresholds_;
  DetectorOptions options_;
  bool have_velocity_;
  std::vector<Joint> joints_;
  std::vector<char> fires_, quiet_;
  std::vector<Bounds> bounds_;
  bool open_ = false;
  Event current_;
  Event out_;
  std::uint64_t next_id_ = 1;
  std::uint64_t rows_ = 0;
  double t_last_ = 0;
  double t_first_ = 0;
  double quiet_since_ = 0;
  bool quiet_run_ = false;
};

}  // namespace momentum::detect
