// What the CSV and the binary stream fuzz targets share: the input written to a file (the
// reader's real path: open(2), read(2) into its window), read in every mode, and the properties
// each read must have. Any input either fails to open with momentum::Error or reads to its end
// without crashing, leaking or undefined behaviour, and:
//   - every row has columns().size() values; rows returned + rows skipped account for the rows
//     parsed (time-order policy off: rows_read() rows come back, none is dropped by time);
//   - strict mode returns the same rows as the lenient read while that read skipped nothing,
//     and throws momentum::Error at the first bad row otherwise;
//   - with the time-order policy, every kept time is finite, a row marked none or gap is later
//     than the kept row before it, a row marked clock_step is not, and the policy's summary
//     counts the rows it kept;
//   - what was read, written again by stream::Writer as binary and as CSV, reads back as the
//     same stream: the same comments, column names and values (bit for bit, NaN as NaN);
//   - read with renames (--rename: the first column dropped, the others renamed and doubled),
//     the same rows come back, without the first column and each value times 2.
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "momentum/core/error.hpp"
#include "momentum/stream/reader.hpp"
#include "momentum/stream/writer.hpp"

namespace stream_fuzz {

using momentum::stream::Encoding;
using momentum::stream::Reader;
using momentum::stream::ReaderOptions;
using momentum::stream::TimeMark;
using momentum::stream::Writer;
using momentum::stream::WriterOptions;

inline void check(bool ok) {
  if (!ok) __builtin_trap();
}

// A file of this process's own (libFuzzer may run jobs side by side in one folder).
inline std::string scratch(const char* what) {
  return "/tmp/momentum-fuzz-" + std::to_string(::getpid()) + "-" + what;
}

inline void write_file(const std::string& path, std::string_view bytes) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  check(fd >= 0);
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd, bytes.data(), bytes.size());
    check(n > 0);
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
  ::close(fd);
}

// A stream as read: header comments, column names, and the rows and comments after the header
// in stream order (a comment is an entry of `items` with is_comment).
struct Item {
  bool is_comment = false;
  std::string comment;
  std::vector<double> values;
};
struct Stream {
  std::vector<std::string> leading_comments;
  std::vector<std::string> columns;
  std::vector<Item> items;
  std::uint64_t rows_read = 0, rows_skipped = 0;
};

inline bool same_value(double a, double b) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  return std::memcmp(&a, &b, sizeof a) == 0;  // -0 stays -0
}

// Reads `path` to its end with `options`; false when the reader throws momentum::Error (open
// or, in strict mode, a bad row).
inline bool read_stream(const std::string& path, ReaderOptions options, Stream& out) {
  try {
    auto reader = Reader::open(path, std::move(options));
    out.leading_comments = reader->leading_comments();
    out.columns = reader->columns();
    check(!out.columns.empty());
    reader->on_comment([&out](std::string_view text) {
      Item item;
      item.is_comment = true;
      item.comment = std::string(text);
      out.items.push_back(std::move(item));
    });
    std::uint64_t returned = 0;
    while (const double* row = reader->next()) {
      Item item;
      item.values.assign(row, row + out.columns.size());
      out.items.push_back(std::move(item));
      ++returned;
    }
    check(reader->next() == nullptr);  // the end stays the end
    out.rows_read = reader->rows_read();
    out.rows_skipped = reader->rows_skipped();
    check(returned == out.rows_read);  // the time-order policy is off in these reads
    return true;
  } catch (const momentum::Error&) {
    return false;
  }
}

inline bool same_stream(const Stream& a, const Stream& b) {
  if (a.leading_comments != b.leading_comments || a.columns != b.columns || a.items.size() != b.items.size())
    return false;
  for (std::size_t i = 0; i < a.items.size(); ++i) {
    const Item& x = a.items[i];
    const Item& y = b.items[i];
    if (x.is_comment != y.is_comment || x.comment != y.comment || x.values.size() != y.values.size()) return false;
    for (std::size_t k = 0; k < x.values.size(); ++k)
      if (!same_value(x.values[k], y.values[k])) return false;
  }
  return true;
}

// Writes `stream` with stream::Writer to `path` in `encoding`.
inline void write_stream(const Stream& stream, const std::string& path, Encoding encoding) {
  WriterOptions options;
  options.encoding = encoding;
  auto writer = Writer::open(path, options);
  for (const std::string& c : stream.leading_comments) writer->comment(c);
  writer->header(stream.columns);
  for (const Item& item : stream.items) {
    if (item.is_comment)
      writer->comment(item.comment);
    else
      writer->row(item.values.data());
  }
  writer->close();
}

// The CSV round trip is exact only for text CSV can carry as it is: the writer splits a comment
// with a line break into one '#' line per line, quotes a name with a separator and refuses one
// with a control character (mo-log(5)), so the comparison below skips streams that hold either.
inline bool csv_can_carry(const Stream& s) {
  auto plain = [](std::string_view text, bool is_name) {
    for (char c : text) {
      if (c == '\n' || c == '\r' || c == '\0' || (is_name && c == ',')) return false;
      // The CSV writer refuses a name with a control character (mo-log(5)).
      if (is_name && (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)) return false;
    }
    if (is_name) {
      if (text.empty() || text.front() == '#' || text.front() == ' ' || text.front() == '\t' ||
          text.back() == ' ' || text.back() == '\t' || text.starts_with("\xEF\xBB\xBF"))
        return false;
    }
    return true;
  };
  for (const auto& c : s.leading_comments)
    if (!plain(c, false)) return false;
  for (const auto& c : s.columns)
    if (!plain(c, true)) return false;
  for (const auto& item : s.items)
    if (item.is_comment && !plain(item.comment, false)) return false;
  // A header of one name that is blank, or a comment-only file, has no CSV form either.
  return !s.columns.empty();
}

// With the time-order policy: kept times are finite, and each kept row is later than the one
// before it unless it is marked as a clock step back.
inline void check_time_marks(const std::string& path) {
  try {
    auto reader = Reader::open(path, ReaderOptions{});
    const auto t_column = reader->find("t");
    reader->on_comment([](std::string_view) {});
    bool first = true;
    double last = 0;
    std::uint64_t returned = 0;
    while (const double* row = reader->next()) {
      ++returned;
      if (!t_column) continue;
      const double t = row[*t_column];
      check(std::isfinite(t));
      if (!first) check(reader->time_mark() == TimeMark::clock_step ? t <= last : t > last);
      first = false;
      last = t;
    }
    if (const auto* summary = reader->time_summary()) {
      check(summary->kept == returned);
      check(summary->kept + summary->dropped() == reader->rows_read());
      check(summary->dropped() <= reader->rows_skipped());
    } else {
      check(returned == reader->rows_read());
    }
  } catch (const momentum::Error&) {
  }
}

// Renaming as the stream is read (ReaderOptions::renames): with the first column dropped and
// every other renamed to c<k> and doubled, the rows are the plain read's, less its first
// column, times 2 (the same IEEE product either way, so equal bit for bit).
inline void check_renamed(const std::string& path, const Stream& plain) {
  ReaderOptions options;
  options.time_order = false;
  for (std::size_t k = 0; k < plain.columns.size(); ++k)
    options.renames.push_back({plain.columns[k], k == 0 ? "_" : "c" + std::to_string(k), k == 0 ? 1.0 : 2.0, false,
                               "--rename", k});
  Stream renamed;
  const bool ok = read_stream(path, options, renamed);
  check(ok == (plain.columns.size() > 1));  // dropping the only column is refused
  if (!ok) return;
  check(renamed.columns.size() + 1 == plain.columns.size());
  check(renamed.items.size() == plain.items.size());
  for (std::size_t i = 0; i < plain.items.size(); ++i) {
    const Item& a = plain.items[i];
    const Item& b = renamed.items[i];
    check(a.is_comment == b.is_comment);
    if (a.is_comment) continue;
    for (std::size_t k = 1; k < a.values.size(); ++k) check(same_value(a.values[k] * 2.0, b.values[k - 1]));
  }
}

// The whole check on one input.
inline void run_one(std::string_view bytes) {
  static const bool quiet = [] {
    momentum::set_warning_sink([](std::string_view) {});
    momentum::set_row_warning_sink([](std::string_view, std::string_view) {});
    return true;
  }();
  (void)quiet;
  const std::string input = scratch("input");
  write_file(input, bytes);

  ReaderOptions plain;
  plain.time_order = false;
  Stream lenient;
  if (!read_stream(input, plain, lenient)) return;

  ReaderOptions strict = plain;
  strict.strict = true;
  Stream strict_read;
  const bool strict_ok = read_stream(input, strict, strict_read);
  check(strict_ok == (lenient.rows_skipped == 0));
  if (strict_ok) check(same_stream(lenient, strict_read));

  check_time_marks(input);
  check_renamed(input, lenient);

  const std::string copy = scratch("copy");
  write_stream(lenient, copy, Encoding::binary);
  Stream back;
  check(read_stream(copy, strict, back));
  check(same_stream(lenient, back));

  if (csv_can_carry(lenient)) {
    write_stream(lenient, copy, Encoding::csv);
    Stream csv_back;
    check(read_stream(copy, strict, csv_back));
    check(same_stream(lenient, csv_back));
  }
}

}  // namespace stream_fuzz
