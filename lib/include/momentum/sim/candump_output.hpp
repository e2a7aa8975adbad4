// The simulated drives on a CAN bus: every sample becomes one control cycle of frames in
// candump's log format (`(SECONDS) can0 ID#DATA`), as `candump -L` would have captured it, so that
// `mo-sim --candump --dbc arm.dbc | mo-can2csv --dbc arm.dbc` gives the sample stream back
// within the encoding's resolution.
//
// A cycle: the SYNC frame (the DBC message with id 0x080, no payload signals needed) at the
// sample's time, then every other message of the DBC in file order, each with its signals
// encoded from the sample's columns of the same name (t, q<j>, dq<j>, i<j>, tau_f_true<j>,
// tau_c_true<j>) by the CAN library's encoder. Frames are spaced by min(100 us, period /
// (frames + 1)) after the SYNC, like drives answering in turn on a 1 Mbit/s bus.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "momentum/can/dbc.hpp"
#include "momentum/can/frame.hpp"
#include "momentum/sim/run.hpp"

namespace momentum::sim {

class CandumpOutput {
 public:
  // `path`: output file, "-" or "" for stdout. `nq`: joints. `period`: nominal sample period,
  // s. Throws momentum::Error when the DBC has no SYNC message (id 0x080), a non-SYNC message
  // has no signal named after a sample column, or the file cannot be created. Signals of a
  // used message that match no column are encoded as 0 and reported once through
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
  std::uint64_t frames() const { return frames_; }
  std::uint64_t saturated() const { return saturated_; }

 private:
  struct Source {
    const can::Message* message;
    std::vector<int> value_index;  // per signal: index into the sample values, -1: zero
  };
  void put(const char* text, std::size_t size);

  const can::Database* db_;
  const can::Message* sync_ = nullptr;
  std::vector<Source> sources_;
  std::string interface_;
  double spacing_ = 0;
  std::FILE* file_ = nullptr;
  bool owns_ = false;
  std::string name_;
  std::vector<double> values_, signal_values_;
  can::Frame frame_;
  std::uint64_t frames_ = 0, saturated_ = 0;
};

}  // namespace momentum::sim
