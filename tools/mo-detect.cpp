// mo-detect: collision events from residuals, live or on recorded logs. Exit status as grep:
// 0 no collision, 1 collision, 2 error. The work is drivers::StreamDetector's.
#include <csignal>
#include <cstdio>
#include <cmath>
#include <iostream>
#include <optional>

#include "momentum/cli/tool.hpp"
#include "momentum/contact/event_contact.hpp"
#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/drivers/stream_detector.hpp"

using namespace momentum;

namespace {

// 3: the input held no row at all, so nothing was checked (a warning says so). 4: no collision
// in what could be judged, but the detector was blind (rows skipped, residuals not finite, a
// clock step, the input stopped) for more than --max-blind of the time the rows cover.
constexpr int kNoCollision = 0, kCollision = 1, kError = 2, kNoRows = 3, kBlind = 4;

std::string signal_name(int number) {
  if (number == SIGINT) return "SIGINT";
  if (number == SIGTERM) return "SIGTERM";
  return "signal " + std::to_string(number);
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("mo-detect", "Collision events from residuals; exit status 1 when any (0 none, 2 error).");
  tool.app().footer("\nExample:\n  mo-observe -p arm.json log.bin | mo-detect -p arm.json > events.csv\n\nMore: man mo-detect");
  tool.add_stream_inputs("input stream (- or none: stdin)");
  tool.add_stream_output();
  tool.add_profile(/*required=*/false);
  std::string signal_option, threshold_list;
  bool constant = false, stats = false, no_identify = false;
  drivers::StreamDetectorOptions options;
  double onset_band = 0;
  auto& app = tool.app();
  app.add_option("--signal", signal_option, "mu or r (default: mu when present, else r)")
      ->check(CLI::IsMember({"mu", "r"}));
  app.add_option("--threshold", threshold_list, "constant thresholds in Nm: one, or one per joint")->type_name("LIST");
  app.add_flag("--constant", constant, "ignore the profile's velocity envelopes");
  app.add_option("--min-samples", options.detector.min_samples, "consecutive rows over the threshold to fire (default 1)")
      ->type_name("N")
      ->check(CLI::PositiveNumber);
  app.add_option("--release", options.detector.release, "a joint is back under its band or this fraction of its threshold (0.5)")
      ->type_name("FRACTION");
  app.add_option("--hold", options.detector.hold, "an event ends when every joint has been back this long, s (0.2)")
      ->type_name("SECONDS");
  app.add_option("--join", options.detector.join, "a joint firing this long after the onset starts a new event, s (0.25)")
      ->type_name("SECONDS");
  app.add_option("--aftermath", options.detector.aftermath,
                 "integral time of the arm's controller: its unloading after a contact is no new event, s (2; 0: off)")
      ->type_name("SECONDS");
  auto* band_option = app.add_option("--onset-band", onset_band, "onset band as a fraction of the threshold")
                          ->type_name("FRACTION");
  app.add_option("--skip", options.detector.skip, "seconds at the start of the stream that do not count (0)")
      ->type_name("SECONDS");
  app.add_flag("--pass", options.pass, "pass the stream through with a collision column instead of events");
  app.add_option("--events", options.events_path, "with --pass: also write the events to FILE")->type_name("FILE");
  app.add_option("--on-collision", options.on_collision, "run CMD (sh -c) per collision once classified, without waiting")
      ->type_name("CMD");
  app.add_option("--on-contact", options.on_contact, "run CMD (sh -c) per contact once classified")->type_name("CMD");
  app.add_flag("--any-class", options.any_class, "--on-collision runs for every event at its detection");
  app.add_option("--on-blind", options.on_blind, "run CMD (sh -c) per span in which the detector cannot judge")
      ->type_name("CMD");
  app.add_option("--hook-jobs", options.hook_jobs, "commands of one hook running at once (4)")
      ->type_name("N")
      ->check(CLI::PositiveNumber);
  app.add_option("--hook-queue", options.hook_queue, "commands of one hook waiting for a place; more are dropped (64)")
      ->type_name("N")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--stall", options.stall, "a live input quiet this long after a row is blind, s (2; 0: off)")
      ->type_name("SECONDS")
      ->check(CLI::NonNegativeNumber);
  double max_blind = 0.01;
  app.add_option("--max-blind", max_blind, "exit 4 when blind for more than this share of the time (0.01)")
      ->type_name("FRACTION")
      ->check(CLI::Range(0.0, 1.0));
  app.add_flag("--no-identify", no_identify, "no contact point, force or class (not even with a model and q)");
  contact::LocatorOptions locator;
  app.add_option("--link-radius", locator.link_radius, "radius of the cylinder searched for the contact point on links without collision shapes, m (0.05)")
      ->type_name("M");
  app.add_option("--link-confidence", locator.link_confidence,
                 "probability the reported link set reaches (0.9)")
      ->type_name("P");
  app.add_flag("--stats", stats, "print rows, events and per-row latency on stderr at the end");
  std::string format = "csv";
  app.add_option("--format", format, "events as csv (default) or jsonl: one JSON object per row")
      ->check(CLI::IsMember({"csv", "jsonl"}));

  // Skipped rows do not change the status (1 means a collision here); they are summed up.
  tool.set_skipped_rows_status(std::nullopt);
  tool.set_error_status(kError);
  tool.set_no_rows_policy(true, kNoRows, /*warning=*/true);
  return tool.run(argc, argv, [&]() -> int {
    try {
      if (tool.inputs().size() > 1) throw cli::UsageError("one input stream at a time");
      if (*band_option) options.detector.onset_band = onset_band;
      options.detector.use_envelope = !constant;
      if (!signal_option.empty()) options.signal = detect::parse_signal(signal_option);
      if (!threshold_list.empty()) options.constant_thresholds = cli::parse_number_list(threshold_list, "--threshold");
      options.profile_path = tool.profile();
      options.output = tool.output();
      options.format = format == "jsonl" ? drivers::EventFormat::jsonl : drivers::EventFormat::csv;
      options.measure_latency = stats;
      options.comments = {tool.provenance()};
      options.open_input = [&](const std::string& path, stream::ReaderOptions o) { return tool.open_input(path, o); };
      options.open_output = [&](stream::Reader& in) { return tool.open_output(in); };
      std::string why;
      if (!options.IsValid(&why)) throw cli::UsageError(why);
      if (!locator.IsValid(&why))
        throw cli::UsageError((locator.link_confidence > 0 && locator.link_confidence <= 1 ? "--link-radius: "
                                                                                             : "--link-confidence: ") +
                              why);
      if (!no_identify) options.annotator = contact::annotator_factory(locator, tool.profile());
      const auto summary = drivers::StreamDetector(options).run(tool.inputs().empty() ? "-" : tool.inputs().front());
      auto at = [&](double t) { return std::isfinite(t) ? " at t=" + core::exact(t) : std::string(" before the first row"); };
      if (summary.output_closed) {
        // Whoever reads the events went away: what follows was not detected on, so "no
        // collision" would be a lie.
        std::cerr << "mo-detect: error: the output was closed: detection stopped" << at(summary.t_last) << "\n";
        return kError;
      }
      if (summary.interrupted) {
        std::cerr << "mo-detect: " << signal_name(summary.signal) << ": detection stopped" << at(summary.t_last) << "\n";
        // Before the header nothing was checked: as a stream without rows.
        if (!summary.finished) return kNoRows;
      }
      if (!summary.blind_text.empty()) warn(summary.blind_text);
      if (stats && summary.finished) std::fputs(drivers::format_stream_detector_stats(summary, "mo-detect").c_str(), stderr);
      if (summary.collisions > 0) return kCollision;
      if (summary.blind_share > max_blind) {
        char share[64];
        std::snprintf(share, sizeof share, "%.3g%% of the time (more than --max-blind %.3g%%)", 100 * summary.blind_share,
                      100 * max_blind);
        warn(std::string("no collision, but the detector was blind for ") + share);
        return kBlind;
      }
      return kNoCollision;
    } catch (const cli::UsageError&) {
      throw;
    } catch (const std::exception& e) {
      // cli::Tool maps runtime errors to 1, which here means "collision": errors are 2.
      std::cerr << "mo-detect: error: " << e.what() << "\n";
      return kError;
    }
  });
}
