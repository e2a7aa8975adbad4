#pragma once
// mo-plot's figures of a stream, read as mo-plot reads it: which residual columns to draw, the
// profile's thresholds for them, and the rows read into the figure data of the time view
// (plot.hpp) or of another view (plot_views.hpp), down to the gnuplot script.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "momentum/detect/events.hpp"
#include "momentum/eval/truth.hpp"
#include "momentum/plot/plot.hpp"
#include "momentum/plot/plot_views.hpp"
#include "momentum/detect/thresholds.hpp"
#include "momentum/stream/reader.hpp"

namespace momentum::drivers {

// The columns of a stream that a figure draws.
struct PlotColumns {
  std::size_t time = 0;                          // column of t
  std::vector<detect::Signal> signals;                   // in panel order
  std::size_t joints = 0;                        // n, >= 1
  std::vector<std::vector<std::size_t>> values;  // per signal, its columns <signal>1..n
  std::vector<std::size_t> velocity;             // dq1..n, empty when the stream lacks them
  std::size_t view_signal = 0;                   // index in signals of the one a view other than time draws
};

// The columns of `signals` in `in` (t, <signal>1..n with n from the first signal, dq1..n when
// all are there). `signals` empty: those the stream has, r first, and the views other than
// time draw mu when the stream has it (what mo-detect uses); else the views draw the first
// one. Throws momentum::Error naming the stream when t is missing, when it has neither r1 nor
// mu1 (and `signals` is empty), or when a signal's columns are missing.
PlotColumns plot_columns(const stream::Reader& in, const std::vector<detect::Signal>& signals);

// The thresholds of each of `signals` from the profile at `profile_path` (empty: none), nullopt
// for a signal the profile has none for (warned about through momentum::warn: no band is
// drawn). `friction_band` (when non-null) gets the band mu's thresholds were calibrated with
// (friction_band.hpp), for PlotOptions::friction_band. Throws what model::load_profile,
// thresholds_from_profile and friction_band_from_profile throw.
std::vector<std::optional<detect::Thresholds>> plot_thresholds(const std::string& profile_path,
                                                       const std::vector<detect::Signal>& signals,
                                                       detect::FrictionBand* friction_band = nullptr);

// Reads the rows of `in` into the figure of `view` (not force) and returns its gnuplot script,
// which draws `output` with `events` and the `truth` contacts marked. Rows whose time goes
// backwards are rejected (stream::Reader::reject_row); in the time view, a row the stream
// marks as a clock step goes on from the last row's time (warned about), so that the time axis
// does not draw over earlier rows. Throws momentum::Error when no row is left to plot (in
// options' time window), and what the reader and the script throw.
std::string stream_plot_script(stream::Reader& in, const PlotColumns& columns,
                               const std::vector<std::optional<detect::Thresholds>>& thresholds, plot::PlotView view,
                               const std::vector<detect::Event>& events, const std::vector<eval::TruthContact>& truth,
                               const std::string& output, const plot::PlotOptions& options);

// The force view (mo-plot --view force) of mo-detect's events at `events_path`: with a truth
// file ("": none), the estimated peak force of each detected contact against its true one
// (matched by eval::score, default window); without, the estimates over time. `strict`: a bad
// event row is an error (eval::read_detections). Throws momentum::Error when no event has an
// estimated force (without truth), and what reading the files and the script throw.
std::string force_plot_script(const std::string& events_path, const std::string& truth_path, bool strict,
                              const std::string& output, const plot::PlotOptions& options);

}  // namespace momentum::drivers
