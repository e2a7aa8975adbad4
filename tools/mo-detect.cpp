// mo-detect: collision events from residuals, live or on recorded logs. Exit status as grep:
// 0 no collision, 1 collision, 2 error.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <optional>

#include "momentum/cli/tool.hpp"
#include "momentum/contact/event_contact.hpp"
#include "momentum/detect/calibration.hpp"
#include "momentum/detect/detector.hpp"
#include "momentum/detect/events_json.hpp"
#include "momentum/detect/live.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/stream/columns.hpp"
#include "momentum/stream/error.hpp"
#include "momentum/core/number.hpp"

using namespace momentum;

namespace {

// 3: the input held no row at all, so nothing was checked (a warning says so).
constexpr int kNoCollision = 0, kCollision = 1, kError = 2, kNoRows = 3;

detect::Thresholds choose_thresholds(const cli::Tool& tool, detect::Signal signal, const std::string& list,
                                     std::size_t joints) {
  if (!list.empty()) return detect::constant_thresholds(signal, cli::parse_number_list(list, "--threshold"), joints);
  if (tool.profile().empty()) throw cli::UsageError("give a profile (-p) or --threshold");
  const auto profile = model::load_profile(tool.profile());
  auto thresholds = detect::thresholds_from_profile(profile.document, signal, tool.profile());
  const std::string name(detect::signal_name(signal));
  if (!thresholds)
    throw Error(tool.profile() + ": no thresholds for " + name + " (run mo-calibrate on " + name +
                " residuals, or give --threshold)");
  if (thresholds->joints.size() != joints)
    throw Error(tool.profile() + ": thresholds for " + std::to_string(thresholds->joints.size()) +
                " joints, the stream has " + std::to_string(joints) + " " + name + " columns");
  return *thresholds;
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("mo-detect", "Collision events from residuals; exit status 1 when any (0 none, 2 error).");
  tool.app().footer("\nExample:\n  mo-observe -p arm.json log.bin | mo-detect -p arm.json > events.csv\n\nMore: man mo-detect");
  tool.add_inputs("input stream (- or none: stdin)");
  tool.add_stream_output();
  tool.add_profile(/*required=*/false);
  std::string signal_option, threshold_list, events_path, command, contact_command;
  bool constant = false, pass = false, stats = false, no_identify = false, any_class = false;
  detect::DetectorOptions options;
  double onset_band = 0;
  auto& app = tool.app();
  app.add_option("--signal", signal_option, "mu or r (default: mu when present, else r)")
      ->check(CLI::IsMember({"mu", "r"}));
  app.add_option("--threshold", threshold_list, "constant thresholds in Nm: one, or one per joint")->type_name("LIST");
  app.add_flag("--constant", constant, "ignore the profile's velocity envelopes");
  app.add_option("--min-samples", options.min_samples, "consecutive rows over the threshold to fire (default 1)")
      ->type_name("N")
      ->check(CLI::PositiveNumber);
  app.add_option("--release", options.release, "a joint is back under its band or this fraction of its threshold (0.5)")
      ->type_name("FRACTION");
  app.add_option("--hold", options.hold, "an event ends when every joint has been back this long, s (0.2)")
      ->type_name("SECONDS");
  app.add_option("--join", options.join, "a joint firing this long after the onset starts a new event, s (0.25)")
      ->type_name("SECONDS");
  auto* band_option = app.add_option("--onset-band", onset_band, "onset band as a fraction of the threshold")
                          ->type_name("FRACTION");
  app.add_option("--skip", options.skip, "seconds at the start of the stream that do not count (0)")
      ->type_name("SECONDS");
  app.add_flag("--pass", pass, "pass the stream through with a collision column instead of events");
  app.add_option("--events", events_path, "with --pass: also write the events to FILE")->type_name("FILE");
  app.add_option("--on-collision", command, "run CMD (sh -c) per collision once classified, without waiting")
      ->type_name("CMD");
  app.add_option("--on-contact", contact_command, "run CMD (sh -c) per contact once classified")->type_name("CMD");
  app.add_flag("--any-class", any_class, "--on-collision runs for every event at its detection");
  app.add_flag("--no-identify", no_identify, "no contact point, force or class (not even with a model and q)");
  contact::LocatorOptions locator;
  app.add_option("--link-radius", locator.link_radius, "radius of the links searched for the contact point, m (0.05)")
      ->type_name("M");
  app.add_flag("--stats", stats, "print rows, events and per-row latency on stderr at the end");
  std::string format = "csv";
  app.add_option("--format", format, "events as csv (default) or jsonl: one JSON object per row")
      ->check(CLI::IsMember({"csv", "jsonl"}));

  // Skipped rows do not change the status (1 means a collision here); they are summed up.
  tool.set_skipped_rows_status(std::nullopt);
  tool.set_error_status(kError);
  tool.set_no_rows_policy(true, kNoRows, /*warning=*/true);
  std::uint64_t collisions = 0;
  const int status = tool.run(argc, argv, [&]() -> int {
    try {
      if (tool.inputs().size() > 1) throw cli::UsageError("one input stream at a time");
      if (!events_path.empty() && !pass) throw cli::UsageError("--events goes with --pass (events are the output)");
      if (*band_option) options.onset_band = onset_band;
      options.use_envelope = !constant;
      std::string why;
      if (!options.IsValid(&why)) throw cli::UsageError(why);
      if (!locator.IsValid(&why)) throw cli::UsageError("--link-radius: " + why);

      const std::string path = tool.inputs().empty() ? "-" : tool.inputs().front();
      // To wake up on SIGINT/SIGTERM while the input is quiet, the reads of a pipe wait in
      // poll() on the input and the signal pipe.
      int poll_fd = -1;
      struct stat st {};
      if (path == "-") poll_fd = 0;
      else if (::stat(path.c_str(), &st) == 0 && (S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode))) poll_fd = -2;
      stream::ReaderOptions reader_options;
      std::string open_path = path;
      int own_fd = -1;
      if (poll_fd == -2) {
        own_fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (own_fd < 0) throw Error(path + ": cannot open: " + std::strerror(errno));
        poll_fd = own_fd;
        open_path = "/dev/fd/" + std::to_string(own_fd);
        reader_options.display_name = path;
      }
      detect::InterruptWatch watch;
      // A live input may stay silent before its header too (a capture that has not started).
      reader_options.before_read = [poll_fd, &watch] {
        if (poll_fd >= 0 && !watch.wait_readable(poll_fd)) throw detect::Interrupted();
      };
      std::unique_ptr<stream::Reader> in;
      try {
        in = tool.open_input(open_path, reader_options);
      } catch (const detect::Interrupted&) {
        if (own_fd >= 0) ::close(own_fd);
        return kNoCollision;
      }

      const std::size_t it = in->require("t");
      detect::Signal signal = detect::Signal::mu;
      if (!signal_option.empty()) signal = detect::parse_signal(signal_option);
      else if (!in->find("mu1") && in->find("r1")) signal = detect::Signal::r;
      const std::string prefix(detect::signal_name(signal));
      const std::size_t n = stream::count_joint_columns(in->columns(), prefix);
      if (n == 0) throw Error(in->name() + ": missing column '" + prefix + "1'");
      const auto ix = stream::column_indices(in->columns(), stream::joint_columns(prefix, n), in->name());
      std::vector<std::size_t> idq;
      if (stream::count_joint_columns(in->columns(), "dq") >= n)
        idq = stream::column_indices(in->columns(), stream::joint_columns("dq", n), in->name());
      const detect::Thresholds thresholds = choose_thresholds(tool, signal, threshold_list, n);
      bool needs_velocity = false;
      for (const auto& J : thresholds.joints) needs_velocity = needs_velocity || J.rest || (J.envelope && !constant);
      if (needs_velocity && idq.empty())
        warn(in->name() + ": no dq1..dq" + std::to_string(n) +
             " columns: the rest state and velocity envelopes are off, constant moving thresholds throughout");
      // Thresholds calibrated on r at rest need the r columns beside mu.
      std::vector<std::size_t> irest;
      if (thresholds.rest_raw && signal == detect::Signal::mu) {
        if (stream::count_joint_columns(in->columns(), "r") < n)
          throw Error(in->name() + ": the profile's thresholds judge rest on r1..r" + std::to_string(n) +
                      ", which the stream does not have (mo-calibrate --rest-signal mu calibrates rest on mu)");
        irest = stream::column_indices(in->columns(), stream::joint_columns("r", n), in->name());
      }
      detect::Detector detector(thresholds, options, !idq.empty());

      // Identification needs the chain (the profile's URDF) and the joint positions.
      std::optional<model::Model> chain;
      std::optional<contact::EventContact> identify;
      std::vector<std::size_t> iq;
      if (!no_identify && !tool.profile().empty() && stream::count_joint_columns(in->columns(), "q") >= n) {
        const auto profile = model::load_profile(tool.profile());
        // Detection does not depend on identification: a chain that cannot be built costs only it.
        try {
          chain.emplace(model::build_model(profile));
        } catch (const Error& e) {
          warn(std::string(e.what()) + ": events without identification");
        }
        if (chain) {
          if (static_cast<std::size_t>(chain->nq) == n) {
            iq = stream::column_indices(in->columns(), stream::joint_columns("q", n), in->name());
            identify.emplace(*chain, thresholds, contact::rule_from_profile(profile.document, prefix, n, tool.profile()),
                             locator);
          }
        }
      }

      std::unique_ptr<stream::Writer> passed;
      std::unique_ptr<detect::EventWriter> events;
      std::unique_ptr<detect::JsonLinesWriter> json_events;
      const bool jsonl = format == "jsonl";
      const nlohmann::json identity =
          jsonl && !tool.profile().empty()
              ? detect::profile_identity(model::load_profile(tool.profile()).document, tool.profile())
              : nlohmann::json(nullptr);
      auto write_event = [&](const detect::Event& e) {
        if (events) events->write(e);
        if (json_events) json_events->write(detect::event_json(e, in->name(), identity, thresholds));
      };
      std::vector<std::string> comments = in->leading_comments();
      comments.push_back(tool.provenance());
      if (pass) {
        passed = tool.open_output(*in);
        auto columns = in->columns();
        columns.push_back("collision");
        passed->header(columns);
        stream::Writer* raw = passed.get();
        in->on_comment([raw](std::string_view c) { raw->comment(c); });
        if (!events_path.empty() && jsonl) json_events = std::make_unique<detect::JsonLinesWriter>(events_path);
        else if (!events_path.empty())
          events = std::make_unique<detect::EventWriter>(events_path, n, comments, identify.has_value());
      } else if (jsonl) {
        json_events = std::make_unique<detect::JsonLinesWriter>(tool.output());
      } else {
        events = std::make_unique<detect::EventWriter>(tool.output(), n, comments, identify.has_value());
      }
      stream::Writer* raw = passed.get();
      in->before_read([raw, poll_fd, &watch] {
        if (raw && raw->interactive()) raw->flush();
        if (poll_fd >= 0 && !watch.wait_readable(poll_fd)) throw detect::Interrupted();
      });
      std::optional<detect::CommandRunner> runner, contact_runner;
      if (!command.empty()) runner.emplace(command);
      if (!contact_command.empty()) contact_runner.emplace(contact_command);
      // Without a class rule every event counts as a collision for the hook, at detection.
      const bool hooks_on_class = identify && identify->classifies() && !any_class;
      detect::Event open_event;

      detect::LogHistogram latency(1e-3, 1e7, 200);
      std::vector<double> x(n), dq(n), x_rest(n), q(n), out(in->columns().size() + 1);
      double t_prev = -INFINITY;
      bool interrupted = false;
      using clock = std::chrono::steady_clock;
      for (;;) {
        const double* row = nullptr;
        try {
          row = in->next();
        } catch (const detect::Interrupted&) {
          // Read nothing more, but detect on the rows already read (the time policy may hold
          // a row or two at the start or around a fault).
          interrupted = true;
          in->stop();
          continue;
        }
        if (!row) break;
        const auto start = clock::now();
        const double t = row[it];
        if (in->time_mark() == stream::TimeMark::clock_step) {
          // The stream's time policy kept this row as the start of a new time line.
          warn(in->where() + ": the clock stepped back from t=" + core::exact(t_prev) + " to t=" +
               core::exact(t) + ": detection goes on");
          t_prev = -INFINITY;
        }
        if (!(t >= t_prev)) {
          in->reject_row(std::isnan(t) ? "time is nan" : "time goes backwards");
          continue;
        }
        t_prev = t;
        for (std::size_t j = 0; j < n; ++j) x[j] = row[ix[j]];
        for (std::size_t j = 0; j < idq.size(); ++j) dq[j] = row[idq[j]];
        for (std::size_t j = 0; j < irest.size(); ++j) x_rest[j] = row[irest[j]];
        for (std::size_t j = 0; j < iq.size(); ++j) q[j] = row[iq[j]];
        if (identify) identify->add(t, q.data(), x.data(), idq.empty() ? nullptr : dq.data());
        for (detect::Event e : detector.step(t, x.data(), dq.data(), irest.empty() ? nullptr : x_rest.data())) {
          if (identify) identify->annotate(e);
          write_event(e);
          if (e.kind == detect::EventKind::onset) {
            ++collisions;
            open_event = e;
            if (runner && !hooks_on_class) runner->launch(e);
          }
        }
        if (hooks_on_class) {
          if (const auto decided = identify->decide()) {
            open_event.contact.event_class = std::string(contact::class_name(*decided));
            auto& hook = *decided == contact::EventClass::collision ? runner : contact_runner;
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
        latency.add(std::chrono::duration<double, std::micro>(clock::now() - start).count());
        if (watch.signal() != 0) {  // stop reading; rows already read are still detected on
          interrupted = true;
          in->stop();
        }
      }
      if (const detect::Event* e = detector.finish(interrupted ? detect::EndReason::signal : detect::EndReason::eof)) {
        write_event(*e);
      }
      if (passed) passed->close();
      if (runner) runner->wait_all();
      if (contact_runner) contact_runner->wait_all();
      if (own_fd >= 0) ::close(own_fd);
      if (stats) {
        std::fprintf(stderr, "mo-detect: %" PRIu64 " rows, %" PRIu64 " bad rows skipped, %" PRIu64 " events%s\n",
                     detector.rows(), in->rows_skipped(), detector.events(), interrupted ? " (interrupted)" : "");
        if (!idq.empty()) {
          std::fprintf(stderr, "mo-detect: rows at rest per joint:");
          for (std::size_t j = 0; j < n; ++j) std::fprintf(stderr, " %" PRIu64, detector.rest_rows(j));
          std::fputc('\n', stderr);
        }
        std::fprintf(stderr, "mo-detect: latency per row: median %.3g us, p99 %.3g us, max %.3g us\n",
                     latency.quantile(0.5), latency.quantile(0.99), latency.max());
        if (runner)
          std::fprintf(stderr, "mo-detect: --on-collision: %" PRIu64 " run, %" PRIu64 " failed\n", runner->launched(),
                       runner->failures());
      }
      return collisions > 0 ? kCollision : kNoCollision;
    } catch (const cli::UsageError&) {
      throw;
    } catch (const stream::BrokenPipe&) {
      return collisions > 0 ? kCollision : kNoCollision;
    } catch (const std::exception& e) {
      // cli::Tool maps runtime errors to 1, which here means "collision": errors are 2.
      std::cerr << "mo-detect: error: " << e.what() << "\n";
      return kError;
    }
  });
  return status;
}
