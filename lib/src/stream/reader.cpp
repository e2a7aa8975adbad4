#include "momentum/stream/reader.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <iterator>
#include <unordered_set>

#include "momentum/core/error.hpp"
#include "momentum/core/file.hpp"
#include "momentum/core/text.hpp"
#include "momentum/stream/columns.hpp"
#include "momentum/stream/mcap.hpp"
#include "mcap_reader.hpp"

static_assert(std::endian::native == std::endian::little,
              "the binary stream format is little-endian; add byte swapping for this host");

namespace momentum::stream {

void Reader::skip_bad(std::string_view kind, std::string_view message) {
  std::string text = location(raw_position_) + ": " + std::string(message);
  if (strict_) throw Error(text);
  ++rows_skipped_;
  note_skip(raw_position_);
  warn_row(kind, text);
}

void Reader::note_skip(std::uint64_t position) {
  // Merge with the last run when no good row was parsed since it began.
  if (!pending_skips_.empty() && pending_skips_.back().last <= position &&
      (!have_good_ || pending_skips_.back().last > last_good_position_)) {
    pending_skips_.back().last = position;
    ++pending_skips_.back().count;
    return;
  }
  auto at = pending_skips_.end();
  while (at != pending_skips_.begin() && std::prev(at)->last > position) --at;
  pending_skips_.insert(at, SkipRun{position, 1});
}

void Reader::settle_skips(bool at_end) {
  std::size_t done = 0;
  while (done < pending_skips_.size() && (at_end || pending_skips_[done].last < position_))
    skipped_before_ += pending_skips_[done++].count;
  pending_skips_.erase(pending_skips_.begin(), pending_skips_.begin() + static_cast<std::ptrdiff_t>(done));
}

void Reader::reject_row(std::string_view kind, std::string_view detail) {
  std::string text = where() + ": " + std::string(kind);
  if (!detail.empty()) text += ": " + std::string(detail);
  if (strict_) throw Error(text);
  ++rows_skipped_;
  note_skip(position_);
  warn_row(kind, text);
}

bool Reader::follows_in_time(double t, double t_previous) {
  if (time_order_) return true;
  if (!std::isfinite(t)) {
    reject_row(time_fault_name(TimeFault::not_finite), "t=" + core::exact(t));
    return false;
  }
  if (!(t > t_previous)) {
    reject_row(time_fault_name(TimeFault::out_of_order), "t=" + core::exact(t) + " after t=" + core::exact(t_previous));
    return false;
  }
  return true;
}

void Reader::warn_clock_step(std::string_view consequence) const {
  warn(where() + ": the clock stepped back: " + std::string(consequence));
}

void Reader::start_time_order(const ReaderOptions& options) {
  const auto t = find("t");
  if (!options.time_order || !t) return;
  time_order_ = std::make_unique<TimeOrder>(
      columns_.size(), *t, [this](std::uint64_t position, TimeFault fault, const std::string& detail) {
        std::string text = location(position) + ": " + std::string(time_fault_name(fault)) + ": " + detail;
        if (strict_) throw Error(text);
        ++rows_skipped_;
        note_skip(position);
        warn_row(time_fault_name(fault), text + ": skipped");
      });
}

void Reader::stop() {
  if (ended_) return;
  ended_ = true;
  if (time_order_) time_order_->finish();
}

const double* Reader::next() {
  if (!time_order_) {
    const double* row = ended_ ? nullptr : mapped(read_row());
    position_ = raw_position_;
    if (row && rows_returned_) ++*rows_returned_;
    settle_skips(row == nullptr);
    return row;
  }
  for (;;) {
    if (const TimeOrder::Row* row = time_order_->pop()) {
      position_ = row->position;
      time_mark_ = row->mark;
      if (rows_returned_) ++*rows_returned_;
      settle_skips(false);
      return row->values.data();
    }
    if (ended_) {
      settle_skips(true);
      return nullptr;
    }
    const double* raw = mapped(read_row());
    if (raw) {
      last_good_position_ = raw_position_;
      have_good_ = true;
      if (time_order_->pass(raw)) {
        // In time order: handed on as read, not copied through the policy's queue.
        position_ = raw_position_;
        time_mark_ = TimeMark::none;
        if (rows_returned_) ++*rows_returned_;
        settle_skips(false);
        return raw;
      }
      time_order_->push(raw, raw_position_);
    } else {
      ended_ = true;
      time_order_->finish();
    }
  }
}

std::size_t Reader::peek(double* rows, std::size_t max) {
  if (ended_ || !mapped_from_.empty() || (time_order_ && !time_order_->idle())) return 0;
  return peek_rows(rows, max);
}

void Reader::start_renames(const std::vector<ColumnRename>& renames) {
  if (renames.empty()) return;
  const RenamedHeader renamed = apply_renames(columns_, renames, name_);
  std::vector<std::string> columns;
  for (std::size_t i = 0; i < renamed.names.size(); ++i) {
    if (renamed.names[i] == "_") continue;
    columns.push_back(renamed.names[i]);
    mapped_from_.push_back(i);
    mapped_scale_.push_back(renamed.scales[i]);
  }
  if (columns.empty()) throw Error(name_ + ": " + renames.front().origin + ": every column is dropped");
  columns_ = std::move(columns);
  mapped_row_.resize(columns_.size());
}

const double* Reader::mapped(const double* raw) {
  if (!raw || mapped_from_.empty()) return raw;
  for (std::size_t i = 0; i < mapped_from_.size(); ++i) mapped_row_[i] = raw[mapped_from_[i]] * mapped_scale_[i];
  return mapped_row_.data();
}

Separator parse_separator(std::string_view name) {
  if (name == "auto" || name == "detect") return Separator::detect;
  if (name == "comma" || name == ",") return Separator::comma;
  if (name == "semicolon" || name == ";") return Separator::semicolon;
  if (name == "tab" || name == "\\t" || name == "\t") return Separator::tab;
  if (name == "space" || name == "blanks" || name == "whitespace" || name == " ") return Separator::blanks;
  throw Error("unknown separator '" + core::printable(name) + "' (auto, comma, semicolon, tab or space)");
}

std::optional<std::size_t> Reader::find(std::string_view column) const {
  for (std::size_t i = 0; i < columns_.size(); ++i)
    if (columns_[i] == column) return i;
  return std::nullopt;
}

std::size_t Reader::require(std::string_view column) const {
  if (auto index = find(column)) return *index;
  throw Error(missing_column_message(columns_, column, name_));
}

namespace {

// Owns the descriptor and a growable window over the input. Memory is bounded by the longest
// line (CSV) or record (binary, MCAP), never by the length of the stream.
class Input final : public mcap::ByteSource {
 public:
  Input(int fd, bool owns, std::string name) : fd_(fd), owns_(owns), name_(std::move(name)) {
    buffer_.resize(1 << 20);
  }
  ~Input() {
    if (owns_ && fd_ >= 0) core::close_input(fd_);
  }
  Input(const Input&) = delete;
  Input& operator=(const Input&) = delete;

  const char* data() const override { return buffer_.data() + begin_; }
  std::size_t available() const override { return end_ - begin_; }
  void consume(std::size_t n) override {
    begin_ += n;
    offset_ += n;
  }
  std::uint64_t offset() const override { return offset_; }
  bool eof() const { return eof_; }

  // Reads more bytes after the available ones; false at end of input.
  bool fill() {
    if (eof_) return false;
    if (begin_ > 0 && begin_ == end_) {
      begin_ = end_ = 0;
    } else if (begin_ > buffer_.size() / 2 || end_ == buffer_.size()) {
      std::memmove(buffer_.data(), buffer_.data() + begin_, end_ - begin_);
      end_ -= begin_;
      begin_ = 0;
    }
    if (end_ == buffer_.size()) buffer_.resize(buffer_.size() * 2);
    if (before_read && *before_read) (*before_read)();
    for (;;) {
      ssize_t got = ::read(fd_, buffer_.data() + end_, buffer_.size() - end_);
      if (got > 0) {
        end_ += static_cast<std::size_t>(got);
        return true;
      }
      if (got == 0) {
        eof_ = true;
        return false;
      }
      if (errno == EINTR) continue;
      throw Error(name_ + ": read error: " + std::strerror(errno));
    }
  }

  // Ensures at least n bytes are available; false if the input ends first.
  bool want(std::size_t n) override {
    while (available() < n)
      if (!fill()) return false;
    return true;
  }

 private:
  int fd_;
  bool owns_;
  std::string name_;
  std::vector<char> buffer_;
  std::size_t begin_ = 0, end_ = 0;
  std::uint64_t offset_ = 0;
  bool eof_ = false;
};

using core::printable;

// A CSV line longer than this is not a stream's row (binary data, or no newlines at all): it
// is skipped as a bad row without being held in memory.
constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;

void check_columns(const std::vector<std::string>& columns, const std::string& where) {
  std::unordered_set<std::string_view> seen;
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (columns[i].empty())
      throw Error(where + ": empty column name (column " + std::to_string(i + 1) + ")");
    if (!seen.insert(columns[i]).second)
      throw Error(where + ": duplicate column name '" + printable(columns[i]) + "'");
  }
}

using core::trim;

// One field of a CSV line: its text (for a quoted field, between the quotes, "" not yet
// undone) and whether it was quoted.
struct Field {
  std::string_view text;
  bool quoted = false;
};

// How the fields of a line are separated: one character, or runs of blanks.
struct FieldSeparator {
  char delimiter = ',';
  bool blanks = false;  // runs of spaces and tabs; blanks at either end ignored
};

// The separator of a header (or, with --names, of the first row): the first of comma,
// semicolon and tab that occurs outside quotes, else runs of blanks when the line has some
// between fields, else a comma (one column).
FieldSeparator detect_separator(std::string_view line) {
  bool quoted = false, comma = false, semicolon = false, tab = false, blank = false;
  const std::string_view inner = trim(line);
  for (char c : inner) {
    if (c == '"') quoted = !quoted;
    if (quoted) continue;
    comma = comma || c == ',';
    semicolon = semicolon || c == ';';
    tab = tab || c == '\t';
    blank = blank || c == ' ';
  }
  if (comma) return {',', false};
  if (semicolon) return {';', false};
  if (tab) return {'\t', false};
  if (blank) return {' ', true};
  return {',', false};
}

// The separator an option names, or the one `line` shows.
FieldSeparator choose_separator(Separator option, std::string_view line) {
  switch (option) {
    case Separator::comma: return {',', false};
    case Separator::semicolon: return {';', false};
    case Separator::tab: return {'\t', false};
    case Separator::blanks: return {' ', true};
    case Separator::detect: break;
  }
  return detect_separator(line);
}

// Splits `line` into `fields` (cleared first). A field may be double-quoted ("" for a quote
// inside, the separator allowed inside, blanks around the quotes ignored). Returns nullptr,
// or why the line cannot be split: an unterminated quote, or text after a closing quote.
const char* split_fields(std::string_view line, FieldSeparator separator, std::vector<Field>& fields) {
  fields.clear();
  const std::size_t n = line.size();
  auto blank = [&](char c) { return c == ' ' || (c == '\t' && separator.delimiter != '\t'); };
  std::size_t i = 0;
  if (separator.blanks) {
    while (i < n && blank(line[i])) ++i;
    if (i == n) return nullptr;
  }
  for (;;) {
    const std::size_t start = i;
    std::size_t at = i;
    while (at < n && blank(line[at])) ++at;
    if (at < n && line[at] == '"') {
      const std::size_t content = ++at;
      for (;;) {
        if (at >= n) return "unterminated quote";
        if (line[at] == '"') {
          if (at + 1 < n && line[at + 1] == '"') {
            at += 2;
            continue;
          }
          break;
        }
        ++at;
      }
      fields.push_back({line.substr(content, at - content), true});
      const std::size_t closing = at++;
      while (at < n && blank(line[at])) ++at;
      if (at == n) return nullptr;
      if (separator.blanks) {
        if (at == closing + 1) return "text after a closing quote";
        i = at;
        continue;
      }
      if (line[at] != separator.delimiter) return "text after a closing quote";
      i = at + 1;
      continue;
    }
    if (separator.blanks) {
      std::size_t end = at;
      while (end < n && !blank(line[end])) ++end;
      fields.push_back({line.substr(at, end - at), false});
      while (end < n && blank(line[end])) ++end;
      if (end == n) return nullptr;
      i = end;
      continue;
    }
    const std::size_t end = std::min(n, line.find(separator.delimiter, start));
    fields.push_back({line.substr(start, end - start), false});
    if (end == n) return nullptr;
    i = end + 1;
  }
}

// A header field as a column name: a quoted one with "" undone, another one trimmed.
std::string field_name(const Field& field) {
  if (!field.quoted) return std::string(trim(field.text));
  std::string out;
  for (std::size_t i = 0; i < field.text.size(); ++i) {
    out += field.text[i];
    if (field.text[i] == '"') ++i;  // the second quote of ""
  }
  return out;
}

// What both encodings' readers start with: their input, name and options.
class InputReader : public Reader {
 protected:
  InputReader(std::unique_ptr<Input> input, std::string display, const ReaderOptions& options, Encoding encoding)
      : in_(std::move(input)) {
    name_ = std::move(display);
    strict_ = options.strict;
    encoding_ = encoding;
    before_read_ = options.before_read;
    in_->before_read = &before_read_;
  }
  std::unique_ptr<Input> in_;
};

class CsvReader final : public InputReader {
 public:
  CsvReader(std::unique_ptr<Input> input, std::string display, const ReaderOptions& options)
      : InputReader(std::move(input), std::move(display), options, Encoding::csv) {
    std::string_view line;
    bool have_line = false;
    while (next_line(line)) {
      if (!line.empty() && line.front() == '#') {
        leading_comments_.emplace_back(line.substr(1));
        continue;
      }
      if (trim(line).empty()) continue;
      have_line = true;
      break;
    }
    if (options.names.empty()) {
      if (!have_line) {
        if (line_number_ == 0) throw Error(name() + ": empty input");
        throw Error(name() + ": no header line (only comments)");
      }
      separator_ = choose_separator(options.separator, line);
      if (const char* why = split_fields(line, separator_, split_))
        throw Error(located(name(), line_number_, std::string("header: ") + why));
      for (const Field& field : split_) columns_.push_back(field_name(field));
      check_columns(columns_, located(name(), line_number_, "header"));
      for (std::size_t i = 0; i < columns_.size(); ++i) keep_.push_back(i);
      fields_ = columns_.size();
      field_names_ = columns_;
    } else {
      if (!have_line && line_number_ == 0) throw Error(name() + ": empty input");
      fields_ = options.names.size();
      field_names_ = options.names;
      names_given_ = true;
      for (std::size_t i = 0; i < options.names.size(); ++i) {
        if (options.names[i] == "_") continue;
        columns_.push_back(options.names[i]);
        keep_.push_back(i);
      }
      check_columns(columns_, name() + ": --names");
      if (have_line) {
        separator_ = choose_separator(options.separator, line);
        pending_ = std::string(line), has_pending_ = true, pending_line_ = line_number_;
      }
    }
    values_.resize(fields_);
    row_.resize(columns_.size());
  }

  const double* read_row() override {
    std::string_view line;
    for (;;) {
      if (has_pending_) {
        has_pending_ = false;
        line = pending_;
        raw_position_ = pending_line_;
      } else {
        if (!next_line(line)) return nullptr;
        raw_position_ = line_number_;
      }
      if (line.empty()) continue;
      if (line.front() == '#') {
        if (comment_handler_) comment_handler_(line.substr(1));
        continue;
      }
      if (parse_row(line)) {
        ++rows_read_;
        return row_.data();
      }
    }
  }

  std::string location(std::uint64_t position) const override { return name() + ":" + std::to_string(position); }

 private:
  bool next_line(std::string_view& line) {
    for (;;) {
      const char* begin = in_->data() + scanned_;
      std::size_t rest = in_->available() - scanned_;
      const char* newline = static_cast<const char*>(std::memchr(begin, '\n', rest));
      if (newline) {
        std::size_t length = static_cast<std::size_t>(newline - in_->data());
        if (discarding_) {  // the end of a line too long to keep
          in_->consume(length + 1);
          scanned_ = 0;
          ++line_number_;
          discarding_ = false;
          continue;
        }
        finish_line(length, length + 1, line);
        return true;
      }
      scanned_ = in_->available();
      if (!discarding_ && scanned_ > kMaxLineBytes) {
        discarding_ = true;
        raw_position_ = line_number_ + 1;
        skip_bad("line too long", "line longer than " + std::to_string(kMaxLineBytes) +
                                      " bytes (binary data, or no newlines?)");
      }
      if (discarding_) {
        in_->consume(in_->available());
        scanned_ = 0;
      }
      if (!in_->fill()) {
        if (discarding_) {
          ++line_number_;
          discarding_ = false;
          return false;
        }
        if (in_->available() == 0) return false;
        finish_line(in_->available(), in_->available(), line);  // last line, no newline
        return true;
      }
    }
  }
  void finish_line(std::size_t length, std::size_t consumed, std::string_view& line) {
    // The view stays valid until the next fill(): consume now, and the buffer is only moved
    // by the next call to fill().
    const char* start = in_->data();
    if (length > 0 && start[length - 1] == '\r') --length;
    line = std::string_view(start, length);
    if (line_number_ == 0) line = core::strip_byte_order_mark(line);  // some editors write one
    in_->consume(consumed);
    scanned_ = 0;
    ++line_number_;
  }

  bool parse_row(std::string_view line) {
    // The plain case (commas, no quotes) is the fast one; anything else takes the splitter.
    if (separator_.delimiter != ',' || separator_.blanks || std::memchr(line.data(), '"', line.size()) != nullptr)
      return parse_split_row(line);
    const char* p = line.data();
    const char* end = p + line.size();
    std::size_t field = 0;
    for (;;) {
      if (field == fields_) {
        // The count of them, not "more": a name list or header one short shows as the number.
        const auto commas = std::count(p, end, ',');
        ragged(fields_ + 1 + static_cast<std::size_t>(commas));
        return false;
      }
      const char* comma = static_cast<const char*>(std::memchr(p, ',', static_cast<std::size_t>(end - p)));
      const char* field_end = comma ? comma : end;
      double value;
      auto result = std::from_chars(p, field_end, value);
      if (result.ec != std::errc() || result.ptr != field_end) {
        auto slow = parse_double(std::string_view(p, static_cast<std::size_t>(field_end - p)));
        if (!slow) {
          skip_bad("bad number", "bad number '" + printable(std::string_view(p, static_cast<std::size_t>(field_end - p))) +
                   "' in column '" + column_name(field) + "'");
          return false;
        }
        value = *slow;
      }
      values_[field++] = value;
      if (!comma) break;
      p = comma + 1;
    }
    if (field != fields_) {
      ragged(field);
      return false;
    }
    for (std::size_t i = 0; i < keep_.size(); ++i) row_[i] = values_[keep_[i]];
    return true;
  }
  bool parse_split_row(std::string_view line) {
    if (const char* why = split_fields(line, separator_, split_)) {
      skip_bad("bad row", why);
      return false;
    }
    if (split_.size() != fields_) {
      ragged(split_.size());
      return false;
    }
    for (std::size_t field = 0; field < fields_; ++field) {
      const std::string_view text = split_[field].text;
      auto value = parse_double(text);
      if (!value) {
        std::string message = "bad number '" + printable(text) + "' in column '" + column_name(field) + "'";
        if (separator_.delimiter != ',' && text.find(',') != std::string_view::npos)
          message += " (a decimal comma? numbers are read with a decimal point)";
        skip_bad("bad number", message);
        return false;
      }
      values_[field] = *value;
    }
    for (std::size_t i = 0; i < keep_.size(); ++i) row_[i] = values_[keep_[i]];
    return true;
  }
  // Reports a row of `got` fields where the header (or --names) has fields_.
  void ragged(std::size_t got) {
    std::string message = "expected " + std::to_string(fields_) + " fields, got " + std::to_string(got);
    if (names_given_) message += " (--names names " + std::to_string(fields_) + ")";
    skip_bad("ragged row", message);
  }
  // The input's name of a field (the header's or --names', before any rename).
  std::string column_name(std::size_t field) const { return field_names_[field]; }

  FieldSeparator separator_;       // detected from the header (or the first row with --names)
  std::vector<Field> split_;  // the fields of the line being parsed (split_fields)
  bool discarding_ = false;  // inside a line longer than kMaxLineBytes
  std::size_t scanned_ = 0;
  std::uint64_t line_number_ = 0;
  std::size_t fields_ = 0;
  std::vector<std::size_t> keep_;
  std::vector<std::string> field_names_;  // every field's name in the input, "_" when dropped
  bool names_given_ = false;              // the names are --names', not a header's
  std::vector<double> values_;
  std::vector<double> row_;
  std::string pending_;
  bool has_pending_ = false;
  std::uint64_t pending_line_ = 0;
};

class BinaryReader final : public InputReader {
 public:
  BinaryReader(std::unique_ptr<Input> input, std::string display, const ReaderOptions& options)
      : InputReader(std::move(input), std::move(display), options, Encoding::binary) {
    if (!in_->want(sizeof kBinaryMagic) || std::memcmp(in_->data(), kBinaryMagic, sizeof kBinaryMagic) != 0)
      throw Error(name() + ": byte 0: wrong magic (not a momentum binary stream)");
    in_->consume(sizeof kBinaryMagic);
    std::uint32_t version = read_u32("version");
    if (version != kBinaryVersion)
      throw Error(name() + ": byte 8: unsupported binary version " + std::to_string(version) +
                  " (this build reads version " + std::to_string(kBinaryVersion) + ")");
    std::uint32_t ncolumns = read_u32("column count");
    std::uint32_t ncomments = read_u32("comment count");
    for (std::uint32_t i = 0; i < ncomments; ++i) leading_comments_.push_back(read_string("comment"));
    for (std::uint32_t i = 0; i < ncolumns; ++i) columns_.push_back(read_string("column name"));
    if (columns_.empty()) throw Error(name() + ": no columns in header");
    check_columns(columns_, name() + ": header");
    row_.resize(columns_.size());
    record_ = columns_.size() * sizeof(double);
  }

  const double* read_row() override {
    for (;;) {
      raw_position_ = in_->offset();
      const bool whole_record = in_->want(record_);
      // A comment record can be shorter than a row record: at the end of a stream, look at
      // its marker before calling what is left a truncated row.
      if (in_->available() >= sizeof(std::uint64_t)) {
        std::uint64_t first;
        std::memcpy(&first, in_->data(), sizeof first);
        if (first == kCommentRecordBits) {
          if (!read_comment_record()) return nullptr;
          continue;
        }
      }
      if (!whole_record) {
        if (in_->available() == 0) return nullptr;
        std::size_t partial = in_->available();
        in_->consume(partial);
        skip_bad("truncated record", "truncated record (" + std::to_string(partial) + " of " + std::to_string(record_) + " bytes)");
        return nullptr;
      }
      std::uint64_t first;
      std::memcpy(&first, in_->data(), sizeof first);
      if (first == kCommentRecordBits) {
        if (!read_comment_record()) return nullptr;
        continue;
      }
      std::memcpy(row_.data(), in_->data(), record_);
      in_->consume(record_);
      ++rows_read_;
      return row_.data();
    }
  }

  std::size_t peek_rows(double* rows, std::size_t max) const override {
    std::size_t count = 0;
    for (const char* at = in_->data(); count < max && in_->available() >= (count + 1) * record_; at += record_) {
      std::uint64_t first;
      std::memcpy(&first, at, sizeof first);
      if (first == kCommentRecordBits) break;
      std::memcpy(rows + count * columns_.size(), at, record_);
      ++count;
    }
    return count;
  }

  std::string location(std::uint64_t position) const override {
    return name() + ": byte " + std::to_string(position);
  }

 private:
  bool read_comment_record() {
    if (!in_->want(16)) {
      in_->consume(in_->available());
      skip_bad("truncated record", "truncated comment record");
      return false;
    }
    std::uint64_t length;
    std::memcpy(&length, in_->data() + 8, sizeof length);
    std::size_t padded = static_cast<std::size_t>((length + 7) / 8 * 8);
    if (length > (1u << 24) || !in_->want(16 + padded)) {
      in_->consume(in_->available());
      skip_bad("truncated record", "truncated or corrupt comment record");
      return false;
    }
    if (comment_handler_) comment_handler_(std::string_view(in_->data() + 16, static_cast<std::size_t>(length)));
    in_->consume(16 + padded);
    return true;
  }
  std::uint32_t read_u32(const char* what) {
    if (!in_->want(4))
      throw Error(name() + ": byte " + std::to_string(in_->offset()) + ": truncated header (" + what + ")");
    std::uint32_t v;
    std::memcpy(&v, in_->data(), 4);
    in_->consume(4);
    return v;
  }
  std::string read_string(const char* what) {
    std::uint32_t length = read_u32(what);
    if (length > (1u << 20) || !in_->want(length))
      throw Error(name() + ": byte " + std::to_string(in_->offset()) + ": truncated header (" + what + ")");
    std::string s(in_->data(), length);
    in_->consume(length);
    return s;
  }

  std::vector<double> row_;
  std::size_t record_ = 0;
};

bool is_live(int fd) {
  struct stat st;
  if (::fstat(fd, &st) != 0) return false;
  return S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode) || S_ISCHR(st.st_mode);
}

}  // namespace

std::unique_ptr<Reader> Reader::open(const std::string& path, ReaderOptions options) {
  const bool from_stdin = core::is_standard_input(path);
  std::string name = !options.display_name.empty() ? options.display_name : core::input_name(path);
  // Opened through core, which records the input so that no output of the run overwrites it.
  int fd = core::open_input(from_stdin ? "-" : path, name);
  struct stat st;
  if (::fstat(fd, &st) == 0 && S_ISDIR(st.st_mode)) {
    if (!from_stdin) ::close(fd);
    throw Error(name + ": is a directory");
  }
  bool live = is_live(fd);
  auto input = std::make_unique<Input>(fd, !from_stdin, name);
  input->before_read = &options.before_read;
  std::unique_ptr<Reader> reader;
  if (!input->want(1)) throw Error(name + ": empty input");
  if (static_cast<unsigned char>(input->data()[0]) == static_cast<unsigned char>(kBinaryMagic[0])) {
    // Both magics start with 0x89 'M'; "MCAP" tells a bag from a binary stream ("MOLOG").
    const bool bag = input->want(5) && std::memcmp(input->data(), mcap::kMagic, 5) == 0;
    if (!options.names.empty()) throw Error(name + ": --names applies to CSV input, not " + (bag ? "MCAP" : "binary"));
    const bool regular = !from_stdin && ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode);
    if (bag) reader = detail::open_mcap(std::move(input), name, options, regular ? path : std::string());
    else reader = std::make_unique<BinaryReader>(std::move(input), name, options);
  } else {
    reader = std::make_unique<CsvReader>(std::move(input), name, options);
  }
  reader->live_ = live;
  reader->start_renames(options.renames);
  reader->start_time_order(options);
  reader->rows_returned_ = options.rows_returned;
  return reader;
}

}  // namespace momentum::stream
