// The simulated drives on a CAN bus: every sample becomes one control cycle of frames in
// candump's log format (`(SECONDS) can0 ID#DATA`), as `candump -L` would have captured it, so that
// `mo-sim --candump --dbc arm.dbc | mo-can2csv --dbc arm.dbc` gives the sample stream back
// within the encoding's resolution.
//
// A cycle: the SYNC frame (the DBC message with id 0x080, no payload signals needed) at the
// sample's time, then every other message of the DBC in file order, each with its signals
// encoded from the sample's columns of the same name (t, q<j>, dq<j>, i<j>, tau_f_true<j>,
// tau_c_true<j>) by the CAN library's capture writer (can::CaptureWriter, the same encoder
// mo-can2csv's decoder is tested against). Frames are spaced by min(100 us, period /
// (frames + 1)) after the SYNC, like drives answering in turn on a 1 Mbit/s bus.
#pragma once

#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "momentum/can/capture.hpp"
#include "momentum/core/file.hpp"
#include "momentum/can/dbc.hpp"
#include "momentum/sim/run.hpp"

namespace momentum::sim {

class CandumpOutput {
 public:
  // `path`: output file, "-" or "" for stdout. `nq`: joints. `period`: nominal sample period,
  // s. Throws momentum::Error when the DBC has no SYNC message (id 0x080), a non-SYNC message
  // has no signal named after a sample column, or the file cannot be created. Signals of a
  // used message that match no column carry raw 0 and are reported once through
  // momentum::warn.
  CandumpOutput(const can::Database& db, const std::string& path, int nq, double period,
                std::string interface = "can0");
  ~CandumpOutput();
  CandumpOutput(const CandumpOutput&) = delete;
  CandumpOutput& operator=(const CandumpOutput&) = delete;

  // Writes one cycle for the sample. Throws stream::BrokenPipe when the reader went away and
  // momentum::Error on another write failure.
  void write(const Sample& sample);
  // Flushes and closes; throws momentum::Error on a write failure.
  void close();

  // Frames written, and values clamped to their signal's range by the encoder.
  std::uint64_t frames() const { return writer_->stats().frames; }
  std::uint64_t saturated() const { return writer_->stats().saturated; }

 private:
  void put(const std::string& text);

  std::vector<std::size_t> columns_;  // per capture source: its index in sample_columns()
  std::optional<can::CaptureWriter> writer_;
  std::optional<core::OutputFile> out_;  // opened once the DBC has been checked
  std::string buffer_;
  std::vector<double> row_, values_;
  std::string text_;
};

}  // namespace momentum::sim
