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

#include "momentum/friction/friction.hpp"
#include "momentum/model/model.hpp"
#include "momentum/observer/observer.hpp"
#include "momentum/stream/reader.hpp"
#include "momentum/stream/writer.hpp"

namespace momentum::observer {

struct ObserveStreamOptions {
  ObserverOptions observer;
  // Friction model compensated inside the observer (nq joints), or nullptr for r only.
  const friction::FrictionModel* friction = nullptr;
  // Append a column `restart`: 1 on rows where r does not continue from the previous row
  // (first row, restart after a gap or after NaN rows, and the NaN rows themselves), else 0.
  bool restart_column = false;
  // Called every 65536 rows with the rows read so far and the last time, for a progress line.
  std::function<void(std::uint64_t rows, double t)> progress;
};

struct ObserveStreamSummary {
  std::uint64_t rows_written = 0;
  std::uint64_t invalid_rows = 0;   // rows with NaN/inf inputs (written with NaN residuals)
  std::uint64_t rejected_rows = 0;  // rows whose time did not increase (not written)
  std::uint64_t restarts = 0;       // restarts after a gap or after invalid rows
  double median_dt = 0;             // running median dt at the end, s
};

// Reads `in` to its end, writing the header and every row to `out` (comments are passed
// through). Restarts are reported through momentum::warn once each, located at the row where
// the observer starts again, with the time. A row whose time does not increase is rejected
// through Reader::reject_row (reported with its location and skipped; an error in strict mode).
// Throws momentum::Error (`stream: message`) when a needed column is missing or the stream's
// joint columns do not match the model's nq, and whatever the reader, writer or observer throw.
ObserveStreamSummary observe_stream(stream::Reader& in, stream::Writer& out,
                                    const model::Model& model, const ObserveStreamOptions& options);

}  // namespace momentum::observer
