#include "momentum/can/asc.hpp"

#include <array>
#include <cstring>

#include "momentum/core/text.hpp"

namespace momentum::can {

namespace {

constexpr std::size_t kMaxTokens = 80;  // an FD frame: 64 data bytes and a dozen fields

struct Tokens {
  std::array<std::string_view, kMaxTokens> items;
  std::size_t count = 0;
  std::string_view operator[](std::size_t k) const { return k < count ? items[k] : std::string_view(); }
};

void split(std::string_view line, Tokens& tokens) {
  core::Words words(line);
  for (std::string_view word = words.next(); !word.empty() && tokens.count < kMaxTokens; word = words.next())
    tokens.items[tokens.count++] = word;
}

int digit_value(char c, bool decimal) {
  if (c >= '0' && c <= '9') return c - '0';
  if (decimal) return -1;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

bool parse_number(std::string_view text, bool decimal, std::uint64_t limit, std::uint64_t& value) {
  if (text.empty()) return false;
  value = 0;
  for (const char c : text) {
    const int d = digit_value(c, decimal);
    if (d < 0) return false;
    value = value * (decimal ? 10 : 16) + static_cast<unsigned>(d);
    if (value > limit) return false;
  }
  return true;
}

// "12.345678" seconds to nanoseconds.
bool parse_time(std::string_view text, std::int64_t& ns) {
  std::int64_t seconds = 0, fraction = 0;
  std::size_t k = 0, digits = 0;
  while (k < text.size() && text[k] >= '0' && text[k] <= '9') {
    seconds = seconds * 10 + (text[k++] - '0');
    if (seconds > 9000000000LL) return false;
  }
  if (k == 0) return false;
  if (k < text.size() && text[k] == '.') {
    ++k;
    while (k < text.size() && text[k] >= '0' && text[k] <= '9') {
      if (digits < 9) fraction = fraction * 10 + (text[k] - '0'), ++digits;
      ++k;
    }
  }
  if (k != text.size()) return false;
  for (; digits < 9; ++digits) fraction *= 10;
  ns = seconds * 1000000000 + fraction;
  return true;
}

bool bit(std::string_view text) { return text == "0" || text == "1"; }

LineKind bad(ParsedLine& info, const char* why) {
  info.error = why;
  return LineKind::bad;
}

// Identifier with an optional 'x' suffix (29 bits).
bool parse_identifier(std::string_view text, bool decimal, Frame& frame) {
  frame.extended = !text.empty() && (text.back() == 'x' || text.back() == 'X');
  if (frame.extended) text.remove_suffix(1);
  std::uint64_t id = 0;
  if (!parse_number(text, decimal, frame.extended ? 0x1FFFFFFF : 0x7FF, id)) return false;
  frame.id = static_cast<std::uint32_t>(id);
  return true;
}

bool parse_direction(std::string_view text, Frame& frame) {
  if (text == "Rx") frame.direction = Direction::rx;
  else if (text == "Tx") frame.direction = Direction::tx;
  else return false;
  return true;
}

LineKind data_bytes(const Tokens& t, std::size_t first, std::size_t count, bool decimal, Frame& frame,
                    ParsedLine& info) {
  if (first + count > t.count) return bad(info, "fewer data bytes than the length says");
  for (std::size_t k = 0; k < count; ++k) {
    std::uint64_t byte = 0;
    if (!parse_number(t[first + k], decimal, 0xFF, byte)) return bad(info, "bad data byte");
    frame.data[k] = static_cast<std::uint8_t>(byte);
  }
  frame.len = static_cast<std::uint8_t>(count);
  return LineKind::frame;
}

}  // namespace

bool is_asc_header(std::string_view line) {
  return line.rfind("date ", 0) == 0 || line.rfind("base ", 0) == 0;
}

LineKind parse_asc_line(std::string_view line, Frame& frame, ParsedLine& info, AscState& state) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  info = ParsedLine{};
  frame = Frame{};
  Tokens t;
  split(line, t);
  if (t.count == 0 || t[0].rfind("//", 0) == 0) return LineKind::skip;
  if (t[0] == "base") {
    if (t[1] == "dec") state.decimal = true;
    else if (t[1] == "hex") state.decimal = false;
    else return bad(info, "base must be hex or dec");
    if (t[2] == "timestamps") state.relative = t[3] == "relative";
    return LineKind::skip;
  }
  if (t[0] == "date" || t[0] == "Begin" || t[0] == "End" || t[0] == "internal" || t[0] == "no")
    return LineKind::skip;
  std::int64_t ns = 0;
  if (!parse_time(t[0], ns)) return bad(info, "not a Vector ASC line (no time)");
  if (state.relative) {
    if (__builtin_add_overflow(state.running_ns, ns, &state.running_ns)) state.running_ns = INT64_MAX;
    ns = state.running_ns;
  }
  frame.time_ns = ns;
  frame.has_time = true;
  info.time_kind = TimeKind::log;
  info.stamp_ns = ns;

  if (t[1] == "CANFD") {
    // <time> CANFD <channel> <dir> <id> [<name>] <brs> <esi> <dlc> <length> <data>...
    info.interface = t[2];
    if (!parse_direction(t[3], frame)) return LineKind::skip;  // TxRq and the like
    if (!parse_identifier(t[4], state.decimal, frame)) return bad(info, "bad identifier");
    std::size_t k = 5;
    if (!(bit(t[k]) && bit(t[k + 1]))) ++k;  // a symbolic name
    if (!(bit(t[k]) && bit(t[k + 1]))) return bad(info, "bad CAN FD flags");
    frame.fd = true;
    frame.fd_flags = static_cast<std::uint8_t>((t[k] == "1" ? 1 : 0) | (t[k + 1] == "1" ? 2 : 0));
    std::uint64_t length = 0;
    if (!parse_number(t[k + 3], true, 64, length)) return bad(info, "bad CAN FD data length");
    return data_bytes(t, k + 4, static_cast<std::size_t>(length), state.decimal, frame, info);
  }
  std::uint64_t channel = 0;
  if (!parse_number(t[1], true, 0xFFFF, channel)) return LineKind::skip;  // Start of measurement, ...
  info.interface = t[1];
  if (t[2] == "ErrorFrame") {
    frame.error = true;
    return LineKind::frame;
  }
  if (!parse_identifier(t[2], state.decimal, frame)) return LineKind::skip;  // Statistic:, Status:, ...
  if (!parse_direction(t[3], frame)) return LineKind::skip;
  if (t[4] == "r") {
    frame.rtr = true;
    std::uint64_t dlc = 0;
    if (t.count > 5 && parse_number(t[5], false, 8, dlc)) frame.len = static_cast<std::uint8_t>(dlc);
    return LineKind::frame;
  }
  if (t[4] != "d") return bad(info, "expected d (data) or r (remote) after the direction");
  std::uint64_t dlc = 0;
  if (!parse_number(t[5], false, 15, dlc)) return bad(info, "bad DLC");
  if (dlc > 8) frame.len8_dlc = static_cast<std::uint8_t>(dlc);
  return data_bytes(t, 6, dlc > 8 ? 8 : static_cast<std::size_t>(dlc), state.decimal, frame, info);
}

}  // namespace momentum::can
