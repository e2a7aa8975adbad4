#include "momentum/plot/plot_views.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"

namespace momentum::plot {

// Built on the detector's vocabulary (thresholds, motion states, events).
using namespace detect;

std::string force_view_script(const std::vector<ForcePoint>& points, const std::string& output,
                              const PlotOptions& options) {
  if (points.empty()) throw Error("no detected contact with an estimated and a true force to plot");
  const int height = options.width * 3 / 4;
  double top = 0;
  std::map<int, std::string> by_link;
  for (const auto& p : points) {
    top = std::max({top, p.truth, p.estimate});
    by_link[p.link] += core::exact(p.truth) + " " + core::exact(p.estimate) + "\n";
  }
  std::string s = "# momentum: estimated against true contact force\n" + gnuplot_output(options, height, output);
  for (const auto& [link, rows] : by_link) s += "$link" + std::to_string(link) + " << EOD\n" + rows + "EOD\n";
  if (!options.title.empty()) s += "set title " + gnuplot_string(options.title) + "\n";
  s += "set xlabel 'true peak force (N)'\nset ylabel 'estimated peak force (N)'\nset grid\nset key top left\n";
  s += "set xrange [0:" + core::exact(1.1 * top) + "]\nset yrange [0:" + core::exact(1.1 * top) + "]\nset size ratio -1\n";
  s += "plot x title 'estimate = truth' lc rgb 'gray' dt 2";
  for (const auto& [link, rows] : by_link)
    s += ", $link" + std::to_string(link) + " using 1:2 with points pt 7 ps 1.2 title 'link " + std::to_string(link) + "'";
  return s + "\n";
}

std::string force_estimate_script(const std::vector<ForceEstimate>& events, const std::string& output,
                                  const PlotOptions& options) {
  if (events.empty()) throw Error("no event with an estimated force to plot (mo-detect's contact columns, f_peak)");
  const int height = options.width * 3 / 8;
  double top = 0;
  std::map<int, std::string> by_link;
  for (const auto& e : events) {
    top = std::max(top, e.estimate);
    by_link[e.link] += core::exact(e.t_detect) + " " + core::exact(e.estimate) + "\n";
  }
  std::string s = "# momentum: estimated contact force of each event\n" + gnuplot_output(options, height, output);
  for (const auto& [link, rows] : by_link) s += "$link" + std::to_string(link) + " << EOD\n" + rows + "EOD\n";
  if (!options.title.empty()) s += "set title " + gnuplot_string(options.title) + "\n";
  s += "set xlabel 'detected at t (s)'\nset ylabel 'estimated peak force (N)'\nset grid\nset key top left\n";
  s += "set yrange [0:" + core::exact(1.1 * top) + "]\nset offsets graph 0.03, graph 0.03, 0, 0\n";
  s += "plot ";
  const char* separator = "";
  for (const auto& [link, rows] : by_link) {
    s += separator;
    const std::string colour = " lc " + std::to_string(link + 1);  // gnuplot's colour sequence, the same per link
    s += "$link" + std::to_string(link) + " using 1:2 with impulses lw 2" + colour + " notitle, $link" +
         std::to_string(link) + " using 1:2 with points pt 7 ps 1.2" + colour + " title '" +
         (link > 0 ? "link " + std::to_string(link) : std::string("link unknown")) + "'";
    separator = ", ";
  }
  return s + "\n";
}

PlotView parse_plot_view(const std::string& name) {
  if (name == "time") return PlotView::time;
  if (name == "force") return PlotView::force;
  if (name == "events") return PlotView::events;
  if (name == "mu-dq") return PlotView::mu_dq;
  if (name == "histogram") return PlotView::histogram;
  throw Error("unknown view '" + name + "' (time, events, mu-dq, histogram)");
}

std::vector<EventSpan> event_spans(const std::vector<Event>& events) {
  std::vector<EventSpan> spans;
  for (const Event& e : events) {
    if (e.kind == EventKind::onset) {
      spans.push_back({e.id, e.t_onset_estimate, e.t_detect, NAN, e.link});
    } else if (e.kind == EventKind::identified) {
      // The link identification chose at detection; without its onset row, the event from here.
      auto it = std::find_if(spans.rbegin(), spans.rend(), [&](const EventSpan& s) { return s.id == e.id; });
      if (it == spans.rend()) spans.push_back({e.id, e.t_onset_estimate, e.t_detect, NAN, e.link});
      else it->link = e.link;
    } else {
      auto it = std::find_if(spans.rbegin(), spans.rend(), [&](const EventSpan& s) { return s.id == e.id; });
      if (it == spans.rend()) {
        // An end row alone, or read_events' merged event (its end row, onset fields included).
        spans.push_back({e.id, e.t_onset_estimate, e.t_detect, e.t_end, e.link});
      } else {
        it->t_end = e.t_end;
        it->link = e.link;  // over the whole event
      }
    }
  }
  return spans;
}

ViewData::ViewData(PlotView view, Signal signal, std::optional<Thresholds> thresholds, std::size_t joints,
                   bool have_velocity, std::vector<EventSpan> spans)
    : view_(view), signal_(signal), thresholds_(std::move(thresholds)), joints_(joints), spans_(std::move(spans)) {
  if (joints_ == 0) throw Error("no joints to plot");
  if (view_ == PlotView::time) throw Error("the time view is PlotData's");
  if (view_ == PlotView::force) throw Error("the force view is force_view_script's: it reads no stream");
  if (view_ == PlotView::mu_dq && (!have_velocity || !thresholds_))
    throw Error("the mu-dq view needs dq1..dqn columns and the profile's thresholds (-p)");
  if (view_ == PlotView::events && spans_.empty()) throw Error("the events view needs events (--events) to show");
  if (thresholds_) detector_.emplace(*thresholds_, DetectorOptions{}, have_velocity);
  if (spans_.size() > kMaxEvents) spans_.resize(kMaxEvents);
  windows_.resize(spans_.size());
  const std::size_t bins = static_cast<std::size_t>((kMaxDecade - kMinDecade) * kBinsPerDecade);
  counts_.assign(joints_, std::vector<std::uint64_t>(bins, 0));
  outside_.assign(joints_, 0);
  peak_.assign(joints_, std::vector<double>(kSpeedBins, NAN));
  bound_.assign(joints_, std::vector<double>(kSpeedBins, NAN));
}

void ViewData::add(double t, const double* x, const double* dq) {
  if (rows_ == 0) t_first_ = t;
  t_last_ = t;
  ++rows_;
  if (detector_) detector_->step(t, x, dq);
  switch (view_) {
    case PlotView::events:
      for (std::size_t k = 0; k < spans_.size(); ++k) {
        const EventSpan& s = spans_[k];
        const double end = std::min(std::isnan(s.t_end) ? INFINITY : s.t_end, s.t_detect + kMaxWindow);
        if (t < s.t_onset_estimate - kPad || t > end + kPad) continue;
        windows_[k].push_back(t);
        windows_[k].insert(windows_[k].end(), x, x + joints_);
      }
      break;
    case PlotView::histogram:
      for (std::size_t j = 0; j < joints_; ++j) {
        const double a = std::fabs(x[j]);
        if (!std::isfinite(a)) continue;
        const double position = (std::log10(std::max(a, 1e-300)) - kMinDecade) * kBinsPerDecade;
        const auto bin = static_cast<std::size_t>(std::clamp(position, 0.0, static_cast<double>(counts_[j].size() - 1)));
        ++counts_[j][bin];
        if (detector_) {
          const Detector::Bounds& b = detector_->bounds(j);
          if (x[j] < b.lower || x[j] > b.upper) ++outside_[j];
        }
      }
      break;
    case PlotView::mu_dq:
      for (std::size_t j = 0; j < joints_; ++j) {
        const double a = std::fabs(x[j]), v = std::fabs(dq[j]);
        if (!std::isfinite(a) || !std::isfinite(v)) continue;
        // Clamped before the conversion: a speed past the last bin (or absurd) goes into it.
        const auto bin = static_cast<std::size_t>(std::min(v / kSpeedBin, static_cast<double>(kSpeedBins - 1)));
        if (!(peak_[j][bin] >= a)) peak_[j][bin] = a;
        const Detector::Bounds& b = detector_->bounds(j);
        // The half-width of the band: the threshold the residual is held to at this speed.
        const double threshold = 0.5 * (b.upper - b.lower);
        if (!(bound_[j][bin] >= threshold)) bound_[j][bin] = threshold;
      }
      break;
    case PlotView::time:
    case PlotView::force:
      break;
  }
}

std::string ViewData::gnuplot_script(const std::vector<eval::TruthContact>& truth, const std::string& output,
                                     const PlotOptions& options) const {
  const std::string name(signal_name(signal_));
  std::string s = "# momentum: " + std::string(view_ == PlotView::events ? "events" : view_ == PlotView::mu_dq ? "mu-dq" : "histogram") + " view\n";
  const std::size_t panels = view_ == PlotView::events ? std::max<std::size_t>(spans_.size(), 1) : joints_;
  const std::size_t columns = view_ == PlotView::events ? std::min<std::size_t>(panels, 3) : 1;
  const std::size_t rows = (panels + columns - 1) / columns;
  const int height = static_cast<int>(rows) * options.panel_height + (options.title.empty() ? 40 : 80);
  s += gnuplot_output(options, height, output);
  s += "set grid lc rgb '#dddddd'\nset lmargin 10\nset rmargin 3\n";
  s += "set multiplot layout " + std::to_string(rows) + "," + std::to_string(columns) +
       (options.title.empty() ? "" : " title " + gnuplot_string(options.title) + " font ',13'") + "\n";
  static const char* colours[] = {"#1f77b4", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f"};

  if (view_ == PlotView::events) {
    for (std::size_t k = 0; k < spans_.size(); ++k) {
      const EventSpan& e = spans_[k];
      const auto& w = windows_[k];
      s += "$e" + std::to_string(k) + " << EOD\n";
      for (std::size_t r = 0; r + joints_ < w.size(); r += joints_ + 1) {
        for (std::size_t c = 0; c <= joints_; ++c) s += (c ? " " : "") + core::exact(w[r + c]);
        s += "\n";
      }
      s += "EOD\n";
      // Title: the detected link against the truth overlapping the event, if any.
      const double end = std::isnan(e.t_end) ? e.t_detect : e.t_end;
      std::string truth_text = "no true contact (false alarm)";
      s += "unset object\nunset arrow\nunset label\n";
      int object = 1;
      for (const auto& c : truth) {
        if (c.t_end < e.t_onset_estimate - kPad || c.t_onset > end + kPad) continue;
        s += "set object " + std::to_string(object++) + " rect from " + core::exact(c.t_onset) + ", graph 0 to " +
             core::exact(c.t_end) + ", graph 1 back fc rgb '#c8ecc8' fs solid 1.0 noborder\n";
        s += "set label " + std::to_string(object) + " " + gnuplot_string("L" + std::to_string(c.link)) + " at " +
             core::exact(c.t_onset) + ", graph 0.92 left front tc rgb '#2ca02c' font ',9'\n";
        truth_text = "true L" + std::to_string(c.link) + (c.link == e.link ? "" : " (isolation error)");
      }
      if (truth.empty()) truth_text = "no truth given";
      s += "set arrow 1 from " + core::exact(e.t_detect) + ", graph 0 to " + core::exact(e.t_detect) +
           ", graph 1 nohead front lc rgb '#d62728' lw 1.2 dt 2\n";
      s += "set label 100 " + gnuplot_string("L" + std::to_string(e.link)) + " at " + core::exact(e.t_detect) +
           ", graph 1.05 center tc rgb '#d62728' font ',9'\n";
      s += "set title " + gnuplot_string("event " + std::to_string(e.id) + " at " + core::significant(e.t_detect, 3) +
                                    " s: detected L" + std::to_string(e.link) + ", " + truth_text) +
           " font ',10'\n";
      s += "set xlabel 't (s)'\nset ylabel '" + name + " (Nm)'\n";
      s += k == 0 ? "set key top left opaque box lc rgb '#bbbbbb' font ',8'\n" : "unset key\n";
      if (w.empty()) {
        s += "plot NaN notitle\n";
        continue;
      }
      s += "plot ";
      for (std::size_t j = 0; j < joints_; ++j) {
        s += (j ? ", " : "") + std::string("$e") + std::to_string(k) + " using 1:" + std::to_string(j + 2) +
             " with lines lw 1.2 lc rgb '" + colours[j % 7] + "' " +
             (k == 0 ? "title '" + name + std::to_string(j + 1) + "'" : std::string("notitle"));
      }
      if (k == 0) {
        s += ", NaN with boxes fs solid 1.0 lc rgb '#c8ecc8' title 'true contact (green L: its link)'";
        s += ", NaN with lines lc rgb '#d62728' dt 2 title 'detection (red L: isolated link)'";
      }
      s += "\n";
    }
  } else if (view_ == PlotView::histogram) {
    const double hours = std::max(t_last_ - t_first_, 0.0) / 3600.0;
    for (std::size_t j = 0; j < joints_; ++j) {
      s += "$h" + std::to_string(j) + " << EOD\n";
      for (std::size_t b = 0; b < counts_[j].size(); ++b) {
        if (counts_[j][b] == 0) continue;
        const double lo = std::pow(10.0, kMinDecade + static_cast<double>(b) / kBinsPerDecade);
        const double hi = std::pow(10.0, kMinDecade + static_cast<double>(b + 1) / kBinsPerDecade);
        s += core::exact(std::sqrt(lo * hi)) + " " + std::to_string(counts_[j][b]) + " " + core::exact(lo) + " " + core::exact(hi) + "\n";
      }
      s += "EOD\n";
      std::string title = "joint " + std::to_string(j + 1) + ": |" + name + "|";
      s += "unset arrow\n";
      if (thresholds_) {
        const JointThreshold& t = thresholds_->joints[j];
        s += "set arrow 1 from " + core::exact(t.moving) + ", graph 0 to " + core::exact(t.moving) +
             ", graph 1 nohead front lc rgb '#ff7f0e' lw 2\n";
        const double share = rows_ ? static_cast<double>(outside_[j]) / static_cast<double>(rows_) : 0.0;
        title += ", moving threshold " + core::significant(t.moving, 3) + " Nm: " + std::to_string(outside_[j]) +
                 " of " + std::to_string(rows_) + " rows outside the band (" + core::significant(share, 3) + " per row" +
                 (hours > 0 ? ", " + core::significant(static_cast<double>(outside_[j]) / hours, 3) + " per hour" : "") + ")";
      }
      s += "set title " + gnuplot_string(title) + " font ',10'\n";
      s += "set logscale xy\nset xlabel '|" + name + "| (Nm)'\nset ylabel 'rows'\n";
      s += j == 0 ? "set key top right opaque box lc rgb '#bbbbbb' font ',8'\n" : "unset key\n";
      s += "plot $h" + std::to_string(j) + " using 1:2:3:4:(0.8):2 with boxxyerror fs solid 0.6 lc rgb '#1f77b4' " +
           (j == 0 ? "title 'rows (data)'" : "notitle");
      if (thresholds_ && j == 0) s += ", NaN with lines lc rgb '#ff7f0e' lw 2 title 'moving threshold'";
      s += "\n";
    }
  } else {
    for (std::size_t j = 0; j < joints_; ++j) {
      s += "$m" + std::to_string(j) + " << EOD\n";
      for (std::size_t b = 0; b < kSpeedBins; ++b) {
        if (std::isnan(peak_[j][b])) continue;
        s += core::exact((static_cast<double>(b) + 0.5) * kSpeedBin) + " " + core::exact(peak_[j][b]) + " " + core::exact(bound_[j][b]) + "\n";
      }
      s += "EOD\n";
      const JointThreshold& t = thresholds_->joints[j];
      std::string rule = t.envelope ? "envelope " + core::significant(t.envelope->a, 3) + " + " + core::significant(t.envelope->b, 3) + " |dq|"
                                    : "constant " + core::significant(t.moving, 3) + " Nm";
      s += "set title " + gnuplot_string("joint " + std::to_string(j + 1) + ": largest |" + name + "| per speed, threshold " + rule) +
           " font ',10'\n";
      s += "unset logscale\nset xlabel '|dq| (rad/s)'\nset ylabel '|" + name + "| (Nm)'\nset yrange [0:*]\n";
      s += "unset arrow\nset arrow 1 from " + core::exact(thresholds_->rest_rule.velocity) + ", graph 0 to " +
           core::exact(thresholds_->rest_rule.velocity) + ", graph 1 nohead back lc rgb '#aaaaaa' dt 3\n";
      s += j == 0 ? "set key top left opaque box lc rgb '#bbbbbb' font ',8'\n" : "unset key\n";
      s += "plot $m" + std::to_string(j) + " using 1:2 with points pt 7 ps 0.4 lc rgb '#1f77b4' " +
           (j == 0 ? "title 'largest |" + name + "| (data)'" : std::string("notitle")) + ", $m" + std::to_string(j) +
           " using 1:3 with lines lw 2 lc rgb '#ff7f0e' " +
           (j == 0 ? "title 'threshold at that speed (dotted: rest velocity)'" : std::string("notitle")) + "\n";
    }
  }
  s += "unset multiplot\nset output\n";
  return s;
}

}  // namespace momentum::plot
