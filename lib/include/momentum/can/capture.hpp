#pragma once
// The inverse of cycle assembly: stream rows (t and mapped columns) encoded into the frames of
// a CANopen-style cycle and written as candump -L text, so that a simulated robot produces the
// capture a real one would (mo-sim --candump). What mo-can2csv reads back with the same DBC
// and column map is the same stream within each signal's resolution.

#include <cstdint>
#include <string>
#include <vector>

#include "momentum/can/cycle.hpp"
#include "momentum/can/dbc.hpp"
#include "momentum/can/frame.hpp"

namespace momentum::can {

struct CaptureOptions {
  // Interface name written in every line.
  std::string interface = "can0";
  // Send a SYNC frame (sync_key, no payload) at the start of every cycle, at the row's time.
  bool send_sync = true;
  std::uint32_t sync_key = 0x080;
  // Bus time between consecutive frames of one cycle, seconds (the first message follows the
  // SYNC by this much). 50 us is about one 8-byte frame at 1 Mbit/s.
  double frame_spacing = 50e-6;

  bool IsValid(std::string* why) const;
};

// Counters of a capture writer; all start at zero.
struct CaptureStats {
  std::uint64_t cycles = 0;
  std::uint64_t frames = 0;     // frames written, SYNC included
  std::uint64_t saturated = 0;  // values clamped to their field (or NaN written as raw 0)
};

class CaptureWriter {
 public:
  // `sources` say which column feeds which signal (see parse_column_map()). Every message with
  // a mapped signal is sent once per cycle and per multiplexer value its mapped signals need,
  // in DBC order; its unmapped signals carry raw 0. Throws momentum::Error for invalid options,
  // a source not of `db`, or a mapped signal under nested multiplexing.
  CaptureWriter(const Database& db, std::vector<ColumnSource> sources, CaptureOptions options = {});

  // Appends the candump -L lines of one cycle at time `t` (seconds) to `out`: values[c] is
  // the physical value for sources[c]. Returns the number of frames written.
  std::size_t write_cycle(double t, const double* values, std::string& out);

  // The frames of the last cycle written (for a socket or another format).
  const std::vector<Frame>& frames() const { return frames_; }
  const CaptureStats& stats() const { return stats_; }

 private:
  struct Group {
    const Message* message = nullptr;
    int selector = -1;               // multiplexer signal index, -1 when none
    std::uint64_t selector_raw = 0;  // its raw value for this group
    std::vector<std::pair<int, std::size_t>> signals;  // (signal index, source column)
  };
  std::vector<ColumnSource> sources_;
  CaptureOptions options_;
  std::vector<Group> groups_;
  std::vector<Frame> frames_;
  std::vector<double> scratch_;
  CaptureStats stats_;
};

}  // namespace momentum::can
