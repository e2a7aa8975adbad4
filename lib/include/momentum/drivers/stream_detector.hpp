#pragma once
// mo-detect's work, as a library driver: a residual stream in, collision events out, live or on
// a recorded log. It reads the stream, chooses the thresholds (constant ones, or the profile's
// for the signal the stream carries), runs the Detector row by row, lets an EventAnnotator
// identify and classify each event beside it, runs the hooks and writes the events (CSV or
// JSON Lines) or the stream with a collision column. Every event row is flushed the moment it
// is written. On the row that crosses a threshold the onset row, the --on-collision hook and
// the --pass row go out first; identification follows in its own row (kind identified) on the
// same input row. SIGINT and SIGTERM close the open event and end the run, also while the
// input is quiet.

#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "momentum/detect/annotator.hpp"
#include "momentum/detect/detector.hpp"
#include "momentum/detect/events.hpp"
#include "momentum/detect/thresholds.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/stream/reader.hpp"
#include "momentum/stream/writer.hpp"

namespace momentum::drivers {

enum class EventFormat { csv, jsonl };

struct StreamDetectorOptions {
  detect::DetectorOptions detector;
  // The residual judged; nullopt: mu when the stream has mu1, else r.
  std::optional<detect::Signal> signal;
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
  // Per hook command: at most this many run at once, and this many more wait for a free place
  // (in event order); an event beyond both is dropped and counted. >= 1 and >= 0.
  std::size_t hook_jobs = 4, hook_queue = 64;
  // Command (sh -c) run at the start of every span in which the detector cannot judge (see
  // BlindWatch), without waiting ("": none): MOMENTUM_BLIND_CAUSE, MOMENTUM_T_START.
  std::string on_blind;
  // A live input (a pipe, socket or terminal) that gives no row for this long after one came
  // is a blind span ("input stopped"), reported at once and closed by the next row, s >= 0;
  // 0: off. Stream time then jumps too, so the span's length is the time the rows did not cover.
  double stall = 2.0;
  // Time every row for the summary's latency figures (two clock reads a row: a tenth of the
  // detector's own cost); off: they stay 0.
  bool measure_latency = false;
  // Identification and classification: built when the profile's chain fits the stream and the
  // stream has q<j>; null: none.
  detect::AnnotatorFactory annotator;
  // Opens the input with the tool's policies (strict, rows counted); null: stream::Reader::open.
  std::function<std::unique_ptr<stream::Reader>(const std::string& path, stream::ReaderOptions options)> open_input;
  // Opens the --pass output like `in`; required with `pass`.
  std::function<std::unique_ptr<stream::Writer>(stream::Reader& in)> open_output;

  // False, with the reason in `why`, for events_path without pass, invalid detector options,
  // neither constant thresholds nor a profile, pass without open_output, or hook_jobs 0.
  bool IsValid(std::string* why) const;
};

// Why the detector could not judge for a while.
enum class BlindCause {
  rows_skipped,  // bad rows the reader skipped (a bad number, a time that does not fit)
  not_finite,    // a residual judged was NaN or infinite (a drive dropout, a bad profile)
  clock_step,    // the clock stepped back: the detector restarts, blind for its start-up skip
  input_stopped, // the input ended in a cut row, or a live input went quiet
};
inline constexpr std::size_t kBlindCauses = 4;
// "rows skipped", "residuals not finite", "clock step back", "input stopped".
std::string_view blind_cause_name(BlindCause cause);

// One span of stream time in which the detector could not judge.
struct BlindSpan {
  BlindCause cause = BlindCause::rows_skipped;
  // Stream time, s: the last row judged before (or the first row not judged) and the first row
  // judged after; NaN end while the span is open. A span of zero length is a blind point (rows
  // skipped before the first row, a cut last row, a clock step without start-up skip).
  double t_start = 0, t_end = 0;
  std::uint64_t rows = 0;  // rows not judged in it (skipped or not finite)
  std::string where;       // location of the row that opened it
  std::string detail;      // which columns, or the clock's times
  bool opened = false;     // reported when it opened (a span that lasts), not only at its end
  double seconds() const { return std::isfinite(t_end) && t_end > t_start ? t_end - t_start : 0.0; }
};

// The spans in which the detector could not judge, found row by row. Reports each span through
// `report` once when it is known complete (ended true), and a span that lasts (residuals not
// finite, a quiet input) also when it opens (ended false), so that a live user learns of it
// at once. Sums them up per cause. Memory is constant: only the first `kept` spans are kept.
class BlindWatch {
 public:
  using Report = std::function<void(const BlindSpan& span, bool ended)>;
  explicit BlindWatch(Report report, std::size_t kept = 10) : report_(std::move(report)), kept_(kept) {}

  // A row read at t (s), at `where`, after `skipped` (>= 0) rows skipped since the row before;
  // `not_finite`: the names of the residual columns not finite on it ("" when all are).
  // Returns whether the row can be judged (all residuals finite).
  bool row(double t, std::uint64_t skipped, std::string_view not_finite, const std::string& where);
  // The row at t starts a new time line after a clock step back from `t_before`; the detector
  // restarts and does not judge for `settle` s (its start-up skip). Closes open spans at
  // t_before. Call before row() for that row.
  void clock_step(double t_before, double t, double settle, const std::string& where);
  // A live input went quiet after the row at `t_last`; the span closes at the next row.
  void input_stopped(double t_last, const std::string& detail, const std::string& where);
  // End of input: `skipped` rows were skipped after the last row (a cut last row, or bad rows
  // at the end), `where` the input's name. Closes every open span at the last row.
  void finish(std::uint64_t skipped, const std::string& where);

  std::uint64_t spans() const { return spans_; }
  std::uint64_t spans(BlindCause cause) const { return per_cause_[static_cast<std::size_t>(cause)]; }
  double seconds() const { return seconds_; }
  std::uint64_t rows() const { return rows_; }
  // The first `kept` spans (complete), for the summary.
  const std::vector<BlindSpan>& kept() const { return kept_spans_; }

 private:
  void open(BlindSpan& span, BlindCause cause, double t, std::string detail, const std::string& where);
  void close(BlindSpan& span, double t_end);
  void record(const BlindSpan& span);
  Report report_;
  std::size_t kept_;
  std::vector<BlindSpan> kept_spans_;
  std::optional<BlindSpan> not_finite_, stopped_;
  double t_last_ = NAN;
  double settle_until_ = NAN;
  std::uint64_t spans_ = 0, rows_ = 0;
  std::uint64_t per_cause_[kBlindCauses] = {};
  double seconds_ = 0;
};

// One span as mo-detect reports it: `where: blind from t=A to t=B (C s): cause (N rows): detail`
// ("from t=A" while open, "at t=A" for a point).
std::string describe_blind_span(const BlindSpan& span);

// The end-of-run summary of the blind spans (empty when none): one line per kept span with its
// cause and times, the count of the others, and the share of `seconds` (the time the rows
// cover, s) that was blind.
std::string format_blind_summary(const BlindWatch& watch, double seconds);

struct StreamDetectorSummary {
  // False when the run ended before detecting (a signal before the header) or when the
  // reader of the output went away (the rows up to then were detected on).
  bool finished = false;
  bool output_closed = false;  // the output's reader went away (a closed pipe)
  bool interrupted = false;    // SIGINT/SIGTERM ended the input
  int signal = 0;              // which, when interrupted
  std::uint64_t rows = 0;          // rows detected on
  // Time the rows cover, s: the sum of their time steps (a clock step adds none), so that a
  // count of events can be set against a false-alarm rate per hour.
  double seconds = 0;
  std::uint64_t rows_skipped = 0;  // bad rows the reader skipped
  std::uint64_t events = 0;
  std::uint64_t collisions = 0;    // onsets written
  // Time of the first and last rows detected on, s (NaN without rows): where a run that was
  // stopped (a signal, a closed output) stopped.
  double t_first = NAN, t_last = NAN;
  // Spans in which the detector could not judge: how many, per cause, their sum (s, stream
  // time) and their share of `seconds` (0 when the rows cover no time; then of the rows).
  std::uint64_t blind_spans = 0;
  std::uint64_t blind_per_cause[kBlindCauses] = {};
  double blind_seconds = 0, blind_share = 0;
  // The end-of-run summary of the spans (format_blind_summary).
  std::string blind_text;
  // Per joint, rows at rest; empty when the stream has no dq columns.
  std::vector<std::uint64_t> rest_rows;
  // Time spent per row, us.
  double latency_median = 0, latency_p99 = 0, latency_max = 0;  // with measure_latency
  // The --on-collision command: whether given, commands started, those that failed, and
  // those dropped because its queue was full.
  bool on_collision = false;
  std::uint64_t hooks_run = 0, hooks_failed = 0, hooks_dropped = 0;
  // Every hook (--on-collision, --on-contact, --on-blind): commands dropped, and failures.
  std::uint64_t all_hooks_dropped = 0, all_hooks_failed = 0;
};

// The run's statistics, lines of `tool: ...` (mo-detect --stats).
std::string format_stream_detector_stats(const StreamDetectorSummary& summary, std::string_view tool);

class StreamDetector {
 public:
  // Throws momentum::Error when `options` are not valid.
  explicit StreamDetector(StreamDetectorOptions options);

  // Detects on the stream at `input` ("-": standard input) to its end or to SIGINT/SIGTERM.
  // Warns (momentum::warn) when the thresholds need dq the stream lacks, when the chain cannot
  // be built (events then go without identification), and for every blind span (BlindWatch:
  // the first ten as they happen, summed up in summary.blind_text); a clock step back starts
  // the detector again as on a new log; a row whose time goes backwards is rejected
  // (Reader::reject_row). Throws momentum::Error when the input cannot be read (standard input
  // closed, for one), lacks t or the signal's columns, when the profile has no thresholds for
  // the signal or thresholds for another joint count, when rest is judged on r and the stream
  // has none, and what the writers throw but a closed pipe (summary.output_closed).
  StreamDetectorSummary run(const std::string& input);

 private:
  StreamDetectorOptions options_;
};

}  // namespace momentum::drivers
