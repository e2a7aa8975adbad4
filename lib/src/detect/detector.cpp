#include "momentum/detect/detector.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "momentum/core/error.hpp"

namespace momentum::detect {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}

bool DetectorOptions::IsValid(std::string* why) const {
  if (min_samples < 1) return invalid(why, "min-samples must be >= 1");
  if (!(release > 0 && release <= 1)) return invalid(why, "release must be in (0, 1]");
  if (!(hold >= 0 && std::isfinite(hold))) return invalid(why, "hold must be >= 0 s");
  if (onset_band && !(*onset_band > 0 && *onset_band <= 1)) return invalid(why, "onset band must be in (0, 1]");
  if (!(skip >= 0 && std::isfinite(skip))) return invalid(why, "skip must be >= 0 s");
  if (!(join >= 0 && std::isfinite(join))) return invalid(why, "join must be >= 0 s");
  if (!(aftermath >= 0 && std::isfinite(aftermath))) return invalid(why, "aftermath must be >= 0 s");
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
  crossing_.assign(joints_.size(), 0);
  bounds_.assign(joints_.size(), Bounds{});
}

std::span<const Event> Detector::step(double t, const double* x, const double* dq, const double* x_rest) {
  if (rows_ == 0) t_first_ = t;
  ++rows_;
  const double t_previous = t_last_;
  t_last_ = t;
  out_count_ = 0;
  const bool judged = !(t - t_first_ < options_.skip);
  bool any_fires = false, all_quiet = true;
  bool arm_still = have_velocity_;
  if (have_velocity_)
    for (std::size_t j = 0; j < joints_.size(); ++j) arm_still = arm_still && std::fabs(dq[j]) < thresholds_.rest_rule.velocity;
  const double* judged_at_rest = thresholds_.rest_raw && x_rest ? x_rest : x;
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    Joint& J = joints_[j];
    const JointThreshold& T = thresholds_.joints[j];
    const double v = have_velocity_ ? dq[j] : kNaN;
    MotionState state = MotionState::moving;
    if (have_velocity_ && (T.rest || T.slow)) state = J.tracker.update(t, v, judged_at_rest[j], !(open_ && J.fired), arm_still);
    // A state without a threshold of its own falls to the next rule down, as in calibration.
    if (state == MotionState::rest && !T.rest) state = MotionState::slow;
    if (state == MotionState::slow && !T.slow) state = MotionState::moving;
    double stat, threshold, band, signed_stat;
    if (state == MotionState::slow) {
      signed_stat = x[j];
      stat = std::fabs(x[j]);
      threshold = *T.slow;
      band = T.slow_band;
    } else if (state == MotionState::rest) {
      ++J.rest_rows;
      const double xr = judged_at_rest[j];
      if (!J.was_rest) J.baseline.start(t, J.tracker.baseline());
      signed_stat = T.rest_absolute ? xr : xr - J.baseline.value();
      // After an event, the level a joint settles at is the torque the controller still holds
      // against that contact: the change from it is judged too (see DetectorOptions::aftermath).
      const bool in_event = open_ && J.fired;
      if (T.rest_absolute && J.after_event && !in_event && options_.aftermath > 0 &&
          std::fabs(xr - J.baseline.value()) < std::fabs(xr))
        signed_stat = xr - J.baseline.value();
      stat = std::fabs(signed_stat);
      // An absolute statistic's baseline serves the aftermath only: it starts where the joint
      // is when its event ends, and follows the level it settles at from there.
      if (T.rest_absolute && in_event) J.baseline.start(t, xr);
      else J.baseline.update(t, xr, T.rest_absolute ? options_.aftermath : T.rest_drift);
      threshold = *T.rest;
      band = T.rest_band;
    } else {
      signed_stat = x[j];
      stat = std::fabs(x[j]);
      threshold = T.moving;
      if (T.envelope && options_.use_envelope && have_velocity_ && std::isfinite(v))
        threshold = T.envelope->a + T.envelope->b * std::fabs(v);
      band = T.band;
      // Calibration counted these rows beyond the friction model's band: the same here.
      if (thresholds_.signal == Signal::mu && have_velocity_) {
        const double widen = options_.friction_band.width(j, v);
        threshold += widen;
        band += widen;
      }
    }
    J.was_rest = state == MotionState::rest;
    if (state == MotionState::moving) J.after_event = false;
    const double centre = state == MotionState::rest && !T.rest_absolute ? J.baseline.value() : 0.0;
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
    // The aftermath: what the controller may still hold of the torque a contact loaded this
    // joint with, on the side it loaded it (see DetectorOptions::aftermath). The integrator
    // builds up the contact's torque while the joint is part of an event, and unloads it after.
    const int side = signed_stat < 0 ? 1 : 0;
    if (options_.aftermath > 0 && rows_ > 1) {
      const double keep = std::exp(-(t - t_previous) / options_.aftermath);
      const bool loading = open_ && J.fired && std::isfinite(stat);
      for (int k = 0; k < 2; ++k) {
        const double load = loading && k == side ? stat : 0.0;
        J.held[k] = load + keep * (J.held[k] - load);
      }
    }
    const double unloading = J.held[side];
    J.over = judged && stat > threshold + unloading ? J.over + 1 : 0;
    fires_[j] = J.over >= options_.min_samples;
    // The row on which a firing run begins; only an armed joint's run is a new contact.
    crossing_[j] = J.over == options_.min_samples && J.armed;
    quiet_[j] = !(stat >= std::max(band, options_.release * threshold));  // NaN counts as back
    if (!quiet_[j]) J.back_since = kNaN;
    else if (std::isnan(J.back_since)) J.back_since = t;
    if (crossing_[j]) J.armed = false;
    else if (quiet_[j] && t - J.back_since >= options_.hold) J.armed = true;
    any_fires = any_fires || fires_[j];
    all_quiet = all_quiet && quiet_[j];
  }

  if (!open_) {
    if (!any_fires) return {};
    open_event(t, x);
    return {out_, out_count_};
  }

  // A new contact while the event is open: a joint of the event firing again after it fell
  // back, or a joint firing for the first time long after the event began.
  bool next = false;
  for (std::size_t j = 0; j < joints_.size(); ++j)
    if (crossing_[j] && (joints_[j].fired || t - current_.t_detect > options_.join)) next = true;
  if (next) {
    close_event(t, EndReason::next);
    open_event(t, x);
    return {out_, out_count_};
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
    return {};
  }
  if (!quiet_run_) {
    quiet_run_ = true;
    quiet_since_ = t;
  }
  if (t - quiet_since_ < options_.hold) return {};
  close_event(quiet_since_, EndReason::release);
  return {out_, out_count_};
}

void Detector::open_event(double t, const double* x) {
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
    if (J.fired) J.armed = false;
    const double magnitude = std::fabs(x[j]);
    current_.peaks[j] = std::isnan(magnitude) ? J.run_peak : std::max(J.run_peak, magnitude);
    if (J.fired) {
      current_.joints.push_back(static_cast<int>(j + 1));
      current_.link = static_cast<int>(j + 1);
      if (!J.in_band) current_.t_onset_estimate = std::min(current_.t_onset_estimate, J.rise_start);
    }
  }
  // The onset estimate of a contact that follows another cannot reach back into it.
  if (out_count_ > 0) current_.t_onset_estimate = std::max(current_.t_onset_estimate, out_[0].t_end);
  out_[out_count_++] = current_;
}

void Detector::close_event(double t_end, EndReason reason) {
  open_ = false;
  for (auto& J : joints_) {
    if (J.fired) J.after_event = true;  // until it moves: the controller may hold torque from it
    J.fired = false;
  }
  Event& e = out_[out_count_++];
  e = current_;
  e.kind = EventKind::end;
  e.t_end = t_end;
  e.ended_by = reason;
}

const Event* Detector::finish(EndReason reason) {
  if (!open_) return nullptr;
  out_count_ = 0;
  close_event(t_last_, reason);
  return &out_[0];
}

}  // namespace momentum::detect
