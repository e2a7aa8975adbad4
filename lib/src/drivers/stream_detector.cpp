#include "momentum/drivers/stream_detector.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "momentum/calibrate/calibration.hpp"
#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/detect/events_json.hpp"
#include "momentum/detect/friction_band.hpp"
#include "momentum/drivers/live.hpp"
#include "momentum/stream/columns.hpp"

namespace momentum::drivers {

// This driver runs the detect stage: its names are this file's vocabulary.
using namespace detect;
using namespace calibrate;
namespace {

Thresholds choose_thresholds(const StreamDetectorOptions& options, const model::Profile* profile, Signal signal,
                             std::size_t joints) {
  if (!options.constant_thresholds.empty()) return constant_thresholds(signal, options.constant_thresholds, joints);
  const std::string& path = options.profile_path;
  auto thresholds = thresholds_from_profile(profile->document, signal, path);
  const std::string name(signal_name(signal));
  if (!thresholds)
    throw Error(path + ": no thresholds for " + name + " (run mo-calibrate on " + name +
                " residuals, or give --threshold)");
  if (thresholds->joints.size() != joints)
    throw Error(path + ": thresholds for " + std::to_string(thresholds->joints.size()) + " joints, the stream has " +
                std::to_string(joints) + " " + name + " columns");
  return *thresholds;
}

// The input and how to wake up on SIGINT/SIGTERM while it is quiet: reads of a pipe wait in
// poll() on the input and the signal pipe. A named pipe or socket is opened here, so that its
// descriptor can be polled; the reader reads that descriptor through /dev/fd/N (core::open_input
// copies it: opened again, the pipe would wait for a writer that may be gone).
class LiveInput {
 public:
  explicit LiveInput(const std::string& path) : open_path_(path) {
    struct stat st {};
    if (core::is_standard_input(path)) {
      // A closed standard input (`<&-`) would make descriptor 0 the next file opened (our own
      // signal pipe, read forever): refuse it before anything is opened.
      if (::fcntl(0, F_GETFD) < 0 && errno == EBADF)
        throw Error("standard input is closed (give an input file, or a stream on standard input)");
      poll_fd_ = 0;
    } else if (::stat(path.c_str(), &st) == 0 && (S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode))) {
      // Opened without waiting for a writer (a blocking open would wait where no signal is
      // watched: SIGINT would end the process there), then read blocking: until a writer
      // comes, poll() in wait() waits for it together with the signals.
      own_fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
      if (own_fd_ < 0) throw Error(path + ": cannot open: " + std::strerror(errno));
      const int flags = ::fcntl(own_fd_, F_GETFL);
      if (flags < 0 || ::fcntl(own_fd_, F_SETFL, flags & ~O_NONBLOCK) != 0) {
        const int saved = errno;
        ::close(own_fd_);
        throw Error(path + ": cannot open: " + std::strerror(saved));
      }
      poll_fd_ = own_fd_;
      open_path_ = "/dev/fd/" + std::to_string(own_fd_);
      display_name_ = path;
    }
  }
  ~LiveInput() {
    if (own_fd_ >= 0) ::close(own_fd_);
  }
  LiveInput(const LiveInput&) = delete;
  LiveInput& operator=(const LiveInput&) = delete;

  const std::string& open_path() const { return open_path_; }
  const std::string& display_name() const { return display_name_; }
  // Waits for input; throws Interrupted when a signal arrived first. With `stall_ms` > 0,
  // calls `stalled` once when nothing came for that long, and waits on.
  void wait(const InterruptWatch& watch, int stall_ms = 0, const std::function<void()>& stalled = {}) const {
    if (poll_fd_ < 0) return;
    if (stall_ms > 0 && stalled) {
      const int ready = watch.wait_readable(poll_fd_, stall_ms);
      if (ready == 0) throw Interrupted();
      if (ready == 1) return;
      stalled();
    }
    if (!watch.wait_readable(poll_fd_)) throw Interrupted();
  }

 private:
  std::string open_path_, display_name_;
  int poll_fd_ = -1, own_fd_ = -1;
};

}  // namespace

bool StreamDetectorOptions::IsValid(std::string* why) const {
  if (!events_path.empty() && !pass) return invalid(why, "--events goes with --pass (events are the output)");
  if (!detector.IsValid(why)) return false;
  if (constant_thresholds.empty() && profile_path.empty()) return invalid(why, "give a profile (-p) or --threshold");
  if (pass && !open_output) return invalid(why, "pass needs open_output");
  if (hook_jobs < 1) return invalid(why, "--hook-jobs must be >= 1");
  if (!(stall >= 0)) return invalid(why, "--stall must be >= 0 s");
  return true;
}

std::string_view blind_cause_name(BlindCause cause) {
  switch (cause) {
    case BlindCause::rows_skipped: return "rows skipped";
    case BlindCause::not_finite: return "residuals not finite";
    case BlindCause::clock_step: return "clock step back";
    case BlindCause::input_stopped: return "input stopped";
  }
  return "?";
}

void BlindWatch::open(BlindSpan& span, BlindCause cause, double t, std::string detail, const std::string& where) {
  span = BlindSpan{};
  span.cause = cause;
  span.t_start = t;
  span.t_end = NAN;
  span.where = where;
  span.detail = std::move(detail);
}

void BlindWatch::close(BlindSpan& span, double t_end) {
  span.t_end = std::isfinite(t_end) ? std::max(t_end, span.t_start) : span.t_start;
  record(span);
}

void BlindWatch::record(const BlindSpan& span) {
  ++spans_;
  ++per_cause_[static_cast<std::size_t>(span.cause)];
  seconds_ += span.seconds();
  rows_ += span.rows;
  if (kept_spans_.size() < kept_) kept_spans_.push_back(span);
  if (report_) report_(span, true);
}

bool BlindWatch::row(double t, std::uint64_t skipped, std::string_view not_finite, const std::string& where) {
  if (stopped_) {  // a quiet input delivers again: the span reaches to this row
    close(*stopped_, t);
    stopped_.reset();
  }
  if (skipped > 0) {
    // The skipped rows lie between the last row and this one (before the first row: a point).
    BlindSpan span;
    open(span, BlindCause::rows_skipped, std::isfinite(t_last_) ? t_last_ : t, "", where);
    span.rows = skipped;
    close(span, t);
  }
  if (!not_finite.empty()) {
    if (!not_finite_) {
      not_finite_.emplace();
      open(*not_finite_, BlindCause::not_finite, t, std::string(not_finite), where);
      not_finite_->opened = true;
      if (report_) report_(*not_finite_, false);
    }
    ++not_finite_->rows;
  } else if (not_finite_) {
    close(*not_finite_, t);
    not_finite_.reset();
  }
  t_last_ = t;
  return not_finite.empty();
}

void BlindWatch::clock_step(double t_before, double t, double settle, const std::string& where) {
  // Spans on the old time line end with it: their length is measured on one clock.
  if (not_finite_) {
    close(*not_finite_, t_before);
    not_finite_.reset();
  }
  if (stopped_) {
    close(*stopped_, t_before);
    stopped_.reset();
  }
  BlindSpan span;
  open(span, BlindCause::clock_step, t, "the clock stepped back from t=" + core::exact(t_before) + " to t=" + core::exact(t),
       where);
  close(span, t + settle);
  t_last_ = NAN;
}

void BlindWatch::input_stopped(double t_last, const std::string& detail, const std::string& where) {
  if (stopped_) return;
  stopped_.emplace();
  open(*stopped_, BlindCause::input_stopped, t_last, detail, where);
  stopped_->opened = true;
  if (report_) report_(*stopped_, false);
}

void BlindWatch::finish(std::uint64_t skipped, const std::string& where) {
  if (not_finite_) {
    close(*not_finite_, t_last_);
    not_finite_.reset();
  }
  if (stopped_) {
    close(*stopped_, t_last_);
    stopped_.reset();
  }
  if (skipped > 0) {
    // Rows cut or bad after the last good one: how long the input would have gone on is unknown.
    BlindSpan span;
    open(span, BlindCause::input_stopped, t_last_, "the input ends in " + std::to_string(skipped) + " bad row" +
                                                       (skipped == 1 ? "" : "s"),
         where);
    span.rows = skipped;
    close(span, t_last_);
  }
}

namespace {

std::string span_times(const BlindSpan& span) {
  if (!std::isfinite(span.t_start)) return "before the first row";
  if (!std::isfinite(span.t_end)) return "from t=" + core::exact(span.t_start);
  if (span.t_end == span.t_start) return "at t=" + core::exact(span.t_start);
  return "from t=" + core::exact(span.t_start) + " to t=" + core::exact(span.t_end) + " (" +
         core::significant(span.seconds(), 3) + " s)";
}

}  // namespace

// One line for a span: `where: blind from t=A to t=B (C s): cause: detail`.
std::string describe_blind_span(const BlindSpan& span) {
  std::string text = span.where + ": blind " + span_times(span) + ": " + std::string(blind_cause_name(span.cause));
  if (span.rows > 0 && span.cause != BlindCause::not_finite)
    text += " (" + std::to_string(span.rows) + " row" + (span.rows == 1 ? "" : "s") + ")";
  if (!span.detail.empty()) text += ": " + span.detail;
  if (span.cause == BlindCause::not_finite && std::isfinite(span.t_end))
    text += " on " + std::to_string(span.rows) + " row" + (span.rows == 1 ? "" : "s");
  return text;
}

namespace {

double blind_share(const BlindWatch& watch, double seconds, std::uint64_t rows) {
  if (seconds > 0) return std::min(1.0, watch.seconds() / seconds);
  return rows > 0 ? std::min(1.0, static_cast<double>(watch.rows()) / static_cast<double>(rows)) : 0.0;
}

}  // namespace

std::string format_blind_summary(const BlindWatch& watch, double seconds) {
  if (watch.spans() == 0) return "";
  std::string text = "blind " + std::to_string(watch.spans()) + " time" + (watch.spans() == 1 ? "" : "s") + " for " +
                     core::significant(watch.seconds(), 3) + " s of " + core::significant(seconds, 6) + " s (";
  char share[32];
  std::snprintf(share, sizeof share, "%.3g%%", 100.0 * (seconds > 0 ? std::min(1.0, watch.seconds() / seconds) : 0.0));
  text += share;
  text += "):";
  bool first = true;
  for (std::size_t c = 0; c < kBlindCauses; ++c) {
    const auto cause = static_cast<BlindCause>(c);
    if (watch.spans(cause) == 0) continue;
    text += std::string(first ? " " : ", ") + std::to_string(watch.spans(cause)) + " " + std::string(blind_cause_name(cause));
    first = false;
  }
  for (const BlindSpan& span : watch.kept()) text += "\n  " + span_times(span) + ": " + std::string(blind_cause_name(span.cause));
  if (watch.spans() > watch.kept().size())
    text += "\n  and " + std::to_string(watch.spans() - watch.kept().size()) + " more";
  return text;
}

StreamDetector::StreamDetector(StreamDetectorOptions options) : options_(std::move(options)) {
  std::string why;
  if (!options_.IsValid(&why)) throw Error(why);
}

std::string format_stream_detector_stats(const StreamDetectorSummary& summary, std::string_view tool) {
  const std::string name(tool);
  char line[256];
  std::string text;
  std::snprintf(line, sizeof line, "%s: %" PRIu64 " rows over %s s, %" PRIu64 " bad rows skipped, %" PRIu64 " events%s\n",
                name.c_str(), summary.rows, core::significant(summary.seconds, 6).c_str(), summary.rows_skipped, summary.events,
                summary.interrupted ? " (interrupted)" : "");
  text += line;
  if (!summary.rest_rows.empty()) {
    text += name + ": rows at rest per joint:";
    for (std::uint64_t rows : summary.rest_rows) text += " " + std::to_string(rows);
    text += "\n";
  }
  std::snprintf(line, sizeof line, "%s: latency per row: median %.3g us, p99 %.3g us, max %.3g us\n", name.c_str(),
                summary.latency_median, summary.latency_p99, summary.latency_max);
  text += line;
  std::snprintf(line, sizeof line, "%s: %" PRIu64 " blind spans over %s s (%.3g%%):", name.c_str(), summary.blind_spans,
                core::significant(summary.blind_seconds, 3).c_str(), 100.0 * summary.blind_share);
  text += line;
  for (std::size_t c = 0; c < kBlindCauses; ++c)
    text += std::string(c == 0 ? " " : ", ") + std::to_string(summary.blind_per_cause[c]) + " " +
            std::string(blind_cause_name(static_cast<BlindCause>(c)));
  text += "\n";
  if (summary.on_collision) {
    std::snprintf(line, sizeof line, "%s: --on-collision: %" PRIu64 " run, %" PRIu64 " failed, %" PRIu64 " dropped\n",
                  name.c_str(), summary.hooks_run - summary.hooks_dropped, summary.hooks_failed, summary.hooks_dropped);
    text += line;
  }
  return text;
}

StreamDetectorSummary StreamDetector::run(const std::string& input) {
  const StreamDetectorOptions& o = options_;
  StreamDetectorSummary summary;
  try {
    LiveInput live(input);
    InterruptWatch watch;
    stream::ReaderOptions reader_options;
    reader_options.display_name = live.display_name();
    // A live input may stay silent before its header too (a capture that has not started).
    reader_options.before_read = [&live, &watch] { live.wait(watch); };
    std::unique_ptr<stream::Reader> in;
    try {
      in = o.open_input ? o.open_input(live.open_path(), reader_options)
                        : stream::Reader::open(live.open_path(), reader_options);
    } catch (const Interrupted&) {
      summary.interrupted = true;
      summary.signal = watch.signal();
      return summary;
    }

    const std::size_t it = in->require("t");
    Signal signal = Signal::mu;
    if (o.signal) signal = *o.signal;
    else if (!in->find("mu1") && in->find("r1")) signal = Signal::r;
    const std::string prefix(signal_name(signal));
    const std::size_t n = stream::count_joint_columns(in->columns(), prefix);
    if (n == 0) throw Error(in->name() + ": missing column '" + prefix + "1'");
    const auto ix = stream::column_indices(in->columns(), stream::joint_columns(prefix, n), in->name());
    std::vector<std::size_t> idq;
    if (stream::count_joint_columns(in->columns(), "dq") >= n)
      idq = stream::column_indices(in->columns(), stream::joint_columns("dq", n), in->name());
    // The profile is read when first needed: a --threshold run may not need it at all.
    std::optional<model::Profile> loaded;
    auto profile = [&]() -> const model::Profile* {
      if (!loaded && !o.profile_path.empty()) loaded = model::load_profile(o.profile_path);
      return loaded ? &*loaded : nullptr;
    };
    const Thresholds thresholds = choose_thresholds(o, o.constant_thresholds.empty() ? profile() : nullptr, signal, n);
    bool needs_velocity = false;
    for (const auto& J : thresholds.joints)
      needs_velocity = needs_velocity || J.rest || (J.envelope && o.detector.use_envelope);
    if (needs_velocity && idq.empty())
      warn(in->name() + ": no dq1..dq" + std::to_string(n) +
           " columns: the rest state and velocity envelopes are off, constant moving thresholds throughout");
    // Thresholds calibrated on r at rest need the r columns beside mu.
    std::vector<std::size_t> irest;
    if (thresholds.rest_raw && signal == Signal::mu) {
      if (stream::count_joint_columns(in->columns(), "r") < n)
        throw Error(in->name() + ": the profile's thresholds judge rest on r1..r" + std::to_string(n) +
                    ", which the stream does not have (mo-calibrate --rest-signal mu calibrates rest on mu)");
      irest = stream::column_indices(in->columns(), stream::joint_columns("r", n), in->name());
    }
    DetectorOptions detector_options = o.detector;
    if (thresholds.friction_band > 0 && signal == Signal::mu && profile()) {
      detector_options.friction_band =
          friction_band_from_profile(profile()->document, thresholds.friction_band, o.profile_path);
      if (detector_options.friction_band.empty())
        warn(o.profile_path + ": the thresholds were calibrated beyond the friction model's band, but the friction "
             "section holds no covariance: moving thresholds without it");
    }
    // A clock step back starts a new log: the detector is built again (its start-up skip, rest
    // trackers and hold timers count from the new time line), as mo-calibrate counts the rows
    // after a step as a log of their own. Event numbers and counts go on over the whole input.
    std::optional<Detector> detector;
    detector.emplace(thresholds, detector_options, !idq.empty());
    std::uint64_t rows_before = 0, events_before = 0;
    std::vector<std::uint64_t> rest_rows_before(n, 0);

    // Identification needs the chain (the profile's URDF) and the joint positions.
    std::optional<model::Model> chain;
    std::unique_ptr<EventAnnotator> identify;
    std::vector<std::size_t> iq;
    if (o.annotator && !o.profile_path.empty() && stream::count_joint_columns(in->columns(), "q") >= n) {
      // Detection does not depend on identification: a chain that cannot be built costs only it.
      const model::Profile& chain_profile = *profile();
      try {
        chain.emplace(model::build_model(chain_profile));
      } catch (const Error& e) {
        warn(std::string(e.what()) + ": events without identification");
      }
      if (chain && static_cast<std::size_t>(chain->nq) == n) {
        iq = stream::column_indices(in->columns(), stream::joint_columns("q", n), in->name());
        identify = o.annotator(*chain, chain_profile, thresholds, detector_options.friction_band);
      }
    }

    std::unique_ptr<stream::Writer> passed;
    std::unique_ptr<EventWriter> events;
    std::unique_ptr<JsonLinesWriter> json_events;
    const bool jsonl = o.format == EventFormat::jsonl;
    const nlohmann::json identity =
        jsonl && !o.profile_path.empty() ? profile_identity(profile()->document, o.profile_path) : nlohmann::json(nullptr);
    auto write_event = [&](const Event& e) {
      if (events) events->write(e);
      if (json_events) json_events->write(event_json(e, in->name(), identity, thresholds));
    };
    std::vector<std::string> comments = in->leading_comments();
    comments.insert(comments.end(), o.comments.begin(), o.comments.end());
    if (o.pass) {
      passed = o.open_output(*in);
      auto columns = in->columns();
      columns.push_back("collision");
      passed->header(columns);
      stream::Writer* raw = passed.get();
      in->on_comment([raw](std::string_view c) { raw->comment(c); });
      if (!o.events_path.empty() && jsonl) json_events = std::make_unique<JsonLinesWriter>(o.events_path);
      else if (!o.events_path.empty())
        events = std::make_unique<EventWriter>(o.events_path, n, comments, identify != nullptr);
    } else if (jsonl) {
      json_events = std::make_unique<JsonLinesWriter>(o.output);
    } else {
      events = std::make_unique<EventWriter>(o.output, n, comments, identify != nullptr);
    }
    std::optional<CommandRunner> runner, contact_runner, blind_runner;
    if (!o.on_collision.empty()) runner.emplace(o.on_collision, "--on-collision", o.hook_jobs, o.hook_queue);
    if (!o.on_contact.empty()) contact_runner.emplace(o.on_contact, "--on-contact", o.hook_jobs, o.hook_queue);
    if (!o.on_blind.empty()) blind_runner.emplace(o.on_blind, "--on-blind", o.hook_jobs, o.hook_queue);
    // Spans in which nothing could be judged are reported as they happen: the first kShownSpans
    // one by one, the rest in the summary at the end; the --on-blind hook runs for every one.
    constexpr std::uint64_t kShownSpans = 10;
    std::uint64_t spans_reported = 0;
    BlindWatch blind([&](const BlindSpan& span, bool ended) {
      // The warning first: a hook's own output follows it.
      if (!ended || ++spans_reported <= kShownSpans) {
        if (spans_reported <= kShownSpans) {
          const bool partial = !ended && span.cause == BlindCause::not_finite;
          warn(describe_blind_span(span) + (partial ? ": detection goes on where it can" : ""));
        }
      } else if (spans_reported == kShownSpans + 1) {
        warn("more blind spans are counted, not shown (see the summary at the end)");
      }
      // A span that lasts has its hook when it opens; one known only once complete, now.
      if (blind_runner && (!ended || !span.opened))
        blind_runner->launch({"MOMENTUM_BLIND_CAUSE=" + std::string(blind_cause_name(span.cause)),
                              "MOMENTUM_T_START=" + core::exact(span.t_start),
                              "MOMENTUM_T_END=" + (ended ? core::exact(span.t_end) : std::string()),
                              "MOMENTUM_BLIND_DETAIL=" + span.detail},
                             "blind span at t=" + core::exact(span.t_start));
    });
    // A live input that stays quiet after a row: blind until the next row (--stall).
    stream::Writer* raw = passed.get();
    const int stall_ms = static_cast<int>(std::min(o.stall, 86400.0) * 1000);
    const std::string stall_text = "no row for " + core::significant(o.stall, 3) + " s";
    // A pipe that has delivered the stream well ahead of the wall clock is a recording or a
    // simulation being replayed: a pause of the program writing it (a buffer filling, a busy
    // machine) is not the robot falling silent. Ahead: more than twice the wall time since the
    // first row, plus a second.
    std::chrono::steady_clock::time_point first_row_wall;  // when the first row was read
    in->before_read([&, raw] {
      if (raw && raw->interactive()) raw->flush();
      const bool started = std::isfinite(summary.t_last);
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - first_row_wall).count();
      const bool replay = started && summary.t_last - summary.t_first > 2 * wall + 1.0;
      live.wait(watch, started && !replay ? stall_ms : 0,
                [&] { blind.input_stopped(summary.t_last, stall_text, in->name()); });
    });
    std::uint64_t skipped_seen = 0;
    std::vector<std::string> residual_names = stream::joint_columns(prefix, n);
    std::vector<std::string> rest_names = irest.empty() ? std::vector<std::string>{} : stream::joint_columns("r", n);
    std::string not_finite;
    // Without a class rule every event counts as a collision for the hook, at detection.
    const bool hooks_on_class = identify && identify->classifies() && !o.any_class;
    Event open_event;

    calibrate::LogHistogram latency(1e-3, 1e7, 200);
    std::vector<double> x(n), dq(n), x_rest(n), q(n), out(in->columns().size() + 1);
    double t_prev = -INFINITY;
    using clock = std::chrono::steady_clock;
    for (;;) {
      const double* row = nullptr;
      try {
        row = in->next();
      } catch (const Interrupted&) {
        // Read nothing more, but detect on the rows already read (the time policy may hold
        // a row or two at the start or around a fault).
        summary.interrupted = true;
        in->stop();
        continue;
      }
      if (!row) break;
      const auto start = o.measure_latency ? clock::now() : clock::time_point{};
      const double t = row[it];
      if (in->time_mark() == stream::TimeMark::clock_step && std::isfinite(t_prev)) {
        // The stream's time policy kept this row as the start of a new time line: a new log.
        if (const Event* e = detector->finish(EndReason::clock_step)) {
          Event closed = *e;
          closed.id += events_before;
          write_event(closed);
        }
        rows_before += detector->rows();
        events_before += detector->events();
        if (!idq.empty())
          for (std::size_t j = 0; j < n; ++j) rest_rows_before[j] += detector->rest_rows(j);
        detector.emplace(thresholds, detector_options, !idq.empty());
        if (identify) identify = o.annotator(*chain, *profile(), thresholds, detector_options.friction_band);
        open_event = Event{};
        blind.clock_step(t_prev, t, detector_options.skip, in->where());
        t_prev = -INFINITY;
      }
      if (!in->follows_in_time(t, t_prev)) continue;
      if (std::isfinite(t_prev)) summary.seconds += t - t_prev;
      t_prev = t;
      if (!std::isfinite(summary.t_first)) {
        summary.t_first = t;
        first_row_wall = std::chrono::steady_clock::now();
      }
      summary.t_last = t;
      not_finite.clear();
      for (std::size_t j = 0; j < n; ++j) {
        x[j] = row[ix[j]];
        if (!std::isfinite(x[j])) not_finite += (not_finite.empty() ? "" : ",") + residual_names[j];
      }
      for (std::size_t j = 0; j < idq.size(); ++j) dq[j] = row[idq[j]];
      for (std::size_t j = 0; j < irest.size(); ++j) {
        x_rest[j] = row[irest[j]];
        if (!std::isfinite(x_rest[j])) not_finite += (not_finite.empty() ? "" : ",") + rest_names[j];
      }
      for (std::size_t j = 0; j < iq.size(); ++j) q[j] = row[iq[j]];
      blind.row(t, in->rows_skipped_before() - skipped_seen, not_finite.empty() ? "" : not_finite + " not finite",
                in->where());
      skipped_seen = in->rows_skipped_before();
      if (identify) identify->add(t, q.data(), x.data(), idq.empty() ? nullptr : dq.data());
      bool to_identify = false;
      for (Event e : detector->step(t, x.data(), dq.data(), irest.empty() ? nullptr : x_rest.data())) {
        e.id += events_before;
        if (identify) identify->annotate(e);
        write_event(e);
        if (e.kind == EventKind::onset) {
          ++summary.collisions;
          open_event = e;
          if (runner && !hooks_on_class) runner->launch(e);
          to_identify = identify != nullptr;
        }
      }
      if (hooks_on_class) {
        if (const auto decided = identify->decide()) {
          open_event.contact.event_class = std::string(*decided);
          auto& hook = *decided == "collision" ? runner : contact_runner;
          if (hook) hook->launch(open_event);
        }
      }
      if (passed) {
        std::copy(row, row + in->columns().size(), out.begin());
        out.back() = detector->open_link();
        passed->row(out.data());
      }
      if (to_identify) {
        // Everything this row decided is out (the onset row is flushed as written; a live
        // --pass row now): identification at detection, the slow part, follows in its own row.
        if (raw && raw->interactive()) raw->flush();
        Event identified = open_event;
        identified.kind = EventKind::identified;
        identify->identify(identified);
        write_event(identified);
        open_event.link = identified.link;
        open_event.contact = identified.contact;
      }
      for (auto* hook : {&runner, &contact_runner, &blind_runner})
        if (*hook && (*hook)->busy()) (*hook)->reap();
      if (o.measure_latency) latency.add(std::chrono::duration<double, std::micro>(clock::now() - start).count());
      if (watch.signal() != 0 && !summary.interrupted) {  // stop reading; rows already read are still detected on
        summary.interrupted = true;
        in->stop();
      }
    }
    if (summary.interrupted) summary.signal = watch.signal();
    // Rows skipped after the last row (a cut last row, bad rows at the end): the input stopped.
    blind.finish(in->rows_skipped_before() - skipped_seen, in->name());
    if (const Event* e = detector->finish(summary.interrupted ? EndReason::signal : EndReason::eof)) {
      Event closed = *e;
      closed.id += events_before;
      write_event(closed);
    }
    if (passed) passed->close();
    for (auto* hook : {&runner, &contact_runner, &blind_runner})
      if (*hook) {
        (*hook)->wait_all();
        summary.all_hooks_dropped += (*hook)->dropped();
        summary.all_hooks_failed += (*hook)->failures();
        const std::string report = (*hook)->report();
        if (!report.empty()) warn(report);
      }
    summary.finished = true;
    summary.rows = rows_before + detector->rows();
    summary.rows_skipped = in->rows_skipped();
    summary.events = events_before + detector->events();
    if (!idq.empty())
      for (std::size_t j = 0; j < n; ++j) summary.rest_rows.push_back(rest_rows_before[j] + detector->rest_rows(j));
    summary.blind_spans = blind.spans();
    for (std::size_t c = 0; c < kBlindCauses; ++c) summary.blind_per_cause[c] = blind.spans(static_cast<BlindCause>(c));
    summary.blind_seconds = blind.seconds();
    summary.blind_share = blind_share(blind, summary.seconds, summary.rows);
    summary.blind_text = format_blind_summary(blind, summary.seconds);
    if (o.measure_latency) {
      summary.latency_median = latency.quantile(0.5);
      summary.latency_p99 = latency.quantile(0.99);
      summary.latency_max = latency.max();
    }
    if (runner) {
      summary.on_collision = true;
      summary.hooks_run = runner->launched();
      summary.hooks_failed = runner->failures();
      summary.hooks_dropped = runner->dropped();
    }
    return summary;
  } catch (const stream::BrokenPipe&) {
    summary.output_closed = true;
    summary.finished = false;
    return summary;
  }
}

}  // namespace momentum::drivers
