#pragma once
// JSON Lines (one JSON object per line, jq-ready) for machines: mo-detect's events (and the
// writer mo-calibrate's report goes through: calibrate/calibration_json.hpp). The keys are
// documented in mo-detect(1) and mo-calibrate(1) under JSON LINES; tests/cli check each line
// against them.

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "momentum/core/file.hpp"
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
