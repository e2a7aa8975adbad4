#include "momentum/detect/stream_detector.hpp"

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

#include "momentum/core/number.hpp"
#include "momentum/detect/calibration.hpp"
#include "momentum/detect/events_json.hpp"
#include "momentum/detect/friction_band.hpp"
#include "momentum/detect/live.hpp"
#include "momentum/stream/columns.hpp"
#include "momentum/stream/error.hpp"

namespace momentum::detect {
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
// descriptor can be polled.
class LiveInput {
 public:
  explicit LiveInput(const std::string& path) : open_path_(path) {
    struct stat st {};
    if (path == "-") {
      poll_fd_ = 0;
    } else if (::stat(path.c_str(), &st) == 0 && (S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode))) {
      own_fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
      if (own_fd_ < 0) throw Error(path + ": cannot open: " + std::strerror(errno));
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
  // Waits for input; throws Interrupted when a signal arrived first.
  void wait(const InterruptWatch& watch) const {
    if (poll_fd_ >= 0 && !watch.wait_readable(poll_fd_)) throw Interrupted();
  }

 private:
  std::string open_path_, display_name_;
  int poll_fd_ = -1, own_fd_ = -1;
};

}  // namespace

bool StreamDetectorOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  if (!events_path.empty() && !pass) return fail("--events goes with --pass (events are the output)");
  if (!detector.IsValid(why)) return false;
  if (constant_thresholds.empty() && profile_path.empty()) return fail("give a profile (-p) or --threshold");
  if (pass && !open_output) return fail("pass needs open_output");
  return true;
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
  if (summary.on_collision) {
    std::snprintf(line, sizeof line, "%s: --on-collision: %" PRIu64 " run, %" PRIu64 " failed\n", name.c_str(),
                  summary.hooks_run, summary.hooks_failed);
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
    Detector detector(thresholds, detector_options, !idq.empty());

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
    stream::Writer* raw = passed.get();
    in->before_read([raw, &live, &watch] {
      if (raw && raw->interactive()) raw->flush();
      live.wait(watch);
    });
    std::optional<CommandRunner> runner, contact_runner;
    if (!o.on_collision.empty()) runner.emplace(o.on_collision);
    if (!o.on_contact.empty()) contact_runner.emplace(o.on_contact);
    // Without a class rule every event counts as a collision for the hook, at detection.
    const bool hooks_on_class = identify && identify->classifies() && !o.any_class;
    Event open_event;

    LogHistogram latency(1e-3, 1e7, 200);
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
      if (in->time_mark() == stream::TimeMark::clock_step) {
        // The stream's time policy kept this row as the start of a new time line.
        warn(in->where() + ": the clock stepped back from t=" + core::exact(t_prev) + " to t=" + core::exact(t) +
             ": detection goes on");
        t_prev = -INFINITY;
      }
      if (!(t >= t_prev)) {
        in->reject_row(std::isnan(t) ? "time is nan" : "time goes backwards");
        continue;
      }
      if (std::isfinite(t_prev)) summary.seconds += t - t_prev;
      t_prev = t;
      for (std::size_t j = 0; j < n; ++j) x[j] = row[ix[j]];
      for (std::size_t j = 0; j < idq.size(); ++j) dq[j] = row[idq[j]];
      for (std::size_t j = 0; j < irest.size(); ++j) x_rest[j] = row[irest[j]];
      for (std::size_t j = 0; j < iq.size(); ++j) q[j] = row[iq[j]];
      if (identify) identify->add(t, q.data(), x.data(), idq.empty() ? nullptr : dq.data());
      for (Event e : detector.step(t, x.data(), dq.data(), irest.empty() ? nullptr : x_rest.data())) {
        if (identify) identify->annotate(e);
        write_event(e);
        if (e.kind == EventKind::onset) {
          ++summary.collisions;
          open_event = e;
          if (runner && !hooks_on_class) runner->launch(e);
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
        out.back() = detector.open_link();
        passed->row(out.data());
      }
      if (runner && runner->running()) runner->reap();
      if (contact_runner && contact_runner->running()) contact_runner->reap();
      if (o.measure_latency) latency.add(std::chrono::duration<double, std::micro>(clock::now() - start).count());
      if (watch.signal() != 0) {  // stop reading; rows already read are still detected on
        summary.interrupted = true;
        in->stop();
      }
    }
    if (const Event* e = detector.finish(summary.interrupted ? EndReason::signal : EndReason::eof)) write_event(*e);
    if (passed) passed->close();
    if (runner) runner->wait_all();
    if (contact_runner) contact_runner->wait_all();
    summary.finished = true;
    summary.rows = detector.rows();
    summary.rows_skipped = in->rows_skipped();
    summary.events = detector.events();
    if (!idq.empty())
      for (std::size_t j = 0; j < n; ++j) summary.rest_rows.push_back(detector.rest_rows(j));
    if (o.measure_latency) {
      summary.latency_median = latency.quantile(0.5);
      summary.latency_p99 = latency.quantile(0.99);
      summary.latency_max = latency.max();
    }
    if (runner) {
      summary.on_collision = true;
      summary.hooks_run = runner->launched();
      summary.hooks_failed = runner->failures();
    }
    return summary;
  } catch (const stream::BrokenPipe&) {
    summary.output_closed = true;
    summary.finished = false;
    return summary;
  }
}

}  // namespace momentum::detect
