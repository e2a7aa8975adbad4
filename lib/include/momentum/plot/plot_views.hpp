#pragma once
// The other figures of mo-plot (--view), each drawn by gnuplot like the time view (plot.hpp):
//   events     one small panel per detected event: every joint's residual around it, the
//              detection (red, with the isolated link) and the true contacts (green, with
//              the link hit), so isolation errors and late detections can be seen one by one;
//   mu-dq      per joint, the largest |residual| at each speed |dq| against the detector's
//              threshold at that speed (constant, velocity envelope, or rest/slow below the
//              rest velocity): where the threshold is tight and where it is loose;
//   histogram  per joint, how often each |residual| occurs (log counts) with the moving
//              threshold and the false-alarm rate it stands for on this stream: the share of
//              rows outside the detector's band, per row and per hour.
//   force      the estimated peak contact force of each detected contact against the true one
//              (events with mo-detect's contact columns and a truth with f_peak), one colour
//              per link, the line of perfect estimates; no stream needed.
// Memory: events keeps the rows of the first max_events event windows; the other views keep
// fixed-size histograms.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "momentum/detect/detector.hpp"
#include "momentum/detect/events.hpp"
#include "momentum/plot/plot.hpp"
#include "momentum/detect/thresholds.hpp"

namespace momentum::plot {

enum class PlotView { time, events, mu_dq, histogram, force };

// Parses "time", "events", "mu-dq", "histogram", "force"; throws momentum::Error naming the view.
PlotView parse_plot_view(const std::string& name);

// One event as the events view needs it: from its onset row and its end row.
struct EventSpan {
  std::uint64_t id = 0;
  double t_onset_estimate = 0, t_detect = 0, t_end = 0;  // s; t_end NaN while open
  int link = 0;
};

// The spans of `events` (mo-detect's rows in file order, or read_events' merged events): an
// onset row opens a span, the end row of the same event closes it, an end row alone is a span.
std::vector<EventSpan> event_spans(const std::vector<detect::Event>& events);

// One detected contact of the force view: true and estimated peak force (N), its link.
struct ForcePoint {
  double truth = 0, estimate = 0;
  int link = 0;
};
// The gnuplot script of the force view. Throws momentum::Error without a point.
std::string force_view_script(const std::vector<ForcePoint>& points, const std::string& output,
                              const PlotOptions& options);

// One detected contact of a real robot's force view (no truth): its detection time (s), the
// estimated peak force (N) and the isolated link (1..n; 0: unknown).
struct ForceEstimate {
  double t_detect = 0, estimate = 0;
  int link = 0;
};
// The gnuplot script of the force view without a truth: each event's estimated peak force
// against its detection time, one colour per isolated link. Throws momentum::Error without an
// event that has an estimate.
std::string force_estimate_script(const std::vector<ForceEstimate>& events, const std::string& output,
                                  const PlotOptions& options);

class ViewData {
 public:
  static constexpr std::size_t kMaxEvents = 12;  // panels of the events view
  static constexpr double kPad = 0.25;           // s shown before the onset and after the end
  static constexpr double kMaxWindow = 3.0;      // s shown at most after the detection

  // One signal of `joints` (>= 1) joints; `thresholds`: the profile's for it, or nullopt (the
  // events and histogram views then draw no threshold; mu-dq needs them); `have_velocity`:
  // add() gets dq (mu-dq needs it). `spans`: the events to show (events view). Throws
  // momentum::Error when the view cannot be drawn from what is given (mu-dq without
  // velocities or thresholds, events without events).
  ViewData(PlotView view, detect::Signal signal, std::optional<detect::Thresholds> thresholds, std::size_t joints,
           bool have_velocity, std::vector<EventSpan> spans);

  // One row at time t (s): residuals x[0..n) (Nm), velocities dq[0..n) (rad/s) or nullptr.
  void add(double t, const double* x, const double* dq);

  // The gnuplot script drawing the view into `output`; `truth` for the events view.
  std::string gnuplot_script(const std::vector<eval::TruthContact>& truth, const std::string& output,
                             const PlotOptions& options) const;

  std::uint64_t rows() const { return rows_; }
  // Rows whose residual left the detector's band, per joint (histogram view, 0 otherwise).
  std::uint64_t outside(std::size_t j) const { return outside_[j]; }

 private:
  static constexpr int kBinsPerDecade = 20, kMinDecade = -4, kMaxDecade = 4;  // |x| histogram
  static constexpr double kSpeedBin = 0.01;                                   // rad/s
  static constexpr std::size_t kSpeedBins = 1000;

  PlotView view_;
  detect::Signal signal_;
  std::optional<detect::Thresholds> thresholds_;
  std::size_t joints_;
  std::optional<detect::Detector> detector_;
  std::vector<EventSpan> spans_;
  std::uint64_t rows_ = 0;
  double t_first_ = 0, t_last_ = 0;
  // events: per shown event, rows as (t, x_1..x_n).
  std::vector<std::vector<double>> windows_;
  // histogram: counts per joint and log bin of |x|; rows outside the band per joint.
  std::vector<std::vector<std::uint64_t>> counts_;
  std::vector<std::uint64_t> outside_;
  // mu-dq: per joint and speed bin, the largest |x| and the largest upper bound seen.
  std::vector<std::vector<double>> peak_, bound_;
};

}  // namespace momentum::plot
