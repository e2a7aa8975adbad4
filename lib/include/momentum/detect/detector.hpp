#pragma once
// The detector state machine of mo-detect: joints fire when their residual stays over its
// threshold, events open on the first firing and close when every joint is back in its band,
// a new contact while one is open is an event of its own (re-arming), and the collided link is
// the most distal joint that fired (paper section 4, fault signature eta = [1..1, 0..0]).
// Semantics in mo-detect(1).

#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "momentum/detect/events.hpp"
#include "momentum/detect/friction_band.hpp"
#include "momentum/detect/motion.hpp"
#include "momentum/detect/thresholds.hpp"

namespace momentum::detect {

struct DetectorOptions {
  // Consecutive rows over the threshold for a joint to fire, >= 1.
  int min_samples = 1;
  // A joint is back when its statistic is under the larger of its band (the calibration's 99th
  // percentile, see onset_band) and release * threshold: well down, not at the first dip under
  // the threshold, yet not at the mercy of the 1% of collision-free rows outside the band. A
  // joint that fired is armed again once it has been back for `hold` seconds: its next firing
  // is a new contact, and a new event. In (0, 1].
  double release = 0.5;
  // An event ends when every joint has been back for `hold` seconds, s >= 0.
  double hold = 0.2;
  // A joint firing for the first time within `join` seconds of an event's detection joins that
  // event (one contact reaches the joints' thresholds at slightly different times); a later
  // first firing is a new contact. s >= 0.
  double join = 0.25;
  // Band for the onset estimate as a fraction of the threshold, in (0, 1]; nullopt: the
  // calibrated band of the profile (band, rest_band), or 0.5 when that is 0.
  std::optional<double> onset_band;
  // Use the velocity envelope of a joint when the thresholds hold one and dq is given.
  bool use_envelope = true;
  // Seconds from the first row during which no joint fires (the observer settles), >= 0.
  double skip = 0;
  // The aftermath of an event: the time constant, s, over which a position controller builds up
  // torque against a contact in its integrator and unloads it after the release (its integral
  // time; "over seconds" on UR arms, 2 s in mo-sim). While a joint is part of an event, the
  // torque it is loaded with on each side of its centre passes through a first-order lag of this
  // time constant (what the integrator builds up), and after the event that held torque decays
  // at it: the joint fires only beyond its threshold plus what it may still hold on that side,
  // so the unloading is no new contact, while a rise beyond it, or on the other side, is. A joint whose rest statistic is
  // absolute and that fired in an event is, until it moves again, also judged by its change
  // from a baseline that follows its level at this time constant: the level it settles at is
  // torque held against stiction from that contact, not a new one. 0: no aftermath. s >= 0.
  double aftermath = 2.0;
  // Signal::mu: widens a moving joint's threshold and band by the friction model's uncertainty
  // at its speed (friction_band.hpp). Must be the band the thresholds were calibrated with
  // (friction_band_for builds it from the profile); empty: none.
  FrictionBand friction_band;
  bool IsValid(std::string* why) const;
};

class Detector {
 public:
  // `thresholds` for n joints; `have_velocity`: whether step() receives dq (rest state and
  // envelopes need it). Throws momentum::Error when the options or thresholds are invalid.
  Detector(Thresholds thresholds, DetectorOptions options, bool have_velocity);

  // One row at time t (s): residuals x[0..n) (Nm) and velocities dq[0..n) (rad/s; ignored
  // when constructed without velocity). Rows must come in time order. Returns the event rows
  // this row produced, in order: none, an onset, an end, or the end of the open event and the
  // onset of the next (a new contact while it was open); valid until the next call. A NaN
  // residual neither fires nor keeps an event open.
  // `x_rest` (optional, n): the residual judged while a joint rests, when it differs from x
  // (Thresholds::rest_raw: the raw residual r while x is the compensated mu).
  std::span<const Event> step(double t, const double* x, const double* dq, const double* x_rest = nullptr);

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
    DriftingBaseline baseline;  // at rest: follows the residual's slow drift
    bool was_rest = false;      // at rest on the previous row
    int over = 0;            // consecutive rows over the threshold
    bool in_band = true;     // previous row inside the onset band
    double rise_start = 0;   // first row of the current out-of-band run, s
    double run_peak = 0;     // peak |x| over that run
    bool fired = false;      // fired during the open event
    bool armed = true;       // back for the hold time since it last fired
    double back_since = NAN;  // start of the current run of rows back in the band, s
    // Torque the controller holds against this joint's last contact, on each side of the
    // joint's centre (0: above, 1: below), Nm >= 0: while the joint is part of an open event,
    // its statistic on that side through a first-order lag of time constant `aftermath`; after it,
    // decaying at the same time constant (see DetectorOptions::aftermath).
    double held[2] = {0, 0};
    bool after_event = false;  // fired in an event and has not moved since
    std::uint64_t rest_rows = 0;
  };
  void open_event(double t, const double* x);
  void close_event(double t_end, EndReason reason);
  Thresholds thresholds_;
  DetectorOptions options_;
  bool have_velocity_;
  std::vector<Joint> joints_;
  std::vector<char> fires_, quiet_, crossing_;
  std::vector<Bounds> bounds_;
  bool open_ = false;
  Event current_;
  Event out_[2];
  std::size_t out_count_ = 0;
  std::uint64_t next_id_ = 1;
  std::uint64_t rows_ = 0;
  double t_last_ = 0;
  double t_first_ = 0;
  double quiet_since_ = 0;
  bool quiet_run_ = false;
};

}  // namespace momentum::detect
