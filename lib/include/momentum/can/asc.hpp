#pragma once
// Vector ASC: the text log format of CANalyzer and CANoe (and python-can's ASCWriter), the
// other capture format CAN engineers have besides candump's. CandumpReader reads it when the
// input's first line is an ASC header line ("date ...", "base hex|dec ..."):
//
//   date Tue Nov 14 10:13:20.000 pm 2023
//   base hex  timestamps absolute
//   Begin Triggerblock Tue Nov 14 10:13:20.000 pm 2023
//      0.000120 1  181             Rx   d 8 A0 86 01 00 3C F6 FF FF  Length = 272000 BitCount = 140
//      0.000300 1  18FEF100x       Tx   d 2 FC E0
//      0.000400 1  282             Rx   r 2
//      0.000500 1  ErrorFrame
//      0.000600 CANFD   1 Rx        780  1 0 d 12 50 00 ...
//   End TriggerBlock
//
// Times are seconds since the start of the measurement ("timestamps relative": since the
// previous event, summed here); the channel number is the interface name (--bus 1). "base dec"
// reads identifiers and data bytes in decimal. Event lines that carry no frame (Start of
// measurement, Statistic:, chip status, TxRq) are skipped.
#include <cstdint>
#include <string_view>

#include "momentum/can/candump.hpp"
#include "momentum/can/frame.hpp"

namespace momentum::can {

// What the header lines said so far; starts as Vector's defaults.
struct AscState {
  bool decimal = false;   // "base dec": ids and data in decimal
  bool relative = false;  // "timestamps relative": each time is a delta
  std::int64_t running_ns = 0;  // sum of deltas in relative mode
};

// True when `line` is an ASC header line ("date ..." or "base ..."), as an ASC file's first
// line is and no candump line can be.
bool is_asc_header(std::string_view line);

// Parses one line of an ASC file (without its newline; a trailing '\r' is ignored). On
// LineKind::frame, `frame` holds the frame (time in frame.time_ns, has_time true) and
// info.interface the channel; header lines update `state` and return LineKind::skip, as do
// events without a frame. Never throws, never allocates.
LineKind parse_asc_line(std::string_view line, Frame& frame, ParsedLine& info, AscState& state);

}  // namespace momentum::can
