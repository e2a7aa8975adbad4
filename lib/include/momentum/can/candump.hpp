#pragma once
// candump text: every format can-utils' candump prints (and python-can's variants of the log
// format), read line by line in constant memory, and the log format written back. The reader
// also reads Vector ASC logs (asc.hpp), told apart by their first line.
//
//   log format (candump -L / -l, python-can):  (1436509052.249713) can0 123#11223344
//                                               (0.5) vcan0 123##1AABB R
//   default format, optional -t a|A|d|z, -x, -a, -8, -S, -i, -e:
//     (1436509052.249713)  can0  RX - -  123   [4]  11 22 33 44   '."3D'
//   DROPCOUNT lines (candump -d) report frames the kernel dropped: they count as lost frames.
//
// Parsing follows can-utils' lib.c parse_canframe() for the log format and the inverse of
// sprint_long_canframe() for the default format. No allocation per line, no iostreams.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "momentum/can/frame.hpp"

namespace momentum::can {

struct AscState;  // asc.hpp

// How to read the timestamps of the default format (log-format timestamps are always times).
enum class TimestampMode : std::uint8_t {
  automatic,  // 10+ integer digits: absolute (-t a); shorter: -t d or -t z, told apart from
              // the first 32 timestamps (deltas go down or stay constant, -t z only grows)
  absolute,   // the printed value is the time (also for -t z captures)
  delta,      // -t d: each value is the time since the previous frame
  zero,       // -t z: each value is the time since the first frame
};

// Parses "auto", "absolute", "delta" (or "d"), "zero" (or "z"); throws momentum::Error.
TimestampMode parse_timestamp_mode(std::string_view name);

// What one line of candump text holds.
enum class LineKind : std::uint8_t {
  frame,      // a CAN frame (possibly an error frame)
  dropcount,  // a DROPCOUNT line; ParsedLine::dropped frames were lost
  skip,       // blank line or '#' comment
  detail,     // a line that starts with a tab: candump -e's details of the error frame above
  bad,        // not candump text; ParsedLine::error says why
};

// How the line printed its timestamp.
enum class TimeKind : std::uint8_t {
  none,      // default format without -t
  log,       // log format: the time itself (absolute, or zero-based for candump -L -t z)
  absolute,  // default format, 10+ integer digits (-t a)
  date,      // default format -t A: local date and time, read as UTC
  relative,  // default format, fewer digits (-t d or -t z)
};

struct ParsedLine {
  LineKind kind = LineKind::bad;
  TimeKind time_kind = TimeKind::none;
  // The printed timestamp in nanoseconds (fraction digits beyond 9 are truncated).
  std::int64_t stamp_ns = 0;
  // Interface name as printed (points into the parsed line).
  std::string_view interface;
  // Frames lost according to a DROPCOUNT line.
  std::uint64_t dropped = 0;
  // Reason for a bad line (static string, lowercase, no final period).
  const char* error = "";
};

// Parses one line (without its newline; a trailing '\r' is ignored). On LineKind::frame,
// `frame` holds the frame with has_time = false and time_ns = 0; the caller turns the stamp
// into a time (see CandumpReader). Never throws, never allocates.
LineKind parse_candump_line(std::string_view line, Frame& frame, ParsedLine& info);

struct CandumpOptions {
  // Stop with momentum::Error at the first bad line instead of reporting, counting, skipping.
  bool strict = false;
  TimestampMode timestamps = TimestampMode::automatic;
  // Keep only frames from this interface (empty: all); others are counted as filtered.
  std::string interface;
  // Name of the input in messages; defaults to the path, or "<stdin>".
  std::string display_name;
};

// Counters of a candump reader; all start at zero.
struct CandumpStats {
  std::uint64_t lines = 0;         // lines read
  std::uint64_t frames = 0;        // frames returned (error frames included)
  std::uint64_t error_frames = 0;  // frames with CAN_ERR_FLAG
  std::uint64_t bad_lines = 0;     // lines reported and skipped
  std::uint64_t lost_frames = 0;   // sum of DROPCOUNT lines
  std::uint64_t filtered = 0;      // frames of other interfaces
};

// Reads candump text from a file, a descriptor or memory, frame by frame. Reading uses
// read(2) on the descriptor, so a frame that arrives on a pipe is returned as soon as its line
// is complete. Bad lines are reported through momentum::warn as `file:line: message`, counted
// and skipped; in strict mode the first one throws momentum::Error.
class CandumpReader {
 public:
  // Opens `path` ("-" or "" for stdin). Throws momentum::Error when it cannot be opened.
  static std::unique_ptr<CandumpReader> open(const std::string& path, CandumpOptions options = {});
  // Reads from a descriptor; closes it at destruction when `owns` is true.
  static std::unique_ptr<CandumpReader> from_fd(int fd, bool owns, CandumpOptions options = {});
  // Reads text held in memory (tests, fuzzing); the text is copied.
  static std::unique_ptr<CandumpReader> from_text(std::string_view text, CandumpOptions options = {});
  ~CandumpReader();
  CandumpReader(const CandumpReader&) = delete;
  CandumpReader& operator=(const CandumpReader&) = delete;

  // Fills `frame` with the next frame, its time resolved (running time for -t d), and returns
  // true; false at end of input. Throws momentum::Error on a read failure, or in strict mode.
  bool next(Frame& frame);

  const CandumpStats& stats() const { return stats_; }
  // Display name of the input.
  const std::string& name() const { return name_; }
  // Line number of the frame last returned.
  std::uint64_t line() const { return frame_line_; }
  // `file:line` of the frame last returned.
  std::string where() const;
  // True when the input is a pipe, socket or terminal.
  bool live() const { return live_; }
  // The timestamp interpretation in force (automatic until decided).
  TimestampMode timestamp_mode() const { return mode_; }

  // Called before every read(2) that may block (tools flush their output there).
  void before_read(std::function<void()> hook) { before_read_ = std::move(hook); }
  // Called when read(2) was interrupted by a signal (tools print --stats on SIGUSR1 there);
  // the read is then retried.
  void on_interrupt(std::function<void()> hook) { on_interrupt_ = std::move(hook); }

 private:
  CandumpReader() = default;
  bool next_line(std::string_view& line);
  bool parse_next(Frame& frame, ParsedLine& info);
  void resolve_time(Frame& frame, const ParsedLine& info);
  void report_bad(const char* message);
  void decide_relative_mode();

  int fd_ = -1;
  bool owns_fd_ = false;
  bool live_ = false;
  bool eof_ = false;
  std::string name_;
  CandumpOptions options_;
  TimestampMode mode_ = TimestampMode::automatic;
  std::vector<char> buffer_;
  std::size_t begin_ = 0;  // start of unread text in buffer_
  std::size_t end_ = 0;    // end of valid text in buffer_
  std::uint64_t line_no_ = 0;
  std::uint64_t frame_line_ = 0;
  bool discarding_long_line_ = false;
  bool after_error_frame_ = false;  // detail lines may follow (candump -e)
  std::int64_t running_ns_ = 0;
  CandumpStats stats_;
  // Frames held back while telling -t d from -t z (at most kProbe).
  struct Pending {
    Frame frame;
    ParsedLine info;
    std::uint64_t line;
  };
  std::vector<Pending> pending_;
  std::size_t pending_next_ = 0;
  std::function<void()> before_read_;
  std::function<void()> on_interrupt_;
  // Set when the first line is a Vector ASC header: the input is read as ASC (asc.hpp).
  std::unique_ptr<AscState> asc_;
};

// Writes a frame in the log format, `(SECONDS.MICROS) IFACE ID#DATA` plus a newline, as
// candump -L prints it (FD frames `ID##F<data>`, RTR `ID#R`, len8_dlc `_X`); 9 fraction digits
// when the time is not a whole microsecond. Returns the characters written; `out` must hold
// kMaxLogLine characters.
inline constexpr std::size_t kMaxLogLine = 96 + 2 * kMaxPayload;
std::size_t format_log_line(const Frame& frame, std::string_view interface, char* out);

}  // namespace momentum::can
