#pragma once
// mo-can2csv --long: one CSV row per decoded signal,
//   t,can_id,message,signal,raw,value
//   1700000000.001000,181,Drive1,q1,4096,0.785398
// for looking at a capture signal by signal. Not a sample stream (it holds names), so it has its
// own writer: write(2) through one 64 KiB buffer, flushed on demand for live captures.
#include <cstdint>
#include <string>
#include <vector>

#include "momentum/can/codec.hpp"
#include "momentum/core/file.hpp"
#include "momentum/can/dbc.hpp"
#include "momentum/can/frame.hpp"

namespace momentum::can {

// What a SignalRowWriter has seen, all starting at zero.
struct SignalRowCounts {
  std::uint64_t decoded = 0;       // frames of a DBC message
  std::uint64_t unknown_ids = 0;   // data frames of no DBC message (skipped)
  std::uint64_t short_frames = 0;  // decoded frames shorter than their message (signals past the end left out)
};

class SignalRowWriter {
 public:
  // Opens `path` for writing ("-" or empty: stdout) and writes the header. `database` must
  // outlive the writer. Throws momentum::Error naming the file when it cannot be created.
  SignalRowWriter(const Database& database, const std::string& path);
  // Flushes what is buffered (errors are ignored here: call flush() to see them).
  ~SignalRowWriter();
  SignalRowWriter(const SignalRowWriter&) = delete;
  SignalRowWriter& operator=(const SignalRowWriter&) = delete;

  // One row per signal of the frame's message; error and remote frames are skipped. Throws
  // stream::BrokenPipe when the reader of a pipe has gone, momentum::Error on other write errors.
  void write(const Frame& frame);
  // Writes out the buffer; throws like write().
  void flush();
  const SignalRowCounts& counts() const { return counts_; }

 private:
  void append(std::string_view text);

  const Database& database_;
  core::OutputFile out_;
  std::string buffer_;
  std::string row_;
  std::vector<SignalValue> values_;
  SignalRowCounts counts_;
};

// A frame's time as "1700000000.001000": 6 fraction digits, 9 when it is not a whole
// microsecond, "nan" for a frame without a time. Returns the characters written; `out` must
// hold 32 characters.
std::size_t format_frame_time(const Frame& frame, char* out);

// "0x080", "080" or "80" -> 0x080 (a standard id); 8 hex digits, or a value above 0x7FF, give
// a 29-bit id (with kExtendedFlag), as candump writes them. Throws momentum::Error on anything
// that is not 1 to 8 hex digits or is above 0x1FFFFFFF.
std::uint32_t parse_can_id(std::string_view text);

}  // namespace momentum::can
