#pragma once
// JSON Lines (one JSON object per line, jq-ready) for machines: mo-detect's events and
// mo-calibrate's report (--format jsonl). The keys are documented in mo-detect(1) and
// mo-calibrate(1) under JSON LINES; tests/cli check each line against them.

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "momentum/core/file.hpp"
#include "momentum/detect/calibration.hpp"
#include "momentum/detect/events.hpp"
#include "momentum/detect/thresholds.hpp"

namespace momentum::detect {

// Which profile a line came from: {"name", "path" (absolute), "calibrated"}, "name" from the
// profile's "name" (null when absent), "calibrated" the time of its last mo-calibrate
// provenance entry (null when none). Null when the detector ran without a profile.
nlohmann::json profile_identity(const nlohmann::json& document, const std::string& path);

// One event row (onset or end) as an object: {"event", "kind", "t_onset_estimate", "t_detect",
// "link", "joints", "t_end", "ended_by", "peaks", "source", "profile", "signal", "thresholds"}.
// t_end and ended_by are null on onset rows; "thresholds" is the thresholds section used (as
// in the profile: thresholds_to_json), "source" the input's name.
nlohmann::json event_json(const Event& event, const std::string& source, const nlohmann::json& profile,
                          const Thresholds& thresholds);

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

// Writes JSON lines to a file or stdout, flushing after every line so that a consumer sees an
// event the moment it is detected.
class JsonLinesWriter {
 public:
  // Opens `path` ("-" or "": stdout). Throws momentum::Error when the file cannot be created.
  explicit JsonLinesWriter(const std::string& path);
  ~JsonLinesWriter();
  JsonLinesWriter(const JsonLinesWriter&) = delete;
  JsonLinesWriter& operator=(const JsonLinesWriter&) = delete;
  // Writes `object` as one line and flushes. Throws momentum::Error on a write failure,
  // stream::BrokenPipe when the reader went away.
  void write(const nlohmann::json& object);

 private:
  core::OutputFile out_;
};

}  // namespace momentum::detect
