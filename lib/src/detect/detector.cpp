#include "momentum/detect/detector.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "momentum/stream/error.hpp"

namespace momentum::detect {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}

bool DetectorOptions::IsValid(std::string* why) const {
  auto bad = [&](const std::string& text) {
    if (why) *why = text;
    return false;
  };
  if (min_samples < 1) return bad("min-samples must be >= 1");
  if (!(release > 0 && release <= 1)) return bad("release must be in (0, 1]");
  if (!(hold >= 0 && std::isfinite(hold))) return bad("hold must be >= 0 s");
  if (onset_band && !(*onset_band > 0 && *onset_band <= 1)) return bad("onset band must be in (0, 1]");
  if (!(skip >= 0 && std::isfinite(skip))) return bad("skip must be >= 0 s");
  return true;
}

Detector::Detector(Thresholds thresholds, DetectorOptions options, bool have_velocity)
    : thresholds_(std::move(thresholds)), options_(options), have_velocity_(have_velocity) {
  std::string why;
  if (!options_.IsValid(&why)) throw Error(why);
  if (!thresholds_.IsValid(&why)) throw Error("thresholds: " + why);
  joints_.assign(thresholds_.joints.size(), Joint{});
  for (auto& J : joints_) J.tracker = RestTracker(thresholds_.rest_rule);
  fires_.assign(joints_.size(), 0);
  quiet_.assign(joints_.size(), 0);
  bounds_.assign(joints_.size(), Bounds{});
}

const Event* Detector::step(double t, const double* x, const double* dq) {
  if (rows_ == 0) t_first_ = t;
  ++rows_;
  t_last_ = t;
  const bool judged = !(t - t_first_ < options_.skip);
  bool any_fires = false, all_quiet = true;
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    Joint& J = joints_[j];
    const JointThreshold& T = thresholds_.joints[j];
    const double v = have_velocity_ ? dq[j] : kNaN;
    MotionState state = MotionState::moving;
    if (have_velocity_ && (T.rest || T.slow)) state = J.tracker.update(t, v, x[j], !(open_ && J.fired));
    // A state without a threshold of its own falls to the next rule down, as in calibration.
    if (state == MotionState::rest && !T.rest) state = MotionState::slow;
    if (state == MotionState::slow && !T.slow) state = MotionState::moving;
    double stat, threshold, band;
    if (state == MotionState::slow) {
      stat = std::fabs(x[j]);
      threshold = *T.slow;
      band = T.slow_band;
    } else if (state == MotionState::rest) {
      ++J.rest_rows;
      stat = T.rest_absolute ? std::fabs(x[j]) : std::fabs(x[j] - J.tracker.baseline());
      threshold = *T.rest;
      band = T.rest_band;
    } else {
      stat = std::fabs(x[j]);
      threshold = T.moving;
      if (T.envelope && options_.use_envelope && have_velocity_ && std::isfinite(v))
        threshold = T.envelope->a + T.envelope->b * std::fabs(v);
      band = T.band;
    }
    const double centre = state == MotionState::rest && !T.rest_absolute ? J.tracker.baseline() : 0.0;
    bounds_[j] = Bounds{centre - threshold, centre + threshold, state == MotionState::rest};
    if (options_.onset_band) band = *options_.onset_band * threshold;
    else if (!(band > 0) || band >= threshold) band = 0.5 * threshold;

    const double magnitude = std::fabs(x[j]);
    if (!(stat > band)) {  // inside the band (NaN counts as inside)
      J.in_band = true;
      J.run_peak = 0;
    } else {
      if (J.in_band) J.rise_start = t;
      J.in_band = false;
      J.run_peak = std::max(J.run_peak, magnitude);
    }
    J.over = judged && stat > threshold ? J.over + 1 : 0;
    fires_[j] = J.over >= options_.min_samples;
    quiet_[j] = !(stat >= options_.release * threshold);
    any_fires = any_fires || fires_[j];
    all_quiet = all_quiet && quiet_[j];
  }

  if (!open_) {
    if (!any_fires) return nullptr;
    open_ = true;
    quiet_run_ = false;
    current_ = Event{};
    current_.id = next_id_++;
    current_.kind = EventKind::onset;
    current_.t_detect = t;
    current_.t_onset_estimate = t;
    current_.t_end = kNaN;
    current_.peaks.assign(joints_.size(), 0.0);
    for (std::size_t j = 0; j < joints_.size(); ++j) {
      Joint& J = joints_[j];
      J.fired = fires_[j];
      const double magnitude = std::fabs(x[j]);
      current_.peaks[j] = std::isnan(magnitude) ? J.run_peak : std::max(J.run_peak, magnitude);
      if (J.fired) {
        current_.joints.push_back(static_cast<int>(j + 1));
        current_.link = static_cast<int>(j + 1);
        if (!J.in_band) current_.t_onset_estimate = std::min(current_.t_onset_estimate, J.rise_start);
      }
    }
    out_ = current_;
    return &out_;
  }

  for (std::size_t j = 0; j < joints_.size(); ++j) {
    Joint& J = joints_[j];
    const double magnitude = std::fabs(x[j]);
    if (!std::isnan(magnitude)) current_.peaks[j] = std::max(current_.peaks[j], magnitude);
    if (fires_[j] && !J.fired) {
      J.fired = true;
      current_.joints.insert(std::upper_bound(current_.joints.begin(), current_.joints.end(), static_cast<int>(j + 1)),
                             static_cast<int>(j + 1));
      current_.link = std::max(current_.link, static_cast<int>(j + 1));
    }
  }
  if (!all_quiet) {
    quiet_run_ = false;
    return nullptr;
  }
  if (!quiet_run_) {
    quiet_run_ = true;
    quiet_since_ = t;
  }
  if (t - quiet_since_ < options_.hold) return nullptr;
  open_ = false;
  for (auto& J : joints_) J.fired = false;
  out_ = current_;
  out_.kind = EventKind::end;
  out_.t_end = quiet_since_;
  out_.ended_by = EndReason::release;
  return &out_;
}

const Event* Detector::finish(EndReason reason) {
  if (!open_) return nullptr;
  open_ = false;
  for (auto& J : joints_) J.fired = false;
  out_ = current_;
  out_.kind = EventKind::end;
  out_.t_end = t_last_;
  out_.ended_by = reason;
  return &out_;
}

}  // namespace momentum::detect
