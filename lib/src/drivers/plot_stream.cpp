#include "momentum/drivers/plot_stream.hpp"

#include <cmath>

#include "momentum/core/error.hpp"
#include "momentum/eval/score.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/stream/columns.hpp"

namespace momentum::drivers {

// This driver runs the detect stage: its names are this file's vocabulary.
using namespace detect;
using namespace plot;

PlotColumns plot_columns(const stream::Reader& in, const std::vector<Signal>& signals) {
  PlotColumns out;
  out.time = in.require("t");
  out.signals = signals;
  if (out.signals.empty()) {
    if (in.find("r1")) out.signals.push_back(Signal::r);
    if (in.find("mu1")) out.signals.push_back(Signal::mu);
    if (out.signals.empty()) throw Error(in.name() + ": no r1 or mu1 column (run mo-observe first)");
    for (std::size_t s = 0; s < out.signals.size(); ++s)
      if (out.signals[s] == Signal::mu) out.view_signal = s;
  }
  const std::string first(signal_name(out.signals.front()));
  out.joints = stream::count_joint_columns(in.columns(), first);
  if (out.joints == 0) throw Error(in.name() + ": missing column '" + first + "1'");
  for (Signal s : out.signals)
    out.values.push_back(stream::column_indices(in.columns(), stream::joint_columns(signal_name(s), out.joints), in.name()));
  if (stream::count_joint_columns(in.columns(), "dq") >= out.joints)
    out.velocity = stream::column_indices(in.columns(), stream::joint_columns("dq", out.joints), in.name());
  return out;
}

std::vector<std::optional<Thresholds>> plot_thresholds(const std::string& profile_path,
                                                       const std::vector<Signal>& signals, FrictionBand* friction_band) {
  std::vector<std::optional<Thresholds>> thresholds(signals.size());
  if (profile_path.empty()) return thresholds;
  const model::Profile profile = model::load_profile(profile_path);
  for (std::size_t s = 0; s < signals.size(); ++s) {
    thresholds[s] = thresholds_from_profile(profile.document, signals[s], profile_path);
    if (!thresholds[s]) warn(profile_path + ": no thresholds for " + std::string(signal_name(signals[s])) + ": none drawn");
    else if (friction_band && signals[s] == Signal::mu)
      *friction_band = friction_band_from_profile(profile.document, thresholds[s]->friction_band, profile_path);
  }
  return thresholds;
}

namespace {

// A view of one signal: rows outside the time window are left out.
std::string view_script(stream::Reader& in, const PlotColumns& c, const std::optional<Thresholds>& thresholds,
                        PlotView view, const std::vector<Event>& events, const std::vector<eval::TruthContact>& truth,
                        const std::string& output, const PlotOptions& options) {
  const std::size_t n = c.joints;
  const std::vector<std::size_t>& columns = c.values[c.view_signal];
  plot::ViewData data(view, c.signals[c.view_signal], thresholds, n, !c.velocity.empty(), plot::event_spans(events));
  std::vector<double> x(n), dq(n);
  double t_prev = -INFINITY;
  while (const double* row = in.next()) {
    const double t = row[c.time];
    if (!in.follows_in_time(t, t_prev)) continue;
    t_prev = t;
    if (t < options.from || t > options.to) continue;
    for (std::size_t j = 0; j < n; ++j) x[j] = row[columns[j]];
    for (std::size_t j = 0; j < c.velocity.size(); ++j) dq[j] = row[c.velocity[j]];
    data.add(t, x.data(), c.velocity.empty() ? nullptr : dq.data());
  }
  if (data.rows() == 0) throw Error(in.name() + ": no rows to plot");
  return data.gnuplot_script(truth, output, options);
}

}  // namespace

std::string stream_plot_script(stream::Reader& in, const PlotColumns& c,
                               const std::vector<std::optional<Thresholds>>& thresholds, PlotView view,
                               const std::vector<Event>& events, const std::vector<eval::TruthContact>& truth,
                               const std::string& output, const PlotOptions& options) {
  if (view != PlotView::time)
    return view_script(in, c, thresholds[c.view_signal], view, events, truth, output, options);
  const std::size_t n = c.joints, signals = c.signals.size();
  plot::PlotData data(c.signals, thresholds, n, !c.velocity.empty(), options);
  std::vector<std::vector<double>> x(signals, std::vector<double>(n));
  std::vector<const double*> rows(signals);
  std::vector<double> dq(n);
  double t_prev = -INFINITY, shift = 0, step = 0;
  while (const double* row = in.next()) {
    if (in.time_mark() == stream::TimeMark::clock_step) {
      // The stream's time policy kept this row as the start of a new time line: the time
      // axis goes on from the last row instead of drawing over earlier rows.
      shift = t_prev + step - row[c.time];
      in.warn_clock_step("the plot shifts the rows from here by " + core::short_number(shift) + " s");
    }
    const double t = row[c.time] + shift;
    if (!in.follows_in_time(t, t_prev)) continue;
    if (std::isfinite(t_prev)) step = t - t_prev;
    t_prev = t;
    for (std::size_t s = 0; s < signals; ++s) {
      for (std::size_t j = 0; j < n; ++j) x[s][j] = row[c.values[s][j]];
      rows[s] = x[s].data();
    }
    for (std::size_t j = 0; j < c.velocity.size(); ++j) dq[j] = row[c.velocity[j]];
    data.add(t, rows.data(), c.velocity.empty() ? nullptr : dq.data());
  }
  if (data.rows() == 0)
    throw Error(in.name() + ": no rows to plot" +
                (std::isfinite(options.from) || std::isfinite(options.to) ? " in the time window" : ""));
  return plot::gnuplot_script(data, events, truth, output, options);
}

std::string force_plot_script(const std::string& events_path, const std::string& truth_path, bool strict,
                              const std::string& output, const plot::PlotOptions& options) {
  const auto detections = eval::read_detections(events_path, strict);
  if (truth_path.empty()) {
    std::vector<ForceEstimate> estimates;
    for (const auto& d : detections)
      if (std::isfinite(d.peak_force)) estimates.push_back({d.t_detect, d.peak_force, d.final_link});
    if (estimates.empty())
      throw Error(events_path + ": no event with an estimated force (f_peak: mo-detect's contact columns)");
    return force_estimate_script(estimates, output, options);
  }
  std::vector<ForcePoint> points;
  for (const auto& o : eval::score(eval::read_truth(truth_path), detections, {}).outcomes)
    if (o.detection >= 0 && std::isfinite(o.force_error))
      points.push_back({o.contact.peak_force, detections[static_cast<std::size_t>(o.detection)].peak_force, o.contact.link});
  return force_view_script(points, output, options);
}

}  // namespace momentum::drivers
