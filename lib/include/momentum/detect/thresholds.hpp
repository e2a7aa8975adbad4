#pragma once
// Per-joint collision thresholds and the motion-state rule they depend on: what mo-calibrate
// writes into the profile's "thresholds" section and mo-detect reads back.
//
// Profile section (one entry per residual signal calibrated, "mu" and/or "r"):
//
//   "thresholds": {
//     "mu": {
//       "rest": {"velocity": 0.01, "time": 0.5, "hangover": 0.1},  // rad/s, s, s
//       "margin": {"nm": 0.5},                             // or {"percent": 10}
//       "friction_band": 3,                                // mu only, optional (friction_band.hpp)
//       "joints": [
//         {"moving": 2.6, "band": 1.1,                     // Nm
//          "slow": 3.9, "slow_band": 2.0,                  // Nm, optional
//          "rest": 0.9, "rest_band": 0.3,                  // Nm, optional
//          "rest_statistic": "deviation",                  // or "absolute"
//          "rest_drift": 1.0,                              // s, optional (0: frozen)
//          "envelope": {"a": 1.7, "b": 0.9}},              // Nm, Nm s/rad, optional
//         ...
//       ]
//     },
//     "r": {...}
//   }

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace momentum::detect {

// Which residual columns thresholds apply to: mu<j> (friction-compensated) or r<j>.
enum class Signal { mu, r };
std::string_view signal_name(Signal signal);  // "mu" or "r"
// "mu" or "r"; throws momentum::Error otherwise.
Signal parse_signal(std::string_view name);
// "mu,r" -> {mu, r}; "" -> {}. Throws momentum::Error naming the first unknown item.
std::vector<Signal> parse_signal_list(std::string_view comma_separated);

// The motion states of a joint (see motion.hpp): slow when |dq| is below `velocity`, and for
// `hangover` seconds after it rises above it; at rest after `time` seconds below it.
struct RestRule {
  double velocity = 0.01;  // rad/s (m/s for prismatic joints), > 0
  double time = 0.5;       // s, >= 0
  double hangover = 0.1;   // s, >= 0
  bool IsValid(std::string* why) const;
};

// Thresholds of one joint. All in Nm (N for prismatic joints), > 0 when present.
struct JointThreshold {
  // Threshold on |signal| while moving (and settling): calibration max + margin.
  double moving = 0;
  // 99th percentile of |signal| while moving in the calibration data: the usual band, used for
  // the onset estimate. 0 when unknown.
  double band = 0;
  // Threshold on |signal| while slow (|dq| under the rest velocity, not yet for the rest
  // time); absent: the moving rule applies.
  std::optional<double> slow;
  // 99th percentile of |signal| while slow. 0 when unknown.
  double slow_band = 0;
  // Threshold at rest on the rest statistic; absent: the moving rule applies at rest too.
  std::optional<double> rest;
  // The rest statistic: |signal - baseline| (deviation from the mean over the settling time),
  // or |signal| (absolute). Calibration picks the one with the lower threshold.
  bool rest_absolute = false;
  // 99th percentile of the rest statistic at rest. 0 when unknown.
  double rest_band = 0;
  // Time constant with which the rest baseline follows slow drift (motion.hpp), s; 0: frozen at
  // the settled mean. Calibration picks it per joint.
  double rest_drift = 0;
  // Velocity-dependent moving threshold a + b |dq| (margin included); a > 0, b >= 0.
  struct Envelope {
    double a = 0;  // Nm
    double b = 0;  // Nm s/rad
  };
  std::optional<Envelope> envelope;
};

// Thresholds of every joint for one signal.
struct Thresholds {
  Signal signal = Signal::mu;
  RestRule rest_rule;
  // At rest, judge the raw residual r instead of mu (Signal::mu only): a joint at rest holds
  // static friction that does not change until it moves, while a friction model driven by the
  // velocity's noise switches between -tau_c and tau_c; compensating at rest adds that noise.
  bool rest_raw = false;
  // Signal::mu: standard deviations of the friction model's steady state by which a moving
  // joint's threshold widens (friction_band.hpp; the band comes from the profile's friction
  // covariances). 0: none. >= 0.
  double friction_band = 0;
  std::vector<JointThreshold> joints;  // joint 1 first
  // The margin as calibrated, for reports: exactly one of these is set when known.
  std::optional<double> margin_nm;
  std::optional<double> margin_percent;
  // Checks sizes and signs; `why` names the first problem.
  bool IsValid(std::string* why) const;
};

// Reads the thresholds for `signal` from a profile document. Returns nullopt when the document
// has no "thresholds" section or no entry for the signal. Throws momentum::Error
// `profile: message` when the entry is malformed (wrong types, non-positive thresholds, b < 0).
// `where` names the profile in messages.
std::optional<Thresholds> thresholds_from_profile(const nlohmann::json& document, Signal signal,
                                                  const std::string& where);

// The section `name` of a signal's entry, document["thresholds"][signal][name] (the sections
// that other stages own beside the thresholds: "classify", "identify"), or nullptr when the
// document, its "thresholds" or the signal's entry has none (or is not an object there).
const nlohmann::json* thresholds_section(const nlohmann::json& document, std::string_view signal,
                                         std::string_view name);

// The JSON entry of `thresholds` (the object under "thresholds"/<signal>).
nlohmann::json thresholds_to_json(const Thresholds& thresholds);

// Stores `thresholds` under document["thresholds"][signal]: the entry's "rest", "margin",
// "friction_band" and "joints" are replaced; its other keys (the "classify" rule that contact/classify.hpp owns)
// and the other signals' entries stay. Throws momentum::Error when "thresholds" exists and is
// not an object.
void store_thresholds(nlohmann::json& document, const Thresholds& thresholds);

// Constant thresholds for `joints` joints from a user list: one value for all joints or one
// per joint, each > 0. Throws momentum::Error naming the problem.
Thresholds constant_thresholds(Signal signal, const std::vector<double>& values, std::size_t joints);

}  // namespace momentum::detect
