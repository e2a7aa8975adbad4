// mo-calibrate: per-joint collision thresholds from collision-free motion, into the profile.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>

#include "momentum/cli/tool.hpp"
#include "momentum/core/file.hpp"
#include "momentum/detect/calibration.hpp"
#include "momentum/detect/events_json.hpp"
#include "momentum/eval/score.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/stream/columns.hpp"
#include "momentum/stream/error.hpp"

using namespace momentum;

// Fewer good rows than this cannot show a joint's usual band (a second at 100 Hz): refused.
constexpr std::uint64_t kMinimumRows = 100;

// --classes: learns the contact/collision rule from a labelled campaign's events and stores it
// beside the thresholds, which stay as they are.
int learn_classes(const cli::Tool& tool, const std::string& classes_path, const std::string& truth_path,
                  const std::string& output, const std::string& signals_option, bool dry_run) {
  if (!tool.inputs().empty()) throw cli::UsageError("--classes learns from events, not from residual streams");
  if (tool.profile().empty()) throw cli::UsageError("--classes needs a profile (-p) to update");
  std::unique_ptr<core::FileLock> lock;
  if (output.empty() && !dry_run) lock = cli::lock_for_update(tool.profile());
  const model::Profile profile = model::load_profile(tool.profile());
  const auto detections = eval::read_detections(classes_path, tool.strict());
  const auto examples = eval::class_examples(eval::read_truth(truth_path), detections, {});
  if (examples.empty())
    throw Error(classes_path + ": no event with a pulse width matches a contact of " + truth_path +
                " (run mo-detect with a profile that has a URDF, on a stream with q)");
  const contact::ClassRule learnt = contact::learn_rule(examples, examples.front().peaks.size());
  const std::string signal = signals_option.empty() ? "mu" : signals_option;
  std::fprintf(output == "-" ? stderr : stdout,
               "classes: %d contacts, %d collisions; a pulse narrower than %.3f s is a collision; %.1f%% right on "
               "these examples\n",
               learnt.contacts, learnt.collisions, learnt.width, 100 * learnt.accuracy);
  if (dry_run) return cli::kSuccess;
  nlohmann::json document = profile.document;
  if (!document.contains("thresholds") || !document["thresholds"].contains(signal))
    throw Error(tool.profile() + ": no thresholds for " + signal + " to classify with (calibrate them first)");
  const auto& joints = document["thresholds"][signal]["joints"];
  if (joints.is_array() && joints.size() != examples.front().peaks.size())
    throw Error(classes_path + ": events of " + std::to_string(examples.front().peaks.size()) + " joints, the profile's " +
                signal + " thresholds are for " + std::to_string(joints.size()));
  document["thresholds"][signal]["classify"] = contact::rule_to_json(learnt);
  model::append_provenance(document, "mo-calibrate",
                           {{"classes", classes_path}, {"truth", truth_path}, {"examples", examples.size()}});
  const std::string destination = output.empty() ? tool.profile() : output;
  if (destination == "-") {
    std::cout << document.dump(2) << "\n";
    return cli::kSuccess;
  }
  model::save_profile_as(document, profile, destination);
  return cli::kSuccess;
}

int main(int argc, char** argv) {
  cli::Tool tool("mo-calibrate", "Collision thresholds per joint from collision-free motion, into the profile.");
  tool.app().footer("\nExample:\n  mo-observe -p arm.json day.bin | mo-calibrate -p arm.json\n\nMore: man mo-calibrate");
  tool.add_inputs("streams of collision-free motion with mu<j> and/or r<j> (- or none: stdin)");
  tool.add_profile(/*required=*/false);
  std::string output, signals_option, rule = "rate";
  double margin = 0, max_rise = 0;
  bool envelope = false, no_rest = false, reject_contact = false, dry_run = false;
  detect::CalibrationOptions options;
  auto& app = tool.app();
  app.add_option("-o,--output", output, "write the updated profile to FILE instead of replacing -p")->type_name("FILE");
  app.add_option("--signal", signals_option, "mu, r or mu,r (default: those the streams have)")->type_name("LIST");
  app.add_option("--rule", rule, "rate: the level crossed --false-alarm-rate times an hour (default); max: max + margin")
      ->check(CLI::IsMember({"rate", "max"}));
  app.add_option("--false-alarm-rate", options.false_alarms_per_hour,
                 "false alarms per hour of each motion state the rate rule aims at (0.01)")
      ->type_name("PER_HOUR");
  app.add_option("--peak-window", options.peak_window, "seconds between independent excursions (0.2, as mo-detect --hold)")
      ->type_name("SECONDS");
  app.add_option("--max-rise", max_rise, "refuse, writing nothing, when a threshold would rise over FACTOR x the profile's")
      ->type_name("FACTOR");
  auto* margin_option = app.add_option("--margin", margin, "safety margin in Nm added to the max")->type_name("NM");
  auto* percent_option = app.add_option("--margin-percent", options.margin_percent,
                                        "safety margin in percent of the max (default 10)")
                             ->type_name("P");
  margin_option->excludes(percent_option);
  app.add_flag("--envelope", envelope, "also fit a velocity envelope a + b|dq| per joint");
  app.add_option("--envelope-bin", options.envelope_bin, "velocity resolution of the envelope, rad/s (0.001)")
      ->type_name("RAD/S");
  app.add_option("--rest-velocity", options.rest_rule.velocity, "a joint rests below this |dq|, rad/s (0.01)")
      ->type_name("RAD/S");
  app.add_option("--rest-time", options.rest_rule.time, "... held for this long, s (0.5)")->type_name("SECONDS");
  app.add_option("--hangover", options.rest_rule.hangover, "rows stay slow this long after |dq| rises, s (0.1)")
      ->type_name("SECONDS");
  app.add_option("--skip", options.skip, "seconds at the start of the stream that do not count (0)")
      ->type_name("SECONDS");
  std::string drift_list;
  app.add_option("--rest-drift", drift_list, "drift times of the rest baseline to choose from, s (0.5,1,2; 0: frozen)")
      ->type_name("LIST");
  app.add_option("--contact-rise", options.contact_rise, "rise time of the slowest contact to see at rest, s (0.3)")
      ->type_name("SECONDS");
  std::string rest_signal = "r";
  app.add_option("--rest-signal", rest_signal, "residual judged at rest with --signal mu: r (default, when present) or mu")
      ->check(CLI::IsMember({"r", "mu"}));
  app.add_flag("--no-rest", no_rest, "no rest state: one threshold per joint for all rows");
  app.add_option("--contact-ratio", options.contact_ratio, "a max over RATIO x p99.9, or x the next peak, looks like a contact (2)")
      ->type_name("RATIO");
  app.add_flag("--reject-contact", reject_contact, "fail, writing nothing, when a max looks like a contact");
  app.add_flag("-n,--dry-run", dry_run, "print the report, do not write the profile");
  tool.add_strict();
  std::string format = "text";
  app.add_option("--format", format, "report as text (default) or jsonl: one JSON object per line")
      ->check(CLI::IsMember({"text", "jsonl"}));

  std::string classes_path, truth_path;
  auto* classes_option =
      app.add_option("--classes", classes_path, "learn contact/collision from mo-detect's events of a labelled campaign")
          ->type_name("EVENTS");
  auto* truth_option = app.add_option("--truth", truth_path, "with --classes: the campaign's truth")->type_name("FILE");
  classes_option->needs(truth_option);
  truth_option->needs(classes_option);

  return tool.run(argc, argv, [&] {
    if (!classes_path.empty()) return learn_classes(tool, classes_path, truth_path, output, signals_option, dry_run);
    if (*margin_option) options.margin_nm = margin;
    options.rule = detect::parse_threshold_rule(rule);
    if (!drift_list.empty()) options.rest_drift_candidates = cli::parse_number_list(drift_list, "--rest-drift");
    if (max_rise != 0 && !(max_rise >= 1 && std::isfinite(max_rise))) throw cli::UsageError("--max-rise must be >= 1");
    options.envelope = envelope;
    options.rest_state = !no_rest;
    std::string why;
    if (!options.IsValid(&why)) throw cli::UsageError(why);
    if (!output.empty() && tool.profile().empty()) throw cli::UsageError("-o needs a profile (-p) to update");
    std::optional<model::Profile> profile;
    // An in-place update holds the profile's lock from this read to the write.
    std::unique_ptr<core::FileLock> lock;
    if (!tool.profile().empty() && output.empty() && !dry_run) lock = cli::lock_for_update(tool.profile());
    if (!tool.profile().empty()) profile = model::load_profile(tool.profile());

    std::vector<std::string> inputs = tool.inputs();
    if (inputs.empty()) inputs.push_back("-");
    std::vector<detect::Signal> signals;
    try {
      signals = detect::parse_signal_list(signals_option);
    } catch (const Error& e) {
      throw cli::UsageError(std::string("--signal: ") + e.what());
    }
    std::vector<detect::Calibrator> calibrators;
    std::size_t joints = 0;
    bool raw_at_rest = false;
    nlohmann::json logs = nlohmann::json::array();
    for (const auto& path : inputs) {
      auto in = tool.open_input(path);
      logs.push_back(in->name());
      if (calibrators.empty()) {
        if (signals.empty()) {
          if (in->find("mu1")) signals.push_back(detect::Signal::mu);
          if (in->find("r1")) signals.push_back(detect::Signal::r);
          if (signals.empty()) throw Error(in->name() + ": no mu1 or r1 column (run mo-observe first)");
        }
        joints = stream::count_joint_columns(in->columns(), detect::signal_name(signals.front()));
        if (joints == 0) throw Error(in->name() + ": missing column '" + std::string(detect::signal_name(signals.front())) + "1'");
        if (profile && !profile->joints.empty() && profile->joints.size() != joints)
          throw Error(in->name() + ": " + std::to_string(joints) + " joints, the profile has " +
                      std::to_string(profile->joints.size()));
        for (auto s : signals) calibrators.emplace_back(s, joints, options);
      }
      const std::size_t it = in->require("t");
      std::vector<std::vector<std::size_t>> columns;
      for (auto s : signals)
        columns.push_back(stream::column_indices(in->columns(), stream::joint_columns(detect::signal_name(s), joints), in->name()));
      std::vector<std::size_t> idq;
      if (stream::count_joint_columns(in->columns(), "dq") >= joints)
        idq = stream::column_indices(in->columns(), stream::joint_columns("dq", joints), in->name());
      // mu's rest rows are judged on r (see mo-detect(1)), when the streams carry it.
      std::vector<std::size_t> ir;
      if (rest_signal == "r" && stream::count_joint_columns(in->columns(), "r") >= joints)
        ir = stream::column_indices(in->columns(), stream::joint_columns("r", joints), in->name());
      if (logs.size() == 1) raw_at_rest = !ir.empty();
      else if (raw_at_rest != !ir.empty())
        throw Error(in->name() + ": some streams have r columns and others not; give --rest-signal mu");
      for (auto& c : calibrators) c.begin_stream(in->name(), !idq.empty());
      std::vector<double> x(joints), dq(joints), xr(joints);
      cli::Progress progress(tool.show_progress());
      auto where = [&] { return in->where(); };
      while (const double* row = in->next()) {
        if (in->time_mark() == stream::TimeMark::clock_step) {
          // The time line starts again: calibrate what follows as a stream of its own.
          warn(in->where() + ": the clock stepped back: the rows from here count as a new log");
          for (auto& c : calibrators) c.begin_stream(in->where(), !idq.empty());
        }
        for (std::size_t j = 0; j < idq.size(); ++j) dq[j] = row[idq[j]];
        for (std::size_t j = 0; j < ir.size(); ++j) xr[j] = row[ir[j]];
        for (std::size_t s = 0; s < calibrators.size(); ++s) {
          for (std::size_t j = 0; j < joints; ++j) x[j] = row[columns[s][j]];
          const bool raw = signals[s] == detect::Signal::mu && !ir.empty();
          calibrators[s].add(row[it], x.data(), idq.empty() ? nullptr : dq.data(), where, raw ? xr.data() : nullptr);
        }
        if ((in->rows_read() & 0xffff) == 0) progress.update(in->name() + ": " + std::to_string(in->rows_read()) + " rows");
      }
    }

    std::vector<detect::CalibrationResult> results;
    for (const auto& c : calibrators) results.push_back(c.result());
    if (results.front().rows < kMinimumRows)
      throw Error(std::to_string(results.front().rows) + " good row" + (results.front().rows == 1 ? "" : "s") +
                  " of residuals: a calibration needs at least " + std::to_string(kMinimumRows) +
                  "; nothing written");
    bool contact = false;
    std::vector<std::string> rises;
    const nlohmann::json identity =
        profile ? detect::profile_identity(profile->document, tool.profile()) : nlohmann::json(nullptr);
    for (const auto& r : results) {
      if (profile && max_rise > 0)
        if (auto old = detect::thresholds_from_profile(profile->document, r.thresholds.signal, tool.profile()))
          for (auto& rise : detect::threshold_rises(*old, r.thresholds, max_rise)) rises.push_back(rise);
      if (format == "jsonl") {
        const std::string lines = detect::calibration_json_lines(r, identity);
        std::fwrite(lines.data(), 1, lines.size(), stdout);
        for (const auto& w : r.warnings) warn(w);
        contact = contact || r.any_contact();
        continue;
      }
      std::string report = detect::format_calibration_report(r);
      if (profile) {
        auto old = detect::thresholds_from_profile(profile->document, r.thresholds.signal, tool.profile());
        report += detect::format_threshold_changes(old ? &*old : nullptr, r.thresholds);
      }
      // With -o - the profile goes to standard output, so the report goes to standard error.
      std::fwrite(report.data(), 1, report.size(), output == "-" ? stderr : stdout);
      for (const auto& w : r.warnings) warn(w);
      contact = contact || r.any_contact();
    }
    std::fflush(stdout);
    if (contact && reject_contact) throw Error("the calibration data look like they hold a contact; profile not written");
    if (!rises.empty()) {
      for (const auto& rise : rises) warn(rise);
      throw Error(std::to_string(rises.size()) + " threshold" + (rises.size() == 1 ? "" : "s") +
                  " would rise more than --max-rise allows; profile not written");
    }
    if (!profile || dry_run) return cli::kSuccess;

    nlohmann::json document = profile->document;
    nlohmann::json details = {{"logs", logs}, {"rows", results.front().rows}};
    for (const auto& r : results) {
      detect::store_thresholds(document, r.thresholds);
      nlohmann::json maxima = nlohmann::json::array();
      for (const auto& c : r.joints) maxima.push_back(c.moving.samples ? c.moving.max : c.rest_absolute.max);
      details["max_" + std::string(detect::signal_name(r.thresholds.signal))] = maxima;
    }
    details["rule"] = rule;
    if (options.rule == detect::ThresholdRule::rate) details["false_alarms_per_hour"] = options.false_alarms_per_hour;
    details["margin"] = options.margin_nm ? nlohmann::json{{"nm", *options.margin_nm}}
                                          : nlohmann::json{{"percent", options.margin_percent}};
    model::append_provenance(document, "mo-calibrate", details);
    const std::string destination = output.empty() ? tool.profile() : output;
    if (destination == "-") {
      core::write_document("-", document.dump(2) + "\n");
      return cli::kSuccess;
    }
    model::save_profile_as(document, *profile, destination);
    return cli::kSuccess;
  });
}
