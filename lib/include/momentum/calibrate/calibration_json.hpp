#pragma once
// mo-calibrate's report as JSON Lines (--format jsonl); the keys are documented in
// mo-calibrate(1) under JSON LINES.

#include <string>

#include <nlohmann/json.hpp>

#include "momentum/calibrate/calibration.hpp"

namespace momentum::calibrate {

// The calibration report of one signal as lines: one object per joint and motion state
// ({"type": "state", "signal", "joint", "state", "samples", "seconds", "rms", "p99", "p999",
// "max", "t_max", "where", "threshold", and, null for a state without a threshold, "peaks"
// (independent peaks), "left_out" (outliers), "fa_per_h" (the fitted tail's rate over the threshold),
// "vouched_fa_per_h" (ThresholdBasis::vouched_per_hour), "data_vouch_for_per_h" (the rarest
// rate the data vouch for)}) then one summary ({"type": "thresholds", "signal", "rows",
// "streams", "profile", "thresholds", "false_alarms_stated_per_hour" (the vouched rate: what
// the thresholds are held to), "false_alarms_expected_per_hour" (the rates aimed at),
// "false_alarms_vouched_per_hour", "out_of_sample": out_of_sample_json}). Numbers that are
// NaN are written null. Each line ends with '\n'.
std::string calibration_json_lines(const CalibrationResult& result, const nlohmann::json& profile);

// The out-of-sample check as JSON: {"stretches", "false_alarms", "hours", "per_hour",
// "stated", "stated_per_hour", "chance", "states": [{"joint" (1-based), "state", "false_alarms",
// "seconds", "stated", "at_least"}]} (states with time in them); {"stretches": 0} unchecked.
nlohmann::json out_of_sample_json(const OutOfSample& check);

}  // namespace momentum::calibrate
