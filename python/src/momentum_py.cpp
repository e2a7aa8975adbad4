// momentum._core: the Python binding, a thin layer over the library. Each function does what
// one tool's main does (tools/mo-observe.cpp, mo-calibrate.cpp, mo-detect.cpp): the same
// library calls with the same defaults, options under the tools' names. Streams are read and
// written by stream::Reader and stream::Writer, so every encoding the library reads works here.
// The drivers read and write paths; momentum/__init__.py passes arrays through binary streams in
// a temporary folder (exact to the bit) and turns the results back into arrays.
//
// The library's process-wide state (the warning sinks, the run's record of inputs and outputs
// that keeps an output from overwriting an input) is not thread-safe: every call holds one
// mutex while it runs, with the GIL released. Warnings are collected during the call and handed
// back to Python, which issues them as momentum.MomentumWarning.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "momentum/contact/event_contact.hpp"
#include "momentum/core/error.hpp"
#include "momentum/core/file.hpp"
#include "momentum/core/text.hpp"
#include "momentum/drivers/calibrate_streams.hpp"
#include "momentum/drivers/stream_detector.hpp"
#include "momentum/detect/thresholds.hpp"
#include "momentum/friction/friction.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/drivers/observe_stream.hpp"
#include "momentum/stream/format.hpp"
#include "momentum/stream/reader.hpp"
#include "momentum/stream/writer.hpp"
#include "momentum/version.hpp"

namespace py = pybind11;
using namespace momentum;

namespace {

// Thrown for what a tool reports as a usage error (exit status 2): Python's ValueError.
class UsageError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// The warnings of one call: (kind, message); kind is empty for warnings that are not skipped rows.
using Warnings = std::vector<std::pair<std::string, std::string>>;

std::mutex& library_mutex() {
  static std::mutex mutex;
  return mutex;
}

// Runs `work` with the GIL released, the library's mutex held and its warning sinks collecting
// into `warnings`; forgets the inputs and outputs of the call afterwards, as a process that
// ends would, so that the next call may write what this one read.
template <typename Work>
auto run_library(Warnings& warnings, Work&& work) {
  py::gil_scoped_release release;
  std::lock_guard lock(library_mutex());
  core::forget_inputs_and_outputs();
  struct Restore {
    WarningSink warning;
    RowWarningSink row;
    ~Restore() {
      set_warning_sink(std::move(warning));
      set_row_warning_sink(std::move(row));
      core::forget_inputs_and_outputs();
    }
  } restore{set_warning_sink([&](std::string_view m) { warnings.emplace_back("", std::string(m)); }),
            set_row_warning_sink([&](std::string_view kind, std::string_view m) {
              warnings.emplace_back(std::string(kind), std::string(m));
            })};
  return work();
}

py::list warning_list(const Warnings& warnings) {
  py::list out;
  for (const auto& [kind, message] : warnings) out.append(py::make_tuple(kind, message));
  return out;
}

// ---- streams ----------------------------------------------------------------------------------

// Reads a whole stream: (columns, data[columns][rows], leading comments, encoding, warnings).
py::tuple read_stream(const std::string& path, bool strict, const std::vector<std::string>& names,
                      bool time_order, const std::string& display_name) {
  Warnings warnings;
  std::vector<std::string> columns, comments;
  std::string encoding;
  auto by_column = std::make_unique<std::vector<double>>();
  std::size_t rows = 0;
  run_library(warnings, [&] {
    stream::ReaderOptions options;
    options.strict = strict;
    options.names = names;
    options.time_order = time_order;
    options.display_name = display_name;
    auto in = stream::Reader::open(path, options);
    columns = in->columns();
    comments = in->leading_comments();
    encoding = std::string(stream::encoding_name(in->encoding()));
    const std::size_t width = columns.size();
    std::vector<double> by_row;
    while (const double* row = in->next()) {
      by_row.insert(by_row.end(), row, row + width);
      ++rows;
    }
    // One contiguous array per column (the row-major data transposed).
    by_column->resize(by_row.size());
    for (std::size_t r = 0; r < rows; ++r)
      for (std::size_t c = 0; c < width; ++c) (*by_column)[c * rows + r] = by_row[r * width + c];
  });
  const std::size_t width = columns.size();
  auto* owner = by_column.release();
  py::capsule free_when_done(owner, [](void* p) { delete static_cast<std::vector<double>*>(p); });
  py::array_t<double> data({width, rows}, owner->data(), free_when_done);
  return py::make_tuple(columns, data, comments, encoding, warning_list(warnings));
}

// Writes columns (one float64 array of `rows` values each) as a stream.
py::list write_stream(const std::string& path, const std::vector<std::string>& columns,
                      const std::vector<py::array_t<double, py::array::c_style | py::array::forcecast>>& data,
                      const std::string& encoding, const std::vector<std::string>& comments) {
  if (data.size() != columns.size())
    throw UsageError(std::to_string(columns.size()) + " column names for " + std::to_string(data.size()) + " columns");
  std::vector<const double*> pointers;
  const std::size_t rows = data.empty() ? 0 : static_cast<std::size_t>(data.front().size());
  for (std::size_t c = 0; c < data.size(); ++c) {
    if (data[c].ndim() != 1 || static_cast<std::size_t>(data[c].size()) != rows)
      throw UsageError("column '" + columns[c] + "': " + std::to_string(data[c].size()) + " values, the first column has " +
                       std::to_string(rows));
    pointers.push_back(data[c].data());
  }
  Warnings warnings;
  run_library(warnings, [&] {
    stream::WriterOptions options;
    if (encoding != "csv" && encoding != "bin" && encoding != "binary")
      throw UsageError("encoding '" + encoding + "' is not csv or binary");
    options.encoding = stream::parse_encoding(encoding);
    auto out = stream::Writer::open(path, options);
    for (const auto& c : comments) out->comment(c);
    out->header(columns);
    std::vector<double> row(columns.size());
    for (std::size_t r = 0; r < rows; ++r) {
      for (std::size_t c = 0; c < pointers.size(); ++c) row[c] = pointers[c][r];
      out->row(row.data());
    }
    out->close();
  });
  return warning_list(warnings);
}

// ---- profile ----------------------------------------------------------------------------------

// A profile loaded from its file (model::load_profile, the payload selected as --payload does)
// and the chain it builds.
struct LoadedProfile {
  model::Profile profile;
  model::Model model;
  std::string payload;  // as asked ("" : the profile's active one)
};

std::shared_ptr<LoadedProfile> load(const std::string& path, const std::string& payload, Warnings& warnings) {
  auto loaded = std::make_shared<LoadedProfile>();
  run_library(warnings, [&] {
    loaded->profile = model::load_profile(path);
    model::select_payload(loaded->profile, payload);
    loaded->model = model::build_model(loaded->profile);
    loaded->payload = payload;
  });
  return loaded;
}

// ---- mo-observe -------------------------------------------------------------------------------

struct ObserveArguments {
  std::optional<int> order;
  std::optional<std::vector<double>> k1, k2, k3, cutoff;
  std::optional<double> gap_factor, bridge_tolerance, signal_sigmas, limit_factor, friction_deadband, friction_cutoff;
  bool signal_check = true, friction = true, restart_column = false, flag_column = false, strict = false;
  std::string lugre_update;
};

// mo-observe's main: input stream in, the observed stream out (binary), as the tool with the
// same options. Returns the summary and the warnings.
py::tuple observe_stream(const LoadedProfile& loaded, const std::string& input, const std::string& display_name,
                         const std::string& output, const ObserveArguments& a, const std::vector<std::string>& comments) {
  Warnings warnings;
  drivers::ObserveStreamSummary summary;
  run_library(warnings, [&] {
    const model::Profile& profile = loaded.profile;
    const model::Model& robot = loaded.model;
    drivers::ObserveStreamOptions options;
    options.observer = drivers::observer_options_from_profile(profile);
    observer::ObserverOptions& o = options.observer;
    if (a.order) o.order = *a.order;
    if (a.k1 && a.cutoff) throw UsageError("give either k1 or cutoff, not both");
    if (a.k1) o.k1 = *a.k1;
    if (a.cutoff) {
      o.k1 = *a.cutoff;
      for (double& k : o.k1) k *= 2 * std::numbers::pi;
    }
    if (a.k2) o.k2 = *a.k2;
    if (a.k3) o.k3 = *a.k3;
    if (o.order == 1 && (a.k2 || a.k3)) throw UsageError("k2 and k3 need order 2");
    if (a.gap_factor) o.gap_factor = *a.gap_factor;
    if (a.bridge_tolerance) o.bridge_tolerance = *a.bridge_tolerance;
    if (!a.signal_check) o.signals.enabled = false;
    if (a.signal_sigmas) o.signals.sigmas = *a.signal_sigmas;
    if (a.limit_factor) o.signals.limit_factor = *a.limit_factor;
    for (const auto& [name, list] : {std::pair{"k1", &a.k1}, {"cutoff", &a.cutoff}, {"k2", &a.k2}, {"k3", &a.k3}}) {
      const std::size_t count = *list ? (*list)->size() : 0;
      if (count > 1 && count != static_cast<std::size_t>(robot.nq))
        throw UsageError(std::string(name) + ": " + std::to_string(count) + " values for " + std::to_string(robot.nq) +
                         " joints");
    }
    std::string why;
    if (!o.IsValid(&why)) throw UsageError(why);
    try {
      o.joint_gains(robot.nq);
    } catch (const Error& e) {
      throw Error(located(profile.path.string(), 0, e.what()));
    }
    std::optional<friction::FrictionModel> friction;
    if (a.friction) friction = drivers::friction_from_profile(profile, robot.nq);
    const bool friction_options = a.friction_deadband || a.friction_cutoff || !a.lugre_update.empty();
    if (friction_options && !friction)
      warn("friction_deadband, friction_cutoff and lugre_update have no effect without a friction model");
    if (friction) {
      if (a.friction_deadband) friction->options.velocity_deadband = *a.friction_deadband;
      if (a.friction_cutoff) friction->options.velocity_cutoff_hz = *a.friction_cutoff;
      if (!a.lugre_update.empty() && !friction::parse_update(a.lugre_update, &friction->options.update))
        throw UsageError("lugre_update: '" + a.lugre_update + "' is not exact or semi-implicit");
      if (!friction->options.IsValid(&why)) throw UsageError(why);
      options.friction = &*friction;
    }
    options.restart_column = a.restart_column;
    options.flag_column = a.flag_column;
    options.strict = a.strict;

    stream::ReaderOptions reader_options;
    reader_options.strict = a.strict;
    reader_options.display_name = display_name;
    auto in = stream::Reader::open(input, reader_options);
    drivers::StreamObserver observe(*in, robot, options);
    stream::WriterOptions writer_options;
    writer_options.encoding = stream::Encoding::binary;
    auto out = stream::Writer::open(output, writer_options);
    for (const auto& c : in->leading_comments()) out->comment(c);
    for (const auto& c : comments) out->comment(c);
    summary = observe.run(*out);
    out->close();
  });
  py::dict s;
  s["rows_written"] = summary.rows_written;
  s["invalid_rows"] = summary.invalid_rows;
  s["rejected_rows"] = summary.rejected_rows;
  s["restarts"] = summary.restarts;
  s["bridged_gaps"] = summary.bridged_gaps;
  s["median_dt"] = summary.median_dt;
  s["flagged_rows"] = summary.flagged_rows;
  return py::make_tuple(s, warning_list(warnings));
}

// ---- mo-calibrate -----------------------------------------------------------------------------

struct CalibrateArguments {
  std::string signal, rule = "rate", rest_signal = "r", format = "text";
  std::optional<double> false_alarm_rate, peak_window, margin, margin_percent, envelope_bin, rest_velocity, rest_time,
      hangover, skip, stretch_gap, contact_ratio, friction_band, contact_rise;
  std::optional<std::vector<double>> rest_drift;
  double max_rise = 0;
  bool envelope = false, no_rest = false, reject_contact = false, strict = false;
};

// mo-calibrate's main (without --classes): thresholds from collision-free residual streams,
// the profile updated unless dry_run. Returns ([(signal, thresholds as JSON text)], report,
// rows, warnings).
py::tuple calibrate_streams(const std::string& profile_path, const std::vector<std::string>& inputs,
                            const std::vector<std::string>& display_names, const std::string& output, bool dry_run,
                            const CalibrateArguments& a) {
  if (display_names.size() != inputs.size()) throw UsageError("one display name per input");
  Warnings warnings;
  std::vector<std::pair<std::string, std::string>> thresholds;
  std::string report;
  std::uint64_t rows = 0;
  run_library(warnings, [&] {
    drivers::CalibrateStreamsOptions streams;
    calibrate::CalibrationOptions& options = streams.calibration;
    if (a.false_alarm_rate) options.false_alarms_per_hour = *a.false_alarm_rate;
    if (a.peak_window) options.peak_window = *a.peak_window;
    if (a.margin && a.margin_percent) throw UsageError("give either margin or margin_percent, not both");
    if (a.margin_percent) options.margin_percent = *a.margin_percent;
    if (a.envelope_bin) options.envelope_bin = *a.envelope_bin;
    if (a.rest_velocity) options.rest_rule.velocity = *a.rest_velocity;
    if (a.rest_time) options.rest_rule.time = *a.rest_time;
    if (a.hangover) options.rest_rule.hangover = *a.hangover;
    if (a.skip) options.skip = *a.skip;
    if (a.stretch_gap) streams.stretch_gap = *a.stretch_gap;
    if (a.contact_ratio) options.contact_ratio = *a.contact_ratio;
    if (a.friction_band) streams.friction_band_sigmas = *a.friction_band;
    if (a.contact_rise) options.contact_rise = *a.contact_rise;
    if (a.margin) options.margin_nm = *a.margin;
    if (a.rule != "rate" && a.rule != "max") throw UsageError("rule: '" + a.rule + "' is not rate or max");
    if (a.rest_signal != "r" && a.rest_signal != "mu") throw UsageError("rest_signal: '" + a.rest_signal + "' is not r or mu");
    if (a.format != "text" && a.format != "jsonl") throw UsageError("format: '" + a.format + "' is not text or jsonl");
    options.rule = calibrate::parse_threshold_rule(a.rule);
    if (a.rest_drift) options.rest_drift_candidates = *a.rest_drift;
    options.envelope = a.envelope;
    options.rest_state = !a.no_rest;
    streams.max_rise = a.max_rise;
    streams.rest_on_r = a.rest_signal == "r";
    streams.reject_contact = a.reject_contact;
    streams.format = a.format == "jsonl" ? drivers::ReportFormat::jsonl : drivers::ReportFormat::text;
    streams.profile_path = profile_path;
    streams.output = output;
    streams.dry_run = dry_run;
    std::string why;
    if (!streams.IsValid(&why)) throw UsageError(why);
    try {
      streams.signals = detect::parse_signal_list(a.signal);
    } catch (const Error& e) {
      throw UsageError(std::string("signal: ") + e.what());
    }
    // As mo-calibrate: the profile file's lock is held from its read to its write.
    const std::string destination = output.empty() ? profile_path : output;
    std::unique_ptr<core::FileLock> lock;
    if (!profile_path.empty() && !dry_run && !core::is_standard_output(destination))
      lock = std::make_unique<core::FileLock>(destination, [](const std::string& name) {
        warn(name + ": another run is updating this profile; waiting for it to finish");
      });
    streams.report = [&](const std::string& text) { report += text; };
    streams.open_input = [&](const std::string& path) {
      stream::ReaderOptions o;
      o.strict = a.strict;
      for (std::size_t i = 0; i < inputs.size(); ++i)
        if (inputs[i] == path) o.display_name = display_names[i];
      return stream::Reader::open(path, o);
    };
    for (const auto& result : drivers::calibrate_streams(inputs, streams)) {
      thresholds.emplace_back(std::string(detect::signal_name(result.thresholds.signal)),
                              detect::thresholds_to_json(result.thresholds).dump());
      rows = result.rows;
    }
  });
  return py::make_tuple(thresholds, report, rows, warning_list(warnings));
}

// ---- mo-detect --------------------------------------------------------------------------------

struct DetectArguments {
  std::string signal;
  std::optional<std::vector<double>> threshold;
  bool constant = false, identify = true, strict = false;
  std::optional<int> min_samples;
  std::optional<double> release, hold, join, aftermath, onset_band, skip, link_radius;
};

// mo-detect's main (events, not --pass; no hooks): events as CSV at `events`. Returns the
// summary and the warnings. Collisions are data here, not an exit status.
py::tuple detect_stream(const std::string& profile_path, const std::string& input, const std::string& display_name,
                        const std::string& events, const DetectArguments& a, const std::vector<std::string>& comments) {
  Warnings warnings;
  drivers::StreamDetectorSummary summary;
  run_library(warnings, [&] {
    drivers::StreamDetectorOptions options;
    if (a.min_samples) options.detector.min_samples = *a.min_samples;
    if (a.release) options.detector.release = *a.release;
    if (a.hold) options.detector.hold = *a.hold;
    if (a.join) options.detector.join = *a.join;
    if (a.aftermath) options.detector.aftermath = *a.aftermath;
    if (a.onset_band) options.detector.onset_band = *a.onset_band;
    if (a.skip) options.detector.skip = *a.skip;
    options.detector.use_envelope = !a.constant;
    if (!a.signal.empty()) {
      if (a.signal != "mu" && a.signal != "r") throw UsageError("signal: '" + a.signal + "' is not mu or r");
      options.signal = detect::parse_signal(a.signal);
    }
    if (a.threshold) options.constant_thresholds = *a.threshold;
    options.profile_path = profile_path;
    options.output = events;
    options.format = drivers::EventFormat::csv;
    options.comments = comments;
    options.stall = 0;  // a file, never a live input
    options.open_input = [&](const std::string& path, stream::ReaderOptions o) {
      o.strict = o.strict || a.strict;
      o.display_name = display_name;
      return stream::Reader::open(path, std::move(o));
    };
    contact::LocatorOptions locator;
    if (a.link_radius) locator.link_radius = *a.link_radius;
    std::string why;
    if (!options.IsValid(&why)) throw UsageError(why);
    if (!locator.IsValid(&why)) throw UsageError("link_radius: " + why);
    if (a.identify) options.annotator = contact::annotator_factory(locator, profile_path);
    summary = drivers::StreamDetector(options).run(input);
  });
  py::dict s;
  s["rows"] = summary.rows;
  s["seconds"] = summary.seconds;
  s["rows_skipped"] = summary.rows_skipped;
  s["events"] = summary.events;
  s["collisions"] = summary.collisions;
  s["blind_seconds"] = summary.blind_seconds;
  s["blind_share"] = summary.blind_share;
  s["blind_text"] = summary.blind_text;
  s["interrupted"] = summary.interrupted;
  return py::make_tuple(s, warning_list(warnings));
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "momentum's library, bound for Python (use the package momentum, not this module)";
  // momentum::Error: bad input, an unreadable file, a profile that does not fit. Its message is
  // the library's `file:line: message`. UsageError (bad options) is a std::invalid_argument,
  // which pybind11 raises as ValueError.
  py::register_exception<Error>(m, "Error", PyExc_RuntimeError);
  m.attr("__version__") = kVersion;

  m.def("read_stream", &read_stream, py::arg("path"), py::arg("strict"), py::arg("names"), py::arg("time_order"),
        py::arg("display_name"));
  m.def("write_stream", &write_stream, py::arg("path"), py::arg("columns"), py::arg("data"), py::arg("encoding"),
        py::arg("comments"));

  py::class_<LoadedProfile, std::shared_ptr<LoadedProfile>>(m, "LoadedProfile")
      .def_property_readonly("path", [](const LoadedProfile& p) { return p.profile.path.string(); })
      .def_property_readonly("payload", [](const LoadedProfile& p) { return p.payload; })
      .def_property_readonly("joints", [](const LoadedProfile& p) { return p.model.nq; })
      .def_property_readonly("joint_names",
                             [](const LoadedProfile& p) {
                               std::vector<std::string> names;
                               for (const auto& j : p.model.joints) names.push_back(j.name);
                               return names;
                             })
      .def_property_readonly("document", [](const LoadedProfile& p) { return p.profile.document.dump(); });
  m.def(
      "load_profile",
      [](const std::string& path, const std::string& payload) {
        Warnings warnings;
        auto loaded = load(path, payload, warnings);
        return py::make_tuple(loaded, warning_list(warnings));
      },
      py::arg("path"), py::arg("payload"));

  py::class_<ObserveArguments>(m, "ObserveArguments")
      .def(py::init<>())
      .def_readwrite("order", &ObserveArguments::order)
      .def_readwrite("k1", &ObserveArguments::k1)
      .def_readwrite("k2", &ObserveArguments::k2)
      .def_readwrite("k3", &ObserveArguments::k3)
      .def_readwrite("cutoff", &ObserveArguments::cutoff)
      .def_readwrite("gap_factor", &ObserveArguments::gap_factor)
      .def_readwrite("bridge_tolerance", &ObserveArguments::bridge_tolerance)
      .def_readwrite("signal_check", &ObserveArguments::signal_check)
      .def_readwrite("signal_sigmas", &ObserveArguments::signal_sigmas)
      .def_readwrite("limit_factor", &ObserveArguments::limit_factor)
      .def_readwrite("flag_column", &ObserveArguments::flag_column)
      .def_readwrite("friction", &ObserveArguments::friction)
      .def_readwrite("friction_deadband", &ObserveArguments::friction_deadband)
      .def_readwrite("friction_cutoff", &ObserveArguments::friction_cutoff)
      .def_readwrite("lugre_update", &ObserveArguments::lugre_update)
      .def_readwrite("restart_column", &ObserveArguments::restart_column)
      .def_readwrite("strict", &ObserveArguments::strict);
  m.def("observe_stream", &observe_stream, py::arg("profile"), py::arg("input"), py::arg("display_name"),
        py::arg("output"), py::arg("arguments"), py::arg("comments"));

  py::class_<CalibrateArguments>(m, "CalibrateArguments")
      .def(py::init<>())
      .def_readwrite("signal", &CalibrateArguments::signal)
      .def_readwrite("rule", &CalibrateArguments::rule)
      .def_readwrite("rest_signal", &CalibrateArguments::rest_signal)
      .def_readwrite("format", &CalibrateArguments::format)
      .def_readwrite("false_alarm_rate", &CalibrateArguments::false_alarm_rate)
      .def_readwrite("peak_window", &CalibrateArguments::peak_window)
      .def_readwrite("margin", &CalibrateArguments::margin)
      .def_readwrite("margin_percent", &CalibrateArguments::margin_percent)
      .def_readwrite("envelope_bin", &CalibrateArguments::envelope_bin)
      .def_readwrite("rest_velocity", &CalibrateArguments::rest_velocity)
      .def_readwrite("rest_time", &CalibrateArguments::rest_time)
      .def_readwrite("hangover", &CalibrateArguments::hangover)
      .def_readwrite("skip", &CalibrateArguments::skip)
      .def_readwrite("stretch_gap", &CalibrateArguments::stretch_gap)
      .def_readwrite("contact_ratio", &CalibrateArguments::contact_ratio)
      .def_readwrite("friction_band", &CalibrateArguments::friction_band)
      .def_readwrite("contact_rise", &CalibrateArguments::contact_rise)
      .def_readwrite("rest_drift", &CalibrateArguments::rest_drift)
      .def_readwrite("max_rise", &CalibrateArguments::max_rise)
      .def_readwrite("envelope", &CalibrateArguments::envelope)
      .def_readwrite("no_rest", &CalibrateArguments::no_rest)
      .def_readwrite("reject_contact", &CalibrateArguments::reject_contact)
      .def_readwrite("strict", &CalibrateArguments::strict);
  m.def("calibrate_streams", &calibrate_streams, py::arg("profile_path"), py::arg("inputs"), py::arg("display_names"),
        py::arg("output"), py::arg("dry_run"), py::arg("arguments"));

  py::class_<DetectArguments>(m, "DetectArguments")
      .def(py::init<>())
      .def_readwrite("signal", &DetectArguments::signal)
      .def_readwrite("threshold", &DetectArguments::threshold)
      .def_readwrite("constant", &DetectArguments::constant)
      .def_readwrite("identify", &DetectArguments::identify)
      .def_readwrite("strict", &DetectArguments::strict)
      .def_readwrite("min_samples", &DetectArguments::min_samples)
      .def_readwrite("release", &DetectArguments::release)
      .def_readwrite("hold", &DetectArguments::hold)
      .def_readwrite("join", &DetectArguments::join)
      .def_readwrite("aftermath", &DetectArguments::aftermath)
      .def_readwrite("onset_band", &DetectArguments::onset_band)
      .def_readwrite("skip", &DetectArguments::skip)
      .def_readwrite("link_radius", &DetectArguments::link_radius);
  m.def("detect_stream", &detect_stream, py::arg("profile_path"), py::arg("input"), py::arg("display_name"),
        py::arg("events"), py::arg("arguments"), py::arg("comments"));
}
