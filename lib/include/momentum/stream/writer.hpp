#pragma once
// Writes a sample stream, CSV or binary, to a file or stdout ("-"), through one buffer written
// with write(2) to a core::OutputFile (its policy for "-", a closed pipe and a full disk). Output is flushed when the buffer fills, when flush() is called, after every
// row in line-buffered mode, and at close.

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "momentum/core/file.hpp"
#include "momentum/stream/format.hpp"

namespace momentum::stream {

// Thrown when the reader of our output went away (EPIPE). Tools end quietly with status 0.
using BrokenPipe = core::BrokenPipe;

struct WriterOptions {
  Encoding encoding = Encoding::csv;
  // Flush after every row (live pipelines); otherwise flush when the 256 KiB buffer is full.
  bool line_buffered = false;
};

class Writer {
 public:
  // Opens `path` ("-" or "" for stdout; a file is created or truncated) with core::OutputFile.
  // Throws momentum::Error naming the path when it cannot be opened (a missing folder, a
  // folder, a read-only file, a symlink loop) or is an input of the run, and for
  // Encoding::mcap (bags are read only).
  static std::unique_ptr<Writer> open(const std::string& path, WriterOptions options = {});
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // A comment line (text without '#'). Before header(): part of the header; after: in stream
  // order (a comment record in binary).
  void comment(std::string_view text);
  // The column names; must be called once, before the first row.
  void header(const std::vector<std::string>& columns);
  // One row of columns().size() values.
  void row(const double* values);
  void flush();
  // Flushes and closes; throws momentum::Error on a write failure. Called by the destructor
  // (which swallows errors) if not called explicitly.
  void close();

  Encoding encoding() const { return options_.encoding; }
  std::size_t width() const { return width_; }
  std::uint64_t rows_written() const { return rows_written_; }
  // True when the output is a pipe, socket or terminal.
  bool interactive() const { return out_->interactive(); }
  void set_line_buffered(bool on) { options_.line_buffered = on; }

 private:
  Writer() = default;
  void append(const void* data, std::size_t size);
  void write_all(const char* data, std::size_t size);
  std::unique_ptr<core::OutputFile> out_;
  bool closed_ = false;
  bool header_written_ = false;
  WriterOptions options_;
  std::size_t width_ = 0;
  std::uint64_t rows_written_ = 0;
  std::vector<std::string> pending_comments_;
  std::vector<char> buffer_;
  std::size_t used_ = 0;
};

}  // namespace momentum::stream
