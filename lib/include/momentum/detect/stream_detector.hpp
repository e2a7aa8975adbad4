#pragma once
// mo-detect's work, as a library driver: a residual stream in, collision events out, live or on
// a recorded log. It reads the stream, chooses the thresholds (constant ones, or the profile's
// for the signal the stream carries), runs the Detector row by row, lets an EventAnnotator
// identify and classify each event beside it, runs the hooks and writes the events (CSV or
// JSON Lines) or the stream with a collision column. Every event row is flushed the moment it
// is written; SIGINT and SIGTERM close the open event and end the run, also while the input
// is quiet.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "momentum/detect/detector.hpp"
#include "momentum/detect/events.hpp"
#include "momentum/detect/thresholds.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/stream/reader.hpp"
#include "momentum/stream/writer.hpp"

namespace momentum::detect {

// Contact identification and classification beside the detector: the stream driver's view of
// contact::EventContact (lib/src/contact builds on detect, so detect only knows this interface).
class EventAnnotator {
 public:
  virtual ~EventAnnotator() = default;
  // Every row, before the detector's step on it: t (s), q, the residual x and the velocities dq
  // (n each; dq null when the stream has none).
  virtual void add(double t, const double* q, const double* x, const double* dq) = 0;
  // Fills the contact fields of an event row the detector produced on the last row added.
  virtual void annotate(Event& event) = 0;
  // Once per event, on the row where its class is decided: the class name ("collision",
  // "contact", or "" when undecidable); nullopt on other rows.
  virtual std::optional<std::string_view> decide() = 0;
  // Whether events are classified at all (the profile holds a class rule).
  virtual bool classifies() const = 0;
};

// Builds the annotator for a stream of `thresholds.joints.size()` joints from the profile's
// chain (chain.nq equals that count), the profile, and the friction band the detector judges
// with (friction_band.hpp; empty: none). Throws momentum::Error for a bad class rule in the
// profile.
using AnnotatorFactory = std::function<std::unique_ptr<EventAnnotator>(
    const model::Model& chain, const model::Profile& profile, const Thresholds& thresholds,
    const FrictionBand& friction_band)>;

enum class EventFormat { csv, jsonl };

struct StreamDetectorOptions {
  DetectorOptions detector;
  // The residual judged; nullopt: mu when the stream has mu1, else r.
  std::optional<Signal> signal;
  // Constant thresholds, Nm: one for every joint or one per joint. Empty: the profile's.
  std::vector<double> constant_thresholds;
  // The robot profile ("": none): thresholds, chain for identification, identity in JSON Lines.
  std::string profile_path;
  // Where the events go ("-": standard output), and how. Comments: lines written at the top of
  // a CSV event file (the input's leading comments come first).
  std::string output = "-";
  EventFormat format = EventFormat::csv;
  std::vector<std::string> comments;
  // Write the stream through with a column `collision` (the open event's link, 0 when none)
  // instead of the events; the events then go to `events_path` when it is not empty.
  bool pass = false;
  std::string events_path;
  // Commands (sh -c) run per collision and per contact once classified, without waiting ("":
  // none). With `any_class`, or without a class rule, `on_collision` runs for every event at
  // its detection.
  std::string on_collision, on_contact;
  bool any_class = false;
  // Time every row for the summary's latency figures (two clock reads a row: a tenth of the
  // detector's own cost); off: they stay 0.
  bool measure_latency = false;
  // Identification and classification: built when the profile's chain fits the stream and the
  // stream has q<j>; null: none.
  AnnotatorFactory annotator;
  // Opens the input with the tool's policies (strict, rows counted); null: stream::Reader::open.
  std::function<std::unique_ptr<stream::Reader>(const std::string& path, stream::ReaderOptions options)> open_input;
  // Opens the --pass output like `in`; required with `pass`.
  std::function<std::unique_ptr<stream::Writer>(stream::Reader& in)> open_output;

  // False, with the reason in `why`, for events_path without pass, invalid detector options,
  // neither constant thresholds nor a profile, or pass without open_output.
  bool IsValid(std::string* why) const;
};

struct StreamDetectorSummary {
  // False when the run ended before detecting (a signal before the header) or when the
  // reader of the output went away (the rows up to then were detected on).
  bool finished = false;
  bool output_closed = false;  // the output's reader went away (a closed pipe)
  bool interrupted = false;    // SIGINT/SIGTERM ended the input
  std::uint64_t rows = 0;          // rows detected on
  // Time the rows cover, s: the sum of their time steps (a clock step adds none), so that a
  // count of events can be set against a false-alarm rate per hour.
  double seconds = 0;
  std::uint64_t rows_skipped = 0;  // bad rows the reader skipped
  std::uint64_t events = 0;
  std::uint64_t collisions = 0;    // onsets written
  // Per joint, rows at rest; empty when the stream has no dq columns.
  std::vector<std::uint64_t> rest_rows;
  // Time spent per row, us.
  double latency_median = 0, latency_p99 = 0, latency_max = 0;  // with measure_latency
  // The --on-collision command: whether given, commands started, and those that failed.
  bool on_collision = false;
  std::uint64_t hooks_run = 0, hooks_failed = 0;
};

// The run's statistics, lines of `tool: ...` (mo-detect --stats).
std::string format_stream_detector_stats(const StreamDetectorSummary& summary, std::string_view tool);

class StreamDetector {
 public:
  // Throws momentum::Error when `options` are not valid.
  explicit StreamDetector(StreamDetectorOptions options);

  // Detects on the stream at `input` ("-": standard input) to its end or to SIGINT/SIGTERM.
  // Warns (momentum::warn) when the thresholds need dq the stream lacks, when the chain cannot
  // be built (events then go without identification), and at a clock step; a row whose time
  // goes backwards is rejected (Reader::reject_row). Throws momentum::Error when the input
  // cannot be read, lacks t or the signal's columns, when the profile has no thresholds for the
  // signal or thresholds for another joint count, when rest is judged on r and the stream has
  // none, and what the writers throw but a closed pipe (summary.output_closed).
  StreamDetectorSummary run(const std::string& input);

 private:
  StreamDetectorOptions options_;
};

}  // namespace momentum::detect
