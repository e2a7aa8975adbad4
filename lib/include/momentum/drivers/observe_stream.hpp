// mo-observe's work, as a library function: a sample stream in, the same stream with residual
// columns out, in constant memory. Columns are looked up once; per row the observer reads
// t, q<j>, dq<j> and tau_m<j> (or i<j>, then tau_m = k_i i) for j = 1..nq.
//
// Output: every input column, then r<j> (and tau_f<j>, mu<j> with a friction model, and
// `restart` when asked), j = 1..nq. An output column the input already has (re-observing an
// observed log) is overwritten in place instead of duplicated.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "momentum/friction/friction.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/observer/observer.hpp"
#include "momentum/stream/reader.hpp"
#include "momentum/stream/writer.hpp"

namespace momentum::drivers {

struct ObserveStreamOptions {
  observer::ObserverOptions observer;
  // Friction model compensated inside the observer (nq joints), or nullptr for r only.
  const friction::FrictionModel* friction = nullptr;
  // Append a column `restart`: 1 on rows where r does not continue from the previous row
  // (first row, restart after a gap or after NaN rows, and the NaN rows themselves), else 0.
  bool restart_column = false;
  // Append a column `flagged`: 1 on rows left out because their signals disagree or are beyond
  // the physical limits (see run()), else 0.
  bool flag_column = false;
  // Stop at the first row whose time does not increase (Reader::reject_row) instead of
  // skipping it (mo-observe --strict).
  bool strict = false;
  // Called every 65536 rows with the rows read so far and the last time, for a progress line.
  std::function<void(std::uint64_t rows, double t)> progress;
};

// The sampling jitter of a log, learnt from the log itself, to tell lost samples from the
// ordinary spread of its intervals (real controllers write rows 10 or 12 ms apart, a simulated
// clock jitters by a tenth of its period). An interval dt is measured against the running
// median step m as e = dt / m - 1. Ordinary steps (those the observer integrates without a
// check, e <= 0.5) estimate the jitter's standard deviation as 1.2533 times their mean |e|
// (exact for normal jitter); longer steps (the observer's gaps) are counted in a histogram of e
// (bins 0.01 wide up to e = 20, constant memory). A gap is unusual for the log when its e
// exceeds both 0.5 and k standard deviations, where k is the deviation that as many normal
// steps as the log has would exceed with a chance of 1% (P(Z > k) <= exp(-k^2/2) / 2, so
// k = sqrt(2 ln(50 N))): a lost sample (e near 1) stands out of any jitter under about 15% of
// the period, and a jitter step does not pass for one.
class StepJitter {
 public:
  // One interval dt (s, > 0) after a running median step `median` (s, > 0); others are ignored.
  void add(double dt, double median);
  // Steps seen, and the gaps among them (e > 0.5).
  std::uint64_t steps() const { return ordinary_ + gaps_; }
  std::uint64_t gaps() const { return gaps_; }
  // The jitter's standard deviation estimated from the ordinary steps, in median steps (0
  // before any).
  double sigma() const;
  // The e beyond which a gap is unusual: max(0.5, k sigma).
  double gap_line() const;
  // Gaps beyond gap_line() (to within a bin), and the longest of them in median steps (1 + e;
  // 0 when none).
  std::uint64_t unusual_gaps() const;
  double longest_unusual() const;

 private:
  static constexpr double kGap = 0.5;
  static constexpr double kBin = 0.01;
  static constexpr int kBins = 2000;
  std::uint64_t ordinary_ = 0;
  std::uint64_t gaps_ = 0;
  double sum_abs_ = 0;
  double longest_ = 0;
  std::vector<std::uint64_t> histogram_ = std::vector<std::uint64_t>(kBins + 1, 0);  // last: overflow
};

struct ObserveStreamSummary {
  std::uint64_t rows_written = 0;
  std::uint64_t invalid_rows = 0;   // rows with NaN/inf inputs (written with NaN residuals)
  std::uint64_t rejected_rows = 0;  // rows whose time did not increase (not written): the sum of
  std::uint64_t duplicate_rows = 0;     //   rows equal to the previous row in every column
  std::uint64_t out_of_order_rows = 0;  //   and the other rows whose time did not increase
  std::uint64_t restarts = 0;       // restarts after a gap or after invalid rows
  std::uint64_t bridged_gaps = 0;   // gaps integrated across without a restart
  double longest_bridge = 0;        // the longest of them, s
  // The log's own timing (StepJitter): the jitter's standard deviation in median steps, and
  // the bridged gaps longer than it explains (lost samples; warned about at the end).
  double step_jitter = 0;
  std::uint64_t unusual_gaps = 0;
  double median_dt = 0;             // running median dt at the end, s
  // Rows whose signals disagree (signal_check.hpp), see StreamObserver::run:
  std::uint64_t flagged_rows = 0;       // left out and bridged (written with the held residual)
  std::uint64_t flagged_stretches = 0;  //   in this many stretches of consecutive rows
  std::uint64_t confirmed_rows = 0;     // suspect at first, then confirmed by the rows after
  std::uint64_t unresolved_rows = 0;    // suspect for longer than a bridge: taken as they are
  std::vector<double> flagged_times;    // t of the first row of the first 20 stretches, s
  // Rows whose dynamics were computed ahead with the rows after them
  // (MomentumObserver::precompute): the binary input from a file, where the CPU has AVX2.
  std::uint64_t rows_computed_ahead = 0;
};

// The stream's columns bound to an observer. Construct it before opening the output, so that
// a stream that does not fit the model fails before anything is written.
class StreamObserver {
 public:
  // Looks the columns up once. Throws momentum::Error (`stream: message`) when t, q<j>,
  // dq<j> or tau_m<j>/i<j> is missing or the stream's joint columns do not match model.nq,
  // and what MomentumObserver's constructor throws. `in` and `model` must outlive it.
  StreamObserver(stream::Reader& in, const model::Model& model, const ObserveStreamOptions& options);

  // Input columns, then the ones the observer adds.
  const std::vector<std::string>& output_columns() const { return columns_; }

  // Reads `in` to its end, writing the header and every row to `out` (comments are passed
  // through). Restarts are reported through momentum::warn once each, located at the row where
  // the observer starts again, with the time and the reason. A row whose time does not
  // increase (an exact duplicate of the previous row, or a row out of time order) is a timing
  // fault, not a bad row: it is skipped and counted (a row after a gap is held until the next
  // row arrives, and skipped alone when the next row shows it was written early, instead of
  // the rows it overtook), the first few of each kind are reported
  // through momentum::warn with their location, and the observer continues from the last good
  // row as if the row had not been there; in strict mode it is rejected through
  // Reader::reject_row (an error) when options.strict. At the end, one warning sums up the skipped rows and one the
  // bridged gaps that the log's own timing jitter does not explain (StepJitter); a log whose
  // only long steps are its ordinary jitter raises none.
  //
  // Rows whose signals disagree (options.observer.signals, signal_check.hpp): a row beyond
  // the physical limits, or whose positions and velocities disagree with the last good row, is
  // held back (not yet written) until a later row decides: when a later row agrees with the
  // last held row (beyond no limit), they were real (a fast change the sensors saw together):
  // they are processed in order, exactly as without the check, so a real impact loses nothing
  // but the wait. Otherwise, when a later row agrees with the last good row, the held rows were
  // a sensor fault: they are written with the residual held at its last value (and `flagged`
  // = 1), and the observer integrates from the last good row across them, as across a gap. A stretch longer than
  // a bridge (gap_factor median steps) is taken as it is (rows beyond the limits excepted,
  // and then the limits are not applied again until a row is within them), and one that the
  // stream ends or a bad row interrupts is left out. Each stretch left out is reported
  // through momentum::warn (the first few) with its location, time and reason; one warning at
  // the end sums them up with their times. Throws what the reader and writer throw.
  ObserveStreamSummary run(stream::Writer& out);

 private:
  stream::Reader& in_;
  const model::Model& model_;
  ObserveStreamOptions options_;
  observer::MomentumObserver observer_;
  std::vector<std::string> columns_;
  std::size_t t_index_ = 0;
  std::vector<std::size_t> q_index_, dq_index_, torque_index_;
  std::vector<double> torque_scale_;
  std::vector<std::size_t> r_out_, tau_f_out_, mu_out_;
  std::optional<std::size_t> restart_out_;
  std::optional<std::size_t> flagged_out_;
};

// StreamObserver(in, model, options).run(out).
ObserveStreamSummary observe_stream(stream::Reader& in, stream::Writer& out,
                                    const model::Model& model, const ObserveStreamOptions& options);

// The profile's "observer" section (defaults when absent). Throws momentum::Error located at
// the profile's file for a bad section; unknown keys are reported through momentum::warn.
observer::ObserverOptions observer_options_from_profile(const model::Profile& profile);

// The profile's "friction" section, or nullopt when absent. Throws momentum::Error located at
// the profile's file for a bad section or when it does not have `joints` joints; unknown keys
// are reported through momentum::warn.
std::optional<friction::FrictionModel> friction_from_profile(const model::Profile& profile, int joints);

}  // namespace momentum::drivers
