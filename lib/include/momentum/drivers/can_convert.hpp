#pragma once
// mo-can2csv's work without its option parsing: a frame source (candump text files one after
// another, or a live SocketCAN interface) with counters over all of it, and the conversion of
// its frames into a sample stream (one row per control cycle) or into signal rows (--long).
// The tool is a thin main over Converter: options in, run(), the Summary out.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "momentum/can/candump.hpp"
#include "momentum/can/cycle.hpp"
#include "momentum/can/frame.hpp"
#include "momentum/can/signal_rows.hpp"
#include "momentum/stream/format.hpp"

namespace momentum::can {
class SocketCanReader;
}  // namespace momentum::can

namespace momentum::drivers {


// Counters of a frame source, summed over every input read so far.
struct SourceStats {
  std::uint64_t frames = 0;       // frames read
  std::uint64_t bad_lines = 0;    // candump lines reported and skipped
  std::uint64_t lost_frames = 0;  // DROPCOUNT lines, kernel drops (SO_RXQ_OVFL)
  std::uint64_t bad_records = 0;  // socket records of a wrong size
  std::uint64_t filtered = 0;     // frames of another interface (CandumpOptions::interface)
};

// Frames from candump text files read one after the other ("-": stdin), or from a live
// SocketCAN interface.
class FrameSource {
 public:
  static std::unique_ptr<FrameSource> files(std::vector<std::string> paths, can::CandumpOptions options);
  // Throws momentum::Error when the interface cannot be opened.
  static std::unique_ptr<FrameSource> interface(const std::string& name);
  ~FrameSource();
  FrameSource(const FrameSource&) = delete;
  FrameSource& operator=(const FrameSource&) = delete;

  // The next frame; false at the end of the last input, or when keep_going said stop.
  bool next(can::Frame& frame);
  // Asked before each read, after each frame of text and whenever a blocking read was
  // interrupted by a signal: false ends the source as if the input had ended (the caller's
  // SIGINT and SIGTERM; it may also print statistics on SIGUSR1).
  void set_keep_going(std::function<bool()> keep_going) { keep_going_ = std::move(keep_going); }
  // Text inputs: called before a read that may wait (flush what a live pipeline should see).
  void before_read(std::function<void()> hook);

  // True for a socket, and for text read from a pipe or terminal.
  bool live() const { return live_; }
  // Where the last frame came from, for messages: `file:line`, or the interface's name.
  std::string where() const;
  SourceStats stats() const;

 private:
  FrameSource() = default;
  bool open_next_text();
  std::vector<std::string> paths_;
  std::size_t next_path_ = 0;
  can::CandumpOptions text_options_;
  std::unique_ptr<can::CandumpReader> text_;
  std::unique_ptr<can::SocketCanReader> socket_;
  std::string interface_;
  SourceStats done_;  // the inputs already closed
  std::function<bool()> keep_going_;
  std::function<void()> before_read_;
  bool live_ = false;
  bool stopped_ = false;
};

// What mo-can2csv converts, and how. Defaults are mo-can2csv(1)'s.
struct ConvertOptions {
  std::string dbc;                  // the DBC file that decodes the frames (required)
  std::vector<std::string> inputs;  // candump text files; none (and no interface): stdin
  std::string interface;            // read live from this SocketCAN interface instead
  can::CandumpOptions text;              // strict, timestamp mode, --bus
  // --long: one row per decoded signal (t,can_id,message,signal,raw,value), CSV only.
  bool long_format = false;
  // Cycle rows: which column each signal feeds (a --map file; empty: signals named q1, dq1,
  // i1, ...) and where a cycle ends (at most one of sync, cycle_message, period; none: the
  // CANopen SYNC 080).
  std::string map;
  std::string sync;           // hex can id of the cycle's boundary frame
  std::string cycle_message;  // each arrival of this DBC message
  std::optional<double> period;
  int hold = 0;  // reuse a missing value for at most this many cycles
  std::string output = "-";
  stream::Encoding encoding = stream::Encoding::csv;
  bool line_buffered = false;  // flush every row (always for live input)
  std::string provenance;      // a comment line at the head of the stream (empty: none)

  // False, with the reason, for options that do not go together.
  bool IsValid(std::string* why) const;
};

// What a conversion did: the source's counters and those of the rows it made.
struct ConvertSummary {
  enum class Mode { none, cycles, signals } mode = Mode::none;
  SourceStats source;
  can::CycleStats cycles;        // mode cycles
  can::SignalRowCounts signals;  // mode signals
  std::uint64_t rows = 0;   // rows written (cycles)
};

// The --stats report: text lines `PREFIXframes read N, ...`, or one JSON object per line.
std::string format_summary(const ConvertSummary& summary, std::string_view prefix);
std::string summary_json_line(const ConvertSummary& summary);

class Converter {
 public:
  // Loads the DBC, opens the input, works out the columns, and opens the output. Throws
  // momentum::Error (an unreadable or unusable DBC or map, an input that cannot be opened)
  // and std::invalid_argument for options that are not IsValid().
  explicit Converter(ConvertOptions options);
  ~Converter();
  Converter(const Converter&) = delete;
  Converter& operator=(const Converter&) = delete;

  // See FrameSource::set_keep_going.
  void set_keep_going(std::function<bool()> keep_going);
  // Converts every frame up to the end of the input (or a stop) and closes the output.
  // Throws stream::BrokenPipe when the reader went away, momentum::Error on a write error or a
  // bad line in strict mode.
  void run();
  // The counters so far (also while run() is going, from keep_going).
  ConvertSummary summary() const;
  // Throws momentum::Error `no rows: ...` when cycle rows were asked for and none was made (a
  // capture without its SYNC frames).
  void require_rows() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace momentum::drivers
