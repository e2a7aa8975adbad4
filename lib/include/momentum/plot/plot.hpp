#pragma once
// Figures of residuals against thresholds (mo-plot): one panel per joint and signal, r and mu
// side by side like the paper's Figures 5 to 7, detected events and true contacts marked,
// drawn by gnuplot. A log of any length is decimated while it is read, to the minimum and
// maximum of each time bucket, so peaks survive and memory stays constant.

#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "momentum/detect/detector.hpp"
#include "momentum/detect/events.hpp"
#include "momentum/detect/thresholds.hpp"
#include "momentum/eval/truth.hpp"

namespace momentum::plot {

// Ranges of PlotOptions' sizes. No image is wider than kMaxPlotWidth pixels, so more than
// kMaxPlotPoints time buckets (each drawn as its minimum and maximum) add nothing visible; the
// bound also keeps the decimated data small (buckets x signals x joints).
inline constexpr int kMinPlotWidth = 200, kMaxPlotWidth = 20000;
inline constexpr int kMinPanelHeight = 80, kMaxPanelHeight = 5000;
inline constexpr std::size_t kMinPlotPoints = 10, kMaxPlotPoints = 100000;

struct PlotOptions {
  std::string format = "png";     // "png", "svg" or "pdf" (plot_format)
  int width = 1400;               // pixels, kMinPlotWidth..kMaxPlotWidth
  int panel_height = 220;         // pixels per joint row, kMinPanelHeight..kMaxPanelHeight
  std::size_t max_points = 2000;  // time buckets per panel, kMinPlotPoints..kMaxPlotPoints
  double from = -INFINITY;        // time window, s
  double to = INFINITY;
  std::string title;              // empty: none; no control characters (check_gnuplot_text)
  // The band mu's thresholds were calibrated with (plot_thresholds gives it); empty: none.
  detect::FrictionBand friction_band;
  bool IsValid(std::string* why) const;
};

// The decimated figure data: for each signal and joint, per time bucket, the range of the
// residual and of the acceptance band that mo-detect applies (Detector::bounds).
class PlotData {
 public:
  // `signals` in panel order (columns); `thresholds[i]` those of signals[i], or nullopt (no
  // band drawn); `joints` >= 1; `have_velocity`: add() gets dq (rest state, envelopes).
  PlotData(std::vector<detect::Signal> signals, std::vector<std::optional<detect::Thresholds>> thresholds, std::size_t joints,
           bool have_velocity, PlotOptions options);

  // One row: time t (s), x[i][j] residual of signal i joint j (Nm), dq[j] (rad/s, or nullptr
  // without velocities). Rows outside [from, to] only advance the detectors' rest state.
  void add(double t, const double* const* x, const double* dq);

  std::size_t joints() const { return joints_; }
  const std::vector<detect::Signal>& signals() const { return signals_; }
  bool has_band(std::size_t signal) const { return detectors_[signal].has_value(); }
  std::uint64_t rows() const { return rows_; }

  struct Range {
    double lo = INFINITY, hi = -INFINITY;
  };
  struct Bucket {
    double t0 = 0, t1 = 0;        // first and last row time, s
    std::vector<Range> value;     // per (signal, joint): residual min..max
    // Per (signal, joint): the narrowest acceptance band of the bucket, from the largest lower
    // bound to the smallest upper bound (-inf..inf when no threshold).
    std::vector<Range> band;
  };
  const std::vector<Bucket>& buckets() const { return buckets_; }
  std::size_t series(std::size_t signal, std::size_t joint) const { return signal * joints_ + joint; }

 private:
  void merge_pairs();
  std::vector<detect::Signal> signals_;
  std::size_t joints_;
  bool have_velocity_;
  PlotOptions options_;
  std::vector<std::optional<detect::Detector>> detectors_;
  std::vector<Bucket> buckets_;
  double width_ = 0;  // current bucket width, s (0: one row per bucket)
  std::uint64_t rows_ = 0;
};

// The gnuplot script that draws `data` with `events` (vertical lines at t_detect, labelled with
// the isolated link) and `truth` (shaded from onset to end) into `output`.
std::string gnuplot_script(const PlotData& data, const std::vector<detect::Event>& events,
                           const std::vector<eval::TruthContact>& truth, const std::string& output,
                           const PlotOptions& options);

// Throws momentum::Error "`what` holds a control character (...)" when `text` has a byte below
// 0x20 or 0x7f. Text goes into gnuplot scripts only as single-quoted strings, where nothing
// but the quote is special (no backquote or macro substitution); a newline would end the
// command and start the next one (`set title 'a\nsystem "..."'` runs a shell command), and
// gnuplot has no escape for it in such strings, so it is refused.
void check_gnuplot_text(std::string_view text, std::string_view what);

// `text` as a gnuplot single-quoted string: '' stands for one quote. Throws as
// check_gnuplot_text for a control character.
std::string gnuplot_string(const std::string& text);

// The image format for `output` ("-": standard output) and --format `format` ("" when not
// given): the file name's extension .png, .svg or .pdf (any case), else `format`, else png for
// a name without extension or "-". Throws momentum::Error when a given format and the
// extension disagree, or when the extension is another one and no format is given (mo-plot
// once wrote a PNG named x.pdf).
std::string plot_format(const std::string& output, const std::string& format);

// The start of every figure's script: the terminal for an image of options.width x `height`
// pixels in options.format (png through pngcairo when gnuplot has it; pdf through pdfcairo at
// 72 pixels per inch, the pixel size of pngcairo's points, or gnuplot exits with a message
// when it lacks pdfcairo), and the output file
// (`output` "-": standard output, as everywhere in the suite).
std::string gnuplot_output(const PlotOptions& options, int height, const std::string& output);

// Runs gnuplot on `script`. Throws momentum::Error when gnuplot cannot be run or fails (its
// own messages go to stderr).
void run_gnuplot(const std::string& script);

}  // namespace momentum::plot
