#pragma once
// From decoded frames to sample-stream rows: which signal feeds which column, where one
// control cycle ends and the next begins, and what to write for a value that did not arrive.
//
// CANopen drives (CiA 402) answer a SYNC frame (0x080) with their TPDOs; a cycle is the SYNC
// and the frames up to the next SYNC, and becomes one row timed at its SYNC. The row goes out
// as soon as every mapped signal of the cycle is in (live, a period earlier than the next SYNC);
// a cycle with a signal missing is closed by the next boundary (SYNC, boundary message or
// period). A value that did not arrive in its cycle is stale: it is written as NaN and counted,
// unless --hold allows reusing the last value for a bounded number of cycles.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "momentum/can/codec.hpp"
#include "momentum/can/dbc.hpp"
#include "momentum/can/frame.hpp"

namespace momentum::can {

// One output column and the signal that feeds it.
struct ColumnSource {
  std::string column;
  const Message* message = nullptr;
  int signal = -1;  // index in message->signals
};

// Parses a column map: one `column = Message.Signal` per line; blank lines and lines starting
// with '#' are ignored. Throws momentum::Error (`name:line: message`) for a malformed line, an
// unknown message or signal, a column named twice, or a column named "t".
std::vector<ColumnSource> parse_column_map(std::string_view text, std::string_view name, const Database& db);
// Reads and parses a column map file.
std::vector<ColumnSource> read_column_map(const std::string& path, const Database& db);
// Columns from signals already named like stream columns (q<j>, dq<j>, ddq<j>, i<j>,
// tau_m<j>), ordered q1..qn, dq1..dqn, ddq, i, tau_m. Throws momentum::Error when two
// messages carry a signal of the same such name.
std::vector<ColumnSource> columns_from_signal_names(const Database& db);

enum class CycleBoundary : std::uint8_t {
  sync,     // a frame with the SYNC id starts a cycle (the SYNC itself carries no signal)
  message,  // each arrival of a chosen DBC message starts a cycle (its signals belong to it)
  period,   // fixed periods from the first frame's time
};

// The range of a fixed cycle period, s. Cycles are counted in whole nanoseconds of the capture
// clock: below 1 us (candump's timestamp resolution) every frame would be its own cycle, and
// the upper bound keeps the period in nanoseconds far inside 64 bits (1e10 s once overflowed
// to one row per frame).
inline constexpr double kMinPeriod = 1e-6;
inline constexpr double kMaxPeriod = 1e6;

// Whether `period` (s) is a usable cycle period; otherwise `*why` says the range.
bool valid_period(double period, std::string* why);

struct CycleOptions {
  CycleBoundary boundary = CycleBoundary::sync;
  // sync: the SYNC frame's key (Frame::key(); kExtendedFlag for a 29-bit id).
  std::uint32_t sync_key = 0x080;
  // message: the boundary message's key.
  std::uint32_t message_key = 0;
  // period: cycle length in seconds, kMinPeriod..kMaxPeriod.
  double period = 0;
  // A value missing from a cycle repeats the last one for at most this many consecutive
  // cycles; 0: never (written as NaN at once).
  int hold = 0;

  bool IsValid(std::string* why) const;
};

// Counters of an assembler; all start at zero.
struct CycleStats {
  std::uint64_t frames = 0;             // frames given to add()
  std::uint64_t decoded = 0;            // frames of a DBC message
  std::uint64_t unknown_ids = 0;        // frames whose id the DBC does not know
  std::uint64_t sync_frames = 0;        // boundary frames (sync mode)
  std::uint64_t error_frames = 0;       // error frames (ignored)
  std::uint64_t remote_frames = 0;      // RTR frames (ignored)
  std::uint64_t short_frames = 0;       // frames shorter than their message's signals need
  std::uint64_t before_first_cycle = 0; // frames before the first boundary (dropped)
  std::uint64_t complete_cycles = 0;    // rows where every column arrived in its cycle
  std::uint64_t incomplete_cycles = 0;  // rows with a held or NaN value
  std::uint64_t empty_periods = 0;      // period mode: periods without any frame (no row)
  std::uint64_t missing_values = 0;     // values written as NaN
  std::uint64_t held_values = 0;        // values reused by --hold
  std::uint64_t repeated_values = 0;    // a column fed twice in one cycle (the last before its
                                        // row went out counts)
};

// Assembles rows `t, column...` from frames in capture order. Constant memory.
class CycleAssembler {
 public:
  // Throws momentum::Error when options are invalid or a source does not belong to `db`.
  CycleAssembler(const Database& db, std::vector<ColumnSource> sources, CycleOptions options);

  // Output columns: "t" then the sources' columns.
  const std::vector<std::string>& columns() const { return columns_; }
  // Feeds one frame. Returns how many cycles it closed (0, 1 or 2): its boundary closes the
  // cycle before it when that still waits for a signal, and its signals may complete the
  // cycle it opens (the last mapped signal in: the row goes out at once). row(0), row(1) hold
  // them in order (t in seconds; NaN when the capture has no timestamps). A value arriving
  // after its cycle's row went out is counted in repeated_values and not used. Throws
  // momentum::Error in period mode for a frame without a timestamp.
  std::size_t add(const Frame& frame);
  // End of input: returns true when the last open cycle received any value; row() holds it.
  bool finish();
  // Row k (0 or 1) of those the last add() or finish() closed: columns().size() values, valid
  // until the next add()/finish().
  const double* row(std::size_t k = 0) const { return rows_[k].data(); }
  const CycleStats& stats() const { return stats_; }

 private:
  void open_cycle(double t);
  bool close_cycle();
  void take(const Frame& frame, const Message& message);

  const Database* db_;
  std::vector<ColumnSource> sources_;
  CycleOptions options_;
  std::vector<std::string> columns_;
  // For each message (by index in db.messages()): offset into signal_column_, or -1.
  std::vector<std::int32_t> message_map_;
  std::vector<std::int32_t> signal_column_;  // column index per signal, or -1
  std::vector<double> value_;                // latest value per column
  std::vector<char> fresh_;                  // arrived in the open cycle
  std::vector<int> age_;                     // cycles since the value last arrived
  std::vector<char> ever_;                   // has a value at all
  std::vector<double> rows_[2];
  std::size_t ready_ = 0;                    // rows the last add()/finish() closed
  std::size_t fresh_count_ = 0;              // columns fresh in the open cycle
  std::vector<SignalValue> decoded_;
  // open_: the cycle collects values; started_: a first boundary was seen (the cycle after an
  // early row is still the same cycle, up to its boundary).
  bool open_ = false;
  bool started_ = false;
  bool any_value_ = false;
  double cycle_t_ = 0;
  bool have_t0_ = false;
  std::int64_t t0_ns_ = 0;
  std::int64_t period_index_ = 0;
  CycleStats stats_;
};

}  // namespace momentum::can
