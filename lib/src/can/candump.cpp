#include "momentum/can/candump.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>

#include "momentum/can/asc.hpp"
#include "momentum/core/error.hpp"
#include "momentum/core/file.hpp"
#include "momentum/core/number.hpp"
#include "momentum/core/text.hpp"

namespace momentum::can {

namespace {

// Hex digit value, 16 for anything else (can-utils' asc2nibble).
struct HexTable {
  std::uint8_t value[256];
  constexpr HexTable() : value() {
    for (int i = 0; i < 256; ++i) value[i] = 16;
    for (int i = 0; i < 10; ++i) value['0' + i] = static_cast<std::uint8_t>(i);
    for (int i = 0; i < 6; ++i) {
      value['A' + i] = static_cast<std::uint8_t>(10 + i);
      value['a' + i] = static_cast<std::uint8_t>(10 + i);
    }
  }
};
constexpr HexTable kHex;

inline unsigned nibble(char c) { return kHex.value[static_cast<unsigned char>(c)]; }
inline bool is_space(char c) { return c == ' ' || c == '\t'; }
inline bool is_digit(char c) { return c >= '0' && c <= '9'; }

constexpr std::size_t kProbe = 32;
constexpr std::size_t kBufferSize = std::size_t{1} << 20;

// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's days_from_civil).
std::int64_t days_from_civil(std::int64_t y, unsigned m, unsigned d) {
  y -= m <= 2;
  const std::int64_t era = (y >= 0 ? y : y - 399) / 400;
  const unsigned yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<std::int64_t>(doe) - 719468;
}

// Reads `count` decimal digits exactly; false if any is not a digit.
bool fixed_digits(const char*& p, const char* end, int count, unsigned& value) {
  if (end - p < count) return false;
  value = 0;
  for (int i = 0; i < count; ++i) {
    if (!is_digit(p[i])) return false;
    value = value * 10 + static_cast<unsigned>(p[i] - '0');
  }
  p += count;
  return true;
}

// Fraction digits after '.', as nanoseconds (digits beyond 9 are truncated).
bool fraction_ns(const char*& p, const char* end, std::int64_t& ns) {
  const char* start = p;
  std::int64_t value = 0;
  int digits = 0;
  while (p < end && is_digit(*p)) {
    if (digits < 9) {
      value = value * 10 + (*p - '0');
      ++digits;
    }
    ++p;
  }
  if (p == start) return false;
  for (; digits < 9; ++digits) value *= 10;
  ns = value;
  return true;
}

// The end of a timestamp at p: an optional ".FRACTION" (`frac`, nanoseconds) and the closing
// ')'; p is then past it.
bool stamp_end(const char*& p, const char* end, std::int64_t& frac, const char*& error) {
  if (p < end && *p == '.') {
    ++p;
    if (!fraction_ns(p, end, frac)) {
      error = "bad timestamp";
      return false;
    }
  }
  if (p >= end || *p != ')') {
    error = "bad timestamp";
    return false;
  }
  ++p;
  return true;
}

// Parses "(...)" at p: "(SECONDS[.FRACTION])" or "(YYYY-MM-DD HH:MM:SS.FRACTION)". On success p
// is past ')', `integer_digits` is the number of digits before the point (0 for a date).
bool parse_stamp(const char*& p, const char* end, std::int64_t& ns, int& integer_digits,
                 const char*& error) {
  ++p;  // '('
  const char* start = p;
  // Times are kept in int64 nanoseconds: up to the year 2262.
  constexpr std::int64_t kMaxSeconds = 9000000000LL;
  std::int64_t seconds = 0;
  while (p < end && is_digit(*p)) {
    seconds = seconds * 10 + (*p - '0');
    if (seconds > kMaxSeconds) {
      error = "timestamp out of range";
      return false;
    }
    ++p;
  }
  integer_digits = static_cast<int>(p - start);
  if (integer_digits == 4 && p < end && *p == '-') {
    // -t A: "(2015-07-10 08:17:32.249713)", local time of the capturing host.
    const char* q = start;
    unsigned year, month, day, hour, minute, second;
    if (!fixed_digits(q, end, 4, year) || q >= end || *q++ != '-' ||
        !fixed_digits(q, end, 2, month) || q >= end || *q++ != '-' ||
        !fixed_digits(q, end, 2, day) || q >= end || *q++ != ' ' ||
        !fixed_digits(q, end, 2, hour) || q >= end || *q++ != ':' ||
        !fixed_digits(q, end, 2, minute) || q >= end || *q++ != ':' ||
        !fixed_digits(q, end, 2, second) || year < 1970 || year > 2250 || month < 1 || month > 12 || day < 1 || day > 31 ||
        hour > 23 || minute > 59 || second > 60) {
      error = "bad date in timestamp";
      return false;
    }
    std::int64_t frac = 0;
    if (!stamp_end(q, end, frac, error)) return false;
    p = q;
    const std::int64_t days = days_from_civil(year, month, day);
    ns = ((days * 24 + hour) * 60 + minute) * 60 + second;
    ns = ns * 1000000000 + frac;
    integer_digits = 0;
    return true;
  }
  if (integer_digits == 0) {
    error = "bad timestamp";
    return false;
  }
  std::int64_t frac = 0;
  if (!stamp_end(p, end, frac, error)) return false;
  ns = seconds * 1000000000 + frac;
  return true;
}

// The id of both formats: 3 hex digits (standard), 8 (extended, or an error frame with
// CAN_ERR_FLAG). The default format of old can-utils padded with spaces instead of zeros, so
// 1 to 3 digits read as standard and 4 to 8 as extended there (`loose`).
bool parse_id(const char* s, std::size_t n, Frame& frame, bool loose, const char*& error) {
  if (!(n == 3 || n == 8 || (loose && n >= 1 && n <= 8))) {
    error = n == 5 ? "can xl frames are not supported" : "bad can id";
    return false;
  }
  std::uint32_t id = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned v = nibble(s[i]);
    if (v > 15) {
      error = "bad can id";
      return false;
    }
    id = (id << 4) | v;
  }
  if (n <= 3) {
    if (id > kStandardMask) {
      error = "standard can id above 7FF";
      return false;
    }
    frame.id = id;
    frame.extended = false;
    return true;
  }
  if (id & kErrorFlag) {
    frame.error = true;
    frame.id = id & kExtendedMask;
  } else {
    frame.extended = true;
    frame.id = id & kExtendedMask;
  }
  return true;
}

// Log format frame: lib.c parse_canframe() (CAN CC and FD; CAN XL is refused).
bool parse_log_frame(const char* s, std::size_t n, Frame& frame, const char*& error) {
  std::size_t idx;
  if (n >= 4 && s[3] == '#') {
    if (!parse_id(s, 3, frame, false, error)) return false;
    idx = 4;
  } else if (n >= 6 && s[5] == '#') {
    error = "can xl frames are not supported";
    return false;
  } else if (n >= 9 && s[8] == '#') {
    if (!parse_id(s, 8, frame, false, error)) return false;
    idx = 9;
  } else {
    error = "expected ID#DATA";
    return false;
  }
  if (idx < n && (s[idx] == 'R' || s[idx] == 'r')) {
    if (frame.error) {
      error = "error frame with rtr";
      return false;
    }
    frame.rtr = true;
    ++idx;
    if (idx < n) {
      const unsigned dlc = nibble(s[idx]);
      if (dlc > 8) {
        error = "bad rtr length";
        return false;
      }
      frame.len = static_cast<std::uint8_t>(dlc);
      ++idx;
      if (dlc == 8 && idx < n && s[idx] == '_') {
        const unsigned raw = idx + 1 < n ? nibble(s[idx + 1]) : 16;
        if (raw < 9 || raw > 15) {
          error = "bad raw dlc after _";
          return false;
        }
        frame.len8_dlc = static_cast<std::uint8_t>(raw);
        idx += 2;
      }
    }
    if (idx != n) {
      error = "unexpected text after rtr";
      return false;
    }
    return true;
  }
  std::size_t max_len = 8;
  if (idx < n && s[idx] == '#') {
    const unsigned flags = idx + 1 < n ? nibble(s[idx + 1]) : 16;
    if (flags > 15) {
      error = "missing can fd flags after ##";
      return false;
    }
    frame.fd = true;
    frame.fd_flags = static_cast<std::uint8_t>(flags);
    max_len = kMaxPayload;
    idx += 2;
  }
  std::size_t len = 0;
  while (idx < n) {
    if (s[idx] == '.') {
      ++idx;
      continue;
    }
    if (s[idx] == '_') break;
    if (len == max_len) {
      error = max_len == 8 ? "more than 8 data bytes (can fd frames use ##)"
                           : "more than 64 data bytes";
      return false;
    }
    const unsigned hi = nibble(s[idx]);
    const unsigned lo = idx + 1 < n ? nibble(s[idx + 1]) : 16;
    if (hi > 15 || lo > 15) {
      error = (hi <= 15 && idx + 1 >= n) ? "odd number of hex digits in data" : "bad hex digit in data";
      return false;
    }
    frame.data[len++] = static_cast<std::uint8_t>((hi << 4) | lo);
    idx += 2;
  }
  frame.len = static_cast<std::uint8_t>(len);
  if (idx < n) {  // '_' raw DLC
    const unsigned raw = idx + 1 < n ? nibble(s[idx + 1]) : 16;
    if (frame.fd || len != 8 || raw < 9 || raw > 15 || idx + 2 != n) {
      error = "bad raw dlc after _";
      return false;
    }
    frame.len8_dlc = static_cast<std::uint8_t>(raw);
  }
  return true;
}

// A whitespace-separated token scanner over one line.
// Default format after the interface: sprint_long_canframe(), with -x fields before it.
bool parse_long_frame(core::Words& tokens, Frame& frame, const char*& error) {
  std::string_view tok = tokens.next();
  if (tok == "RX" || tok == "TX") {
    frame.direction = tok == "RX" ? Direction::rx : Direction::tx;
    const std::string_view brs = tokens.next();
    const std::string_view esi = tokens.next();
    if (brs.size() != 1 || esi.size() != 1 || (brs[0] != '-' && brs[0] != 'B') ||
        (esi[0] != '-' && esi[0] != 'E')) {
      error = "bad -x fields";
      return false;
    }
    frame.fd_flags = static_cast<std::uint8_t>((brs[0] == 'B' ? 1 : 0) | (esi[0] == 'E' ? 2 : 0));
    tok = tokens.next();
  }
  if (tok.empty()) {
    error = "missing can id";
    return false;
  }
  if (!parse_id(tok.data(), tok.size(), frame, true, error)) return false;
  const std::string_view len_tok = tokens.next();
  std::size_t len = 0;
  if (len_tok.size() == 3 && len_tok[0] == '[' && len_tok[2] == ']' && is_digit(len_tok[1])) {
    len = static_cast<std::size_t>(len_tok[1] - '0');
    if (len > 8) {
      error = "bad length field";
      return false;
    }
  } else if (len_tok.size() == 3 && len_tok[0] == '{' && len_tok[2] == '}' && nibble(len_tok[1]) <= 15) {
    const unsigned dlc = nibble(len_tok[1]);  // -8: raw DLC of a classic frame
    len = dlc > 8 ? 8 : dlc;
    if (dlc > 8) frame.len8_dlc = static_cast<std::uint8_t>(dlc);
  } else if (len_tok.size() == 4 && len_tok[0] == '[' && len_tok[3] == ']' && is_digit(len_tok[1]) &&
             is_digit(len_tok[2])) {
    len = static_cast<std::size_t>((len_tok[1] - '0') * 10 + (len_tok[2] - '0'));
    if (len > kMaxPayload) {
      error = "bad length field";
      return false;
    }
    frame.fd = true;
  } else if (len_tok.size() == 6 && len_tok[0] == '[') {
    error = "can xl frames are not supported";
    return false;
  } else {
    error = "expected [LEN] after the can id";
    return false;
  }
  if (!frame.fd) frame.fd_flags = 0;  // -x prints "- -" for classic frames anyway
  frame.len = static_cast<std::uint8_t>(len);
  if (!frame.fd && !frame.error) {
    // " remote request" replaces the data of an RTR frame.
    const core::Words save = tokens;
    if (tokens.next() == "remote") {
      if (tokens.next() == "request") {
        frame.rtr = true;
        return true;
      }
      error = "bad remote request";
      return false;
    }
    tokens = save;
  }
  // Data: hex pairs (" 11 22"), binary octets with -i (" 00010001"), and with -S the bytes in
  // reverse order joined by '`' (" 22`11").
  std::size_t got = 0;
  bool swapped = false;
  while (got < len) {
    tok = tokens.next();
    if (tok.empty()) {
      error = "fewer data bytes than the length field says";
      return false;
    }
    std::size_t i = 0;
    while (i < tok.size()) {
      if (tok[i] == '`') {
        swapped = true;
        ++i;
        continue;
      }
      if (got == len) {
        error = "more data bytes than the length field says";
        return false;
      }
      std::size_t run = i;
      while (run < tok.size() && tok[run] != '`') ++run;
      const std::size_t width = run - i;
      if (width == 2) {
        const unsigned hi = nibble(tok[i]), lo = nibble(tok[i + 1]);
        if (hi > 15 || lo > 15) {
          error = "bad hex digit in data";
          return false;
        }
        frame.data[got++] = static_cast<std::uint8_t>((hi << 4) | lo);
      } else if (width == 8) {
        unsigned value = 0;
        for (std::size_t k = 0; k < 8; ++k) {
          if (tok[i + k] != '0' && tok[i + k] != '1') {
            error = "bad binary digit in data";
            return false;
          }
          value = (value << 1) | static_cast<unsigned>(tok[i + k] - '0');
        }
        frame.data[got++] = static_cast<std::uint8_t>(value);
      } else {
        error = "bad data byte";
        return false;
      }
      i = run;
    }
  }
  if (swapped) {
    for (std::size_t a = 0, b = len - 1; a < b; ++a, --b) std::swap(frame.data[a], frame.data[b]);
  }
  // What follows is the -a ASCII column or ERRORFRAME: nothing more to read.
  return true;
}

}  // namespace

TimestampMode parse_timestamp_mode(std::string_view name) {
  if (name == "auto" || name == "automatic") return TimestampMode::automatic;
  if (name == "absolute" || name == "a") return TimestampMode::absolute;
  if (name == "delta" || name == "d") return TimestampMode::delta;
  if (name == "zero" || name == "z") return TimestampMode::zero;
  throw Error("unknown timestamp mode '" + std::string(name) + "' (expected auto, absolute, delta or zero)");
}

LineKind parse_candump_line(std::string_view line, Frame& frame, ParsedLine& info) {
  info = ParsedLine{};
  clear(frame);
  const char* p = line.data();
  const char* end = p + line.size();
  while (end > p && (end[-1] == '\r' || end[-1] == ' ' || end[-1] == '\t' || end[-1] == '\n')) --end;
  if (p < end && *p == '\t') return info.kind = LineKind::detail;
  while (p < end && is_space(*p)) ++p;
  if (p == end || *p == '#') return info.kind = LineKind::skip;
  const char* error = "";
  auto bad = [&](const char* why) {
    info.error = why;
    return info.kind = LineKind::bad;
  };

  if (*p == 'D' && end - p >= 10 && std::memcmp(p, "DROPCOUNT:", 10) == 0) {
    // "DROPCOUNT: dropped %u CAN frame%s on '%s' socket (total drops %u)"
    const char* q = p + 10;
    while (q < end && is_space(*q)) ++q;
    if (end - q < 8 || std::memcmp(q, "dropped ", 8) != 0) return bad("bad DROPCOUNT line");
    q += 8;
    std::uint64_t count = 0;
    const char* digits = q;
    while (q < end && is_digit(*q) && q - digits < 19) count = count * 10 + static_cast<std::uint64_t>(*q++ - '0');
    if (q == digits || (q < end && !is_space(*q))) return bad("bad DROPCOUNT line");
    info.dropped = count;
    return info.kind = LineKind::dropcount;
  }

  int integer_digits = -1;
  if (*p == '(') {
    if (!parse_stamp(p, end, info.stamp_ns, integer_digits, error)) return bad(error);
    // The log format has one space after ')', the default format two; either way a token
    // follows.
  }
  core::Words tokens(std::string_view(p, static_cast<std::size_t>(end - p)));
  const std::string_view iface = tokens.next();
  if (iface.empty()) return bad("missing interface name");
  info.interface = iface;
  const core::Words after_iface = tokens;
  const std::string_view first = tokens.next();
  if (first.empty()) return bad(integer_digits < 0 ? "not candump text" : "missing frame");

  if (first.find('#') != std::string_view::npos) {
    // Log format: "(stamp) iface ID#DATA" with an optional " R" or " T" (candump -x, python-can).
    if (integer_digits < 0) return bad("log format line without a timestamp");
    if (integer_digits == 0) return bad("date timestamp in a log format line");
    if (!parse_log_frame(first.data(), first.size(), frame, error)) return bad(error);
    const std::string_view extra = tokens.next();
    if (!extra.empty()) {
      if (extra == "R" || extra == "r") {
        frame.direction = Direction::rx;
      } else if (extra == "T" || extra == "t") {
        frame.direction = Direction::tx;
      } else {
        return bad("unexpected text after the frame");
      }
      if (!tokens.next().empty()) return bad("unexpected text after the frame");
    }
    info.time_kind = TimeKind::log;
    return info.kind = LineKind::frame;
  }

  tokens = after_iface;
  if (!parse_long_frame(tokens, frame, error)) {
    // A line with neither a timestamp nor a hex id where the default format has one is not a
    // damaged frame but something else altogether.
    if (integer_digits < 0 && std::strcmp(error, "bad can id") == 0) return bad("not candump text");
    return bad(error);
  }
  if (integer_digits < 0) {
    info.time_kind = TimeKind::none;
  } else if (integer_digits == 0) {
    info.time_kind = TimeKind::date;
  } else if (integer_digits >= 10) {
    info.time_kind = TimeKind::absolute;
  } else {
    info.time_kind = TimeKind::relative;
  }
  return info.kind = LineKind::frame;
}

// ---------------------------------------------------------------------------------------------

std::unique_ptr<CandumpReader> CandumpReader::open(const std::string& path, CandumpOptions options) {
  if (core::is_standard_input(path)) {
    if (options.display_name.empty()) options.display_name = core::input_name(path);
    return from_fd(0, false, std::move(options));
  }
  const int fd = core::open_input(path);  // recorded: no output of the run may overwrite it
  if (options.display_name.empty()) options.display_name = path;
  return from_fd(fd, true, std::move(options));
}

std::unique_ptr<CandumpReader> CandumpReader::from_fd(int fd, bool owns, CandumpOptions options) {
  std::unique_ptr<CandumpReader> reader(new CandumpReader());
  reader->fd_ = fd;
  reader->owns_fd_ = owns;
  reader->name_ = options.display_name.empty() ? "<fd " + std::to_string(fd) + ">" : options.display_name;
  reader->mode_ = options.timestamps;
  reader->options_ = std::move(options);
  reader->buffer_.resize(kBufferSize);
  struct stat st {};
  if (fstat(fd, &st) == 0) reader->live_ = S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode) || S_ISCHR(st.st_mode);
  return reader;
}

std::unique_ptr<CandumpReader> CandumpReader::from_text(std::string_view text, CandumpOptions options) {
  std::unique_ptr<CandumpReader> reader(new CandumpReader());
  reader->name_ = options.display_name.empty() ? "<text>" : options.display_name;
  reader->mode_ = options.timestamps;
  reader->options_ = std::move(options);
  reader->buffer_.assign(text.begin(), text.end());
  reader->end_ = text.size();
  reader->eof_ = true;
  return reader;
}

CandumpReader::~CandumpReader() {
  if (owns_fd_ && fd_ >= 0) core::close_input(fd_);
}

std::string CandumpReader::where() const { return name_ + ":" + std::to_string(frame_line_); }

bool CandumpReader::next_line(std::string_view& line) {
  for (;;) {
    const char* base = buffer_.data();
    const void* nl = begin_ < end_ ? std::memchr(base + begin_, '\n', end_ - begin_) : nullptr;
    if (nl != nullptr) {
      const std::size_t at = static_cast<std::size_t>(static_cast<const char*>(nl) - base);
      line = std::string_view(base + begin_, at - begin_);
      begin_ = at + 1;
      ++line_no_;
      if (discarding_long_line_) {
        discarding_long_line_ = false;
        continue;
      }
      if (line_no_ == 1) line = core::strip_byte_order_mark(line);  // some editors write one
      return true;
    }
    if (eof_) {
      if (begin_ < end_ && !discarding_long_line_) {
        line = std::string_view(base + begin_, end_ - begin_);
        begin_ = end_;
        ++line_no_;
        if (line_no_ == 1) line = core::strip_byte_order_mark(line);
        return true;
      }
      begin_ = end_;
      return false;
    }
    // Keep the partial line and read more.
    if (begin_ > 0) {
      std::memmove(buffer_.data(), buffer_.data() + begin_, end_ - begin_);
      end_ -= begin_;
      begin_ = 0;
    }
    if (end_ == buffer_.size()) {
      // A line longer than the whole buffer: report it once and drop it up to its newline.
      if (!discarding_long_line_) {
        ++stats_.lines;
        line_no_ += 1;
        report_bad("line longer than 1 MiB");
        line_no_ -= 1;
        --stats_.lines;
      }
      discarding_long_line_ = true;
      end_ = 0;
    }
    if (before_read_) before_read_();
    const ssize_t got = ::read(fd_, buffer_.data() + end_, buffer_.size() - end_);
    if (got < 0) {
      if (errno == EINTR) {
        if (on_interrupt_) on_interrupt_();
        continue;
      }
      throw Error(name_ + ": read error: " + std::strerror(errno));
    }
    if (got == 0) {
      eof_ = true;
    } else {
      end_ += static_cast<std::size_t>(got);
    }
  }
}

void CandumpReader::report_bad(const char* message) {
  ++stats_.bad_lines;
  std::string text = located(name_, line_no_, message);
  if (options_.strict) throw Error(text);
  warn_row(message, text);
}

bool CandumpReader::parse_next(Frame& frame, ParsedLine& info) {
  std::string_view line;
  while (next_line(line)) {
    ++stats_.lines;
    if (stats_.lines == 1 && is_asc_header(line)) asc_ = std::make_unique<AscState>();
    const LineKind kind = asc_ ? parse_asc_line(line, frame, info, *asc_) : parse_candump_line(line, frame, info);
    if (kind == LineKind::detail && !after_error_frame_) {
      report_bad("tab-indented line not below an error frame (only candump -e details are)");
      continue;
    }
    if (kind != LineKind::detail && kind != LineKind::skip) after_error_frame_ = kind == LineKind::frame && frame.error;
    switch (kind) {
      case LineKind::frame:
        if (!options_.interface.empty() && info.interface != options_.interface) {
          ++stats_.filtered;
          continue;
        }
        ++stats_.frames;
        if (frame.error) ++stats_.error_frames;
        return true;
      case LineKind::dropcount:
        stats_.lost_frames += info.dropped;
        continue;
      case LineKind::skip:
      case LineKind::detail:
        continue;
      case LineKind::bad:
        report_bad(info.error);
        continue;
    }
  }
  return false;
}

void CandumpReader::resolve_time(Frame& frame, const ParsedLine& info) {
  switch (info.time_kind) {
    case TimeKind::none:
      frame.has_time = false;
      frame.time_ns = 0;
      return;
    case TimeKind::log:
      frame.time_ns = info.stamp_ns;
      break;
    case TimeKind::absolute:
    case TimeKind::date:
    case TimeKind::relative:
      if (mode_ == TimestampMode::delta) {
        // Saturate rather than wrap on absurd sums of deltas.
        if (__builtin_add_overflow(running_ns_, info.stamp_ns, &running_ns_)) running_ns_ = INT64_MAX;
        frame.time_ns = running_ns_;
      } else {
        frame.time_ns = info.stamp_ns;
      }
      break;
  }
  frame.has_time = true;
}

void CandumpReader::decide_relative_mode() {
  // -t z prints the time since the first frame: it never goes down, and it grows. -t d prints
  // the gaps between frames: on a real bus they go up and down, and on a perfectly regular one
  // they stay constant. Frames with other timestamp kinds do not take part.
  std::int64_t first_after_start = -1, previous = -1, last = -1;
  std::size_t count = 0;
  bool decreased = false;
  for (const Pending& p : pending_) {
    if (p.info.time_kind != TimeKind::relative) continue;
    const std::int64_t v = p.info.stamp_ns;
    if (previous >= 0 && v < previous) decreased = true;
    if (count == 1) first_after_start = v;
    previous = last = v;
    ++count;
  }
  const bool constant = count >= 3 && first_after_start > 0 && last == first_after_start;
  mode_ = (decreased || constant) ? TimestampMode::delta : TimestampMode::zero;
}

bool CandumpReader::next(Frame& frame) {
  if (pending_next_ < pending_.size()) {
    Pending& p = pending_[pending_next_++];
    frame = p.frame;
    frame_line_ = p.line;
    resolve_time(frame, p.info);
    if (pending_next_ == pending_.size()) {
      pending_.clear();
      pending_next_ = 0;
    }
    return true;
  }
  ParsedLine info;
  if (!parse_next(frame, info)) return false;
  if (info.time_kind == TimeKind::relative && mode_ == TimestampMode::automatic) {
    pending_.reserve(kProbe);
    pending_.push_back({frame, info, line_no_});
    Pending next_one;
    while (pending_.size() < kProbe && parse_next(next_one.frame, next_one.info)) {
      next_one.line = line_no_;
      pending_.push_back(next_one);
    }
    decide_relative_mode();
    pending_next_ = 0;
    return next(frame);
  }
  frame_line_ = line_no_;
  resolve_time(frame, info);
  return true;
}

// ---------------------------------------------------------------------------------------------

std::size_t format_log_line(const Frame& frame, std::string_view interface, char* out) {
  static constexpr char kDigits[] = "0123456789ABCDEF";
  char* o = out;
  *o++ = '(';
  o += core::format_nanoseconds(frame.time_ns, 10, o);  // can-utils: "(%010lu.%06lu)"
  *o++ = ')';
  *o++ = ' ';
  if (interface.size() > 32) interface = interface.substr(0, 32);
  std::memcpy(o, interface.data(), interface.size());
  o += interface.size();
  *o++ = ' ';
  o += format_id(frame, o);
  *o++ = '#';
  const std::size_t len = frame.len > (frame.fd ? kMaxPayload : 8) ? (frame.fd ? kMaxPayload : 8) : frame.len;
  if (frame.rtr && !frame.fd) {
    *o++ = 'R';
    if (len > 0) {
      *o++ = kDigits[len];
      if (len == 8 && frame.len8_dlc > 8 && frame.len8_dlc <= 15) {
        *o++ = '_';
        *o++ = kDigits[frame.len8_dlc];
      }
    }
  } else {
    if (frame.fd) {
      *o++ = '#';
      *o++ = kDigits[frame.fd_flags & 0xF];
    }
    for (std::size_t i = 0; i < len; ++i) {
      *o++ = kDigits[frame.data[i] >> 4];
      *o++ = kDigits[frame.data[i] & 0xF];
    }
    if (!frame.fd && len == 8 && frame.len8_dlc > 8 && frame.len8_dlc <= 15) {
      *o++ = '_';
      *o++ = kDigits[frame.len8_dlc];
    }
  }
  if (frame.direction != Direction::unknown) {
    *o++ = ' ';
    *o++ = frame.direction == Direction::tx ? 'T' : 'R';
  }
  *o++ = '\n';
  return static_cast<std::size_t>(o - out);
}

}  // namespace momentum::can
