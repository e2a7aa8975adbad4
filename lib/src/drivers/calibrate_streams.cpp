#include "momentum/calibrate/calibration_json.hpp"
#include "momentum/drivers/calibrate_streams.hpp"

#include <cmath>
#include <cstdio>
#include <optional>

#include "momentum/core/error.hpp"
#include "momentum/core/file.hpp"
#include "momentum/detect/events_json.hpp"
#include "momentum/model/json_number.hpp"
#include "momentum/stream/columns.hpp"
#include "momentum/stream/non_finite.hpp"

namespace momentum::drivers {

// This driver runs the detect stage: its names are this file's vocabulary.
using namespace detect;
using namespace calibrate;

bool CalibrateStreamsOptions::IsValid(std::string* why) const {
  if (max_rise != 0 && !(max_rise >= 1 && std::isfinite(max_rise))) return invalid(why, "--max-rise must be >= 1");
  if (!calibration.IsValid(why)) return false;
  if (!(friction_band_sigmas >= 0 && std::isfinite(friction_band_sigmas)))
    return invalid(why, "--friction-band must be >= 0 standard deviations");
  if (!output.empty() && profile_path.empty()) return invalid(why, "-o needs a profile (-p) to update");
  if (!(stretch_gap > 0)) return invalid(why, "--stretch-gap must be > 0 s");
  return true;
}

std::vector<calibrate::CalibrationResult> calibrate_streams(const std::vector<std::string>& inputs,
                                                 const CalibrateStreamsOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw Error(why);
  calibrate::CalibrationOptions calibration = options.calibration;
  std::optional<model::Profile> profile;
  if (!options.profile_path.empty()) profile = model::load_profile(options.profile_path);
  if (profile && calibration.friction_band.empty())
    calibration.friction_band =
        friction_band_from_profile(profile->document, options.friction_band_sigmas, options.profile_path);

  std::vector<Signal> signals = options.signals;
  std::vector<calibrate::Calibrator> calibrators;
  std::size_t joints = 0;
  bool raw_at_rest = false;
  nlohmann::json logs = nlohmann::json::array();
  for (const auto& path : inputs) {
    auto in = options.open_input ? options.open_input(path) : stream::Reader::open(path);
    logs.push_back(in->name());
    if (calibrators.empty()) {
      if (signals.empty()) {
        if (in->find("mu1")) signals.push_back(Signal::mu);
        if (in->find("r1")) signals.push_back(Signal::r);
        if (signals.empty()) throw Error(in->name() + ": no mu1 or r1 column (run mo-observe first)");
      }
      joints = stream::count_joint_columns(in->columns(), signal_name(signals.front()));
      if (joints == 0) throw Error(in->name() + ": missing column '" + std::string(signal_name(signals.front())) + "1'");
      if (profile && !profile->joints.empty() && profile->joints.size() != joints)
        throw Error(in->name() + ": " + std::to_string(joints) + " joints, the profile has " +
                    std::to_string(profile->joints.size()));
      for (auto s : signals) calibrators.emplace_back(s, joints, calibration);
    }
    const std::size_t it = in->require("t");
    std::vector<std::vector<std::size_t>> columns;
    for (auto s : signals)
      columns.push_back(stream::column_indices(in->columns(), stream::joint_columns(signal_name(s), joints), in->name()));
    std::vector<std::size_t> idq;
    if (stream::count_joint_columns(in->columns(), "dq") >= joints)
      idq = stream::column_indices(in->columns(), stream::joint_columns("dq", joints), in->name());
    // mu's rest rows are judged on r (see mo-detect(1)), when the streams carry it.
    std::vector<std::size_t> ir;
    if (options.rest_on_r && stream::count_joint_columns(in->columns(), "r") >= joints)
      ir = stream::column_indices(in->columns(), stream::joint_columns("r", joints), in->name());
    if (logs.size() == 1) raw_at_rest = !ir.empty();
    else if (raw_at_rest != !ir.empty())
      throw Error(in->name() + ": some streams have r columns and others not; give --rest-signal mu");
    for (auto& c : calibrators) c.begin_stream(in->name(), !idq.empty());
    std::vector<double> x(joints), dq(joints), xr(joints);
    auto where = [&] { return in->where(); };
    double t_previous = NAN;
    stream::NonFiniteRows non_finite;
    while (const double* row = in->next()) {
      if (in->time_mark() == stream::TimeMark::clock_step) {
        // The time line starts again: calibrate what follows as a stream of its own.
        in->warn_clock_step("the rows from here count as a new log");
        for (auto& c : calibrators) c.begin_stream(in->where(), !idq.empty());
      } else if (in->time_mark() == stream::TimeMark::gap && row[it] - t_previous > options.stretch_gap) {
        // Recorded apart: a stretch of its own for the out-of-sample check, and the gap is no
        // exposure.
        for (auto& c : calibrators) c.begin_stretch(in->where());
      }
      t_previous = row[it];
      for (std::size_t j = 0; j < idq.size(); ++j) dq[j] = row[idq[j]];
      for (std::size_t j = 0; j < ir.size(); ++j) xr[j] = row[ir[j]];
      bool finite = std::isfinite(row[it]);
      for (std::size_t s = 0; s < calibrators.size(); ++s)
        for (std::size_t j = 0; j < joints; ++j) finite = finite && std::isfinite(row[columns[s][j]]);
      if (!finite) non_finite.note(*in, row[it]);
      for (std::size_t s = 0; s < calibrators.size(); ++s) {
        for (std::size_t j = 0; j < joints; ++j) x[j] = row[columns[s][j]];
        const bool raw = signals[s] == Signal::mu && !ir.empty();
        calibrators[s].add(row[it], x.data(), idq.empty() ? nullptr : dq.data(), where, raw ? xr.data() : nullptr);
      }
      if (options.progress && (in->rows_read() & 0xffff) == 0)
        options.progress(in->name() + ": " + std::to_string(in->rows_read()) + " rows");
    }
    if (options.progress) options.progress("");
    if (non_finite.count() > 0) warn(in->name() + ": " + non_finite.summary() + " for some of the joints calibrated");
  }

  std::vector<calibrate::CalibrationResult> results;
  for (const auto& c : calibrators) results.push_back(c.result());
  if (results.front().rows < kMinimumCalibrationRows)
    throw Error(std::to_string(results.front().rows) + " good row" + (results.front().rows == 1 ? "" : "s") +
                " of residuals: a calibration needs at least " + std::to_string(kMinimumCalibrationRows) +
                "; nothing written");
  bool contact = false;
  std::vector<std::string> rises;
  const nlohmann::json identity =
      profile ? profile_identity(profile->document, options.profile_path) : nlohmann::json(nullptr);
  for (const auto& r : results) {
    std::optional<Thresholds> old;
    if (profile && (options.max_rise > 0 || options.format == ReportFormat::text))
      old = thresholds_from_profile(profile->document, r.thresholds.signal, options.profile_path);
    if (old && options.max_rise > 0)
      for (auto& rise : calibrate::threshold_rises(*old, r.thresholds, options.max_rise)) rises.push_back(rise);
    if (options.format == ReportFormat::jsonl) {
      const std::string lines = calibration_json_lines(r, identity);
      if (options.report)
        options.report(lines);
      else
        std::fwrite(lines.data(), 1, lines.size(), stdout);
    } else {
      std::string report = calibrate::format_calibration_report(r);
      if (profile) report += calibrate::format_threshold_changes(old ? &*old : nullptr, r.thresholds);
      // With -o - the profile goes to standard output, so the report goes to standard error.
      if (options.report)
        options.report(report);
      else
        std::fwrite(report.data(), 1, report.size(), options.output == "-" ? stderr : stdout);
    }
    for (const auto& w : r.warnings) warn(w);
    contact = contact || r.any_contact();
  }
  std::fflush(stdout);
  if (contact && options.reject_contact)
    throw Error("the calibration data look like they hold a contact; profile not written");
  if (!rises.empty()) {
    for (const auto& rise : rises) warn(rise);
    throw Error(std::to_string(rises.size()) + " threshold" + (rises.size() == 1 ? "" : "s") +
                " would rise more than --max-rise allows; profile not written");
  }
  if (!profile || options.dry_run) return results;

  nlohmann::json document = profile->document;
  nlohmann::json details = {{"logs", logs}, {"rows", results.front().rows}};
  for (const auto& r : results) {
    store_thresholds(document, r.thresholds);
    nlohmann::json maxima = nlohmann::json::array();
    for (const auto& c : r.joints) maxima.push_back(c.moving.samples ? c.moving.max : c.rest_absolute.max);
    details["max_" + std::string(signal_name(r.thresholds.signal))] = maxima;
  }
  details["rule"] = calibration.rule == ThresholdRule::rate ? "rate" : "max";
  if (calibration.rule == ThresholdRule::rate) details["false_alarms_per_hour"] = calibration.false_alarms_per_hour;
  details["margin"] = calibration.margin_nm ? nlohmann::json{{"nm", *calibration.margin_nm}}
                                            : nlohmann::json{{"percent", calibration.margin_percent}};
  // What the thresholds stand for, and that statement checked out of sample, per signal.
  nlohmann::json expected = nlohmann::json::object(), vouched = nlohmann::json::object(),
                 checked = nlohmann::json::object();
  for (const auto& r : results) {
    const std::string signal(signal_name(r.thresholds.signal));
    expected[signal] = model::json_number(r.expected_false_alarms_per_hour());
    vouched[signal] = model::json_number(r.vouched_false_alarms_per_hour());
    checked[signal] = out_of_sample_json(r.out_of_sample);
    // The profile keeps the states that saw false alarms: where the promise was tested hardest;
    // and those with time left unchecked: where it was not tested.
    if (checked[signal].contains("states")) {
      nlohmann::json crossed = nlohmann::json::array();
      for (const auto& state : checked[signal]["states"])
        if (state["false_alarms"].get<std::uint64_t>() > 0 || state.contains("unchecked_seconds")) crossed.push_back(state);
      checked[signal]["states"] = crossed;
    }
  }
  // The nightly job holds the profile to the stated rate: the vouched one.
  details["false_alarms_stated_per_hour"] = vouched;
  details["false_alarms_expected_per_hour"] = expected;
  details["false_alarms_vouched_per_hour"] = vouched;
  details["out_of_sample"] = checked;
  model::append_provenance(document, "mo-calibrate", details);
  model::write_updated_profile(document, *profile, options.output);
  return results;
}

}  // namespace momentum::drivers
