// mo-calibrate: per-joint collision thresholds from collision-free motion, into the profile
// (drivers::calibrate_streams); with --classes, the contact/collision rule (drivers::learn_classes).
#include <cstdio>
#include <memory>
#include <optional>

#include "momentum/cli/tool.hpp"
#include "momentum/core/error.hpp"
#include "momentum/core/file.hpp"
#include "momentum/drivers/calibrate_streams.hpp"
#include "momentum/drivers/learn_classes.hpp"

using namespace momentum;

int main(int argc, char** argv) {
  cli::Tool tool("mo-calibrate", "Collision thresholds per joint from collision-free motion, into the profile.");
  tool.app().footer("\nExample:\n  mo-observe -p arm.json day.bin | mo-calibrate -p arm.json\n\nMore: man mo-calibrate");
  tool.add_stream_inputs("streams of collision-free motion with mu<j> and/or r<j> (- or none: stdin)");
  tool.add_profile(/*required=*/false);
  std::string output, signals_option, rule = "rate";
  double margin = 0, max_rise = 0;
  bool envelope = false, no_rest = false, reject_contact = false, dry_run = false;
  drivers::CalibrateStreamsOptions streams;
  calibrate::CalibrationOptions& options = streams.calibration;
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
  app.add_option("--stretch-gap", streams.stretch_gap, "a gap over this many seconds starts a new stretch (10)")
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
  app.add_option("--friction-band", streams.friction_band_sigmas,
                 "mu moving rows count beyond K sd of the profile's friction model at their speed (3; 0: off)")->type_name("K");
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
    // Every profile write, in place or -o, holds the written file's lock from the read of the
    // profile to the write, so that two runs writing one file (each its own section) keep both.
    const std::string destination = output.empty() ? tool.profile() : output;
    const bool writes = !tool.profile().empty() && !dry_run && !core::is_standard_output(destination);
    std::unique_ptr<core::FileLock> lock;
    if (!classes_path.empty()) {
      if (!tool.inputs().empty()) throw cli::UsageError("--classes learns from events, not from residual streams");
      const drivers::LearnClassesOptions learn{classes_path, truth_path, tool.profile(), output, dry_run,
                                            signals_option.empty() ? "mu" : signals_option, tool.strict()};
      std::string why;
      if (!learn.IsValid(&why)) throw cli::UsageError(why);
      if (writes) lock = cli::lock_for_update(destination);
      const drivers::LearnClassesResult learnt = drivers::learn_classes(learn);
      // Beside a profile written to standard output, the report goes to standard error.
      std::fputs(drivers::format_learn_classes(learnt).c_str(), output == "-" ? stderr : stdout);
      return cli::kSuccess;
    }
    if (*margin_option) options.margin_nm = margin;
    options.rule = calibrate::parse_threshold_rule(rule);
    if (!drift_list.empty()) options.rest_drift_candidates = cli::parse_number_list(drift_list, "--rest-drift");
    options.envelope = envelope;
    options.rest_state = !no_rest;
    streams.max_rise = max_rise;
    streams.rest_on_r = rest_signal == "r";
    streams.reject_contact = reject_contact;
    streams.format = format == "jsonl" ? drivers::ReportFormat::jsonl : drivers::ReportFormat::text;
    streams.profile_path = tool.profile();
    streams.output = output;
    streams.dry_run = dry_run;
    std::string why;
    if (!streams.IsValid(&why)) throw cli::UsageError(why);
    try {
      streams.signals = detect::parse_signal_list(signals_option);
    } catch (const Error& e) {
      throw cli::UsageError(std::string("--signal: ") + e.what());
    }
    if (writes) lock = cli::lock_for_update(destination);
    cli::Progress progress(tool.show_progress());
    streams.progress = [&](const std::string& line) { line.empty() ? progress.finish() : progress.update(line); };
    streams.open_input = [&](const std::string& path) { return tool.open_input(path); };
    std::vector<std::string> inputs = tool.inputs();
    if (inputs.empty()) inputs.push_back("-");
    drivers::calibrate_streams(inputs, streams);
    if (tool.profile().empty() && !dry_run)
      warn("no profile (-p): the report only, nothing written (give -p to update a profile)");
    return cli::kSuccess;
  });
}
