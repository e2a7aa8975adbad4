#include "momentum/can/dbc.hpp"

#include <algorithm>
#include <bitset>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "momentum/core/error.hpp"
#include "momentum/core/text.hpp"

namespace momentum::can {

namespace {

bool is_ident_start(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_'; }
bool is_ident_char(char c) { return is_ident_start(c) || (c >= '0' && c <= '9'); }
bool is_number_char(char c) {
  return (c >= '0' && c <= '9') || c == '+' || c == '-' || c == '.' || c == 'e' || c == 'E';
}

struct Number {
  double value = 0;
  bool is_integer = false;  // written without '.', 'e' or 'E' and fits in int64
  std::int64_t integer = 0;
};

// Signal as read, before the multiplexing references are resolved.
struct PendingMux {
  std::string parent;  // switch name from SG_MUL_VAL_
  std::vector<std::pair<std::uint64_t, std::uint64_t>> ranges;
  std::uint32_t line = 0;
};

}  // namespace

class DbcParser {
 public:
  DbcParser(std::string_view text, std::string_view name) : p_(text.data()), end_(text.data() + text.size()), name_(name) {}

  Database run();

 private:
  [[noreturn]] void fail(const std::string& message) const { throw Error(located(name_, line_, message)); }
  [[noreturn]] void fail_at(std::uint32_t line, const std::string& message) const {
    throw Error(located(name_, line, message));
  }

  void skip_ws() {
    while (p_ < end_) {
      const char c = *p_;
      if (c == '\n') {
        ++line_;
        ++p_;
      } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
        ++p_;
      } else {
        break;
      }
    }
  }
  void skip_inline_ws() {
    while (p_ < end_ && (*p_ == ' ' || *p_ == '\t' || *p_ == '\r')) ++p_;
  }
  void skip_to_eol() {
    while (p_ < end_ && *p_ != '\n') ++p_;
  }
  bool at_eol() {
    skip_inline_ws();
    return p_ >= end_ || *p_ == '\n';
  }
  std::string_view identifier(const char* what) {
    skip_ws();
    if (p_ >= end_ || !is_ident_start(*p_)) fail(std::string("expected ") + what);
    const char* start = p_;
    while (p_ < end_ && is_ident_char(*p_)) ++p_;
    return {start, static_cast<std::size_t>(p_ - start)};
  }
  void expect(char c) {
    skip_ws();
    if (p_ >= end_ || *p_ != c) fail(std::string("expected '") + c + "'");
    ++p_;
  }
  bool accept(char c) {
    skip_ws();
    if (p_ < end_ && *p_ == c) {
      ++p_;
      return true;
    }
    return false;
  }
  Number number(const char* what) {
    skip_ws();
    const char* start = p_;
    while (p_ < end_ && is_number_char(*p_)) ++p_;
    std::string_view text(start, static_cast<std::size_t>(p_ - start));
    if (text.empty()) fail(std::string("expected ") + what);
    Number n;
    std::string_view t = text;
    if (t.front() == '+') t.remove_prefix(1);
    if (t.find_first_of(".eE") == std::string_view::npos) {
      auto r = std::from_chars(t.data(), t.data() + t.size(), n.integer);
      if (r.ec == std::errc() && r.ptr == t.data() + t.size()) {
        n.is_integer = true;
        n.value = static_cast<double>(n.integer);
        return n;
      }
    }
    auto r = std::from_chars(t.data(), t.data() + t.size(), n.value);
    if (r.ec == std::errc::result_out_of_range) {
      n.value = std::strtod(std::string(t).c_str(), nullptr);
    } else if (r.ec != std::errc() || r.ptr != t.data() + t.size()) {
      fail(std::string("bad number '") + std::string(text) + "' for " + what);
    }
    return n;
  }
  std::uint64_t unsigned_number(const char* what) {
    skip_ws();
    const char* start = p_;
    while (p_ < end_ && *p_ >= '0' && *p_ <= '9') ++p_;
    std::uint64_t value = 0;
    auto r = std::from_chars(start, p_, value);
    if (start == p_ || r.ec != std::errc()) fail(std::string("expected ") + what);
    return value;
  }
  std::string string_literal(const char* what) {
    skip_ws();
    if (p_ >= end_ || *p_ != '"') fail(std::string("expected ") + what + " (a quoted string)");
    const std::uint32_t start_line = line_;
    ++p_;
    std::string out;
    while (p_ < end_ && *p_ != '"') {
      if (*p_ == '\\' && p_ + 1 < end_ && (p_[1] == '"' || p_[1] == '\\')) ++p_;
      if (*p_ == '\n') ++line_;
      out.push_back(*p_++);
    }
    if (p_ >= end_) fail_at(start_line, "unterminated string");
    ++p_;
    return out;
  }
  // Skips to the ';' that ends the statement (strings may hold ';').
  void skip_statement(std::string_view keyword) {
    const std::uint32_t start_line = line_;
    while (p_ < end_) {
      if (*p_ == '"') {
        string_literal("string");
        continue;
      }
      if (*p_ == '\n') ++line_;
      if (*p_++ == ';') return;
    }
    fail_at(start_line, std::string("missing ';' after ") + std::string(keyword));
  }
  void end_statement(std::string_view keyword) {
    skip_ws();
    if (p_ >= end_ || *p_ != ';') fail(std::string("expected ';' to end ") + std::string(keyword));
    ++p_;
  }

  Message* message_by_id(std::uint64_t id) {
    auto it = by_id_.find(id);
    if (it == by_id_.end()) fail("unknown message id " + std::to_string(id));
    return &parts_.messages_[it->second];
  }
  Signal* signal_by_name(Message* m, std::string_view name) {
    for (Signal& s : m->signals)
      if (s.name == name) return &s;
    fail("message " + m->name + " has no signal " + std::string(name));
  }

  void parse_message();
  void parse_signal();
  void parse_comment();
  void parse_attribute_definition();
  void parse_attribute_default();
  void parse_attribute();
  void parse_value_table();
  void parse_value_type();
  void parse_mux_values();

  const char* p_;
  const char* end_;
  std::string_view name_;
  std::uint32_t line_ = 1;
  void finish();
  // Throws `file:line: signal B overlaps signal A ...` when two signals of `m` that can be in
  // one frame (not selected by different values of one multiplexer) share a payload bit:
  // decoding would give garbage for at least one of them. cantools refuses the same (strict).
  void refuse_overlaps(const Message& m) const;

  Database parts_;
  std::map<std::uint64_t, std::size_t> by_id_;
  Message* current_ = nullptr;
  Message pseudo_;
  bool current_is_pseudo_ = false;
  // Per message index: the multiplexer text of each signal (by signal index) and SG_MUL_VAL_.
  std::vector<std::vector<std::string>> mux_text_;
  std::vector<std::map<std::string, PendingMux>> mux_values_;
  std::vector<std::string> frame_format_enum_;
  std::string frame_format_default_;
  std::map<std::size_t, std::string> frame_format_;  // message index -> enum value
};

Database DbcParser::run() {
  for (;;) {
    skip_ws();
    if (p_ >= end_) break;
    if (*p_ == '/' && p_ + 1 < end_ && p_[1] == '/') {  // not DBC, but some tools write it
      skip_to_eol();
      continue;
    }
    if (!is_ident_start(*p_)) fail(std::string("unexpected character '") + *p_ + "'");
    const std::string_view kw = identifier("keyword");
    if (kw != "SG_") current_ = nullptr;  // BO_ sets it again
    if (kw == "VERSION") {
      parts_.version_ = string_literal("version");
    } else if (kw == "NS_") {
      expect(':');
      skip_to_eol();
      // The symbol list: indented lines up to the next statement.
      while (p_ < end_) {
        if (*p_ == '\n') {
          ++line_;
          ++p_;
        } else if (*p_ == ' ' || *p_ == '\t' || *p_ == '\r') {
          skip_to_eol();
        } else {
          break;
        }
      }
    } else if (kw == "BS_" || kw == "BU_") {
      skip_to_eol();
    } else if (kw == "BO_") {
      parse_message();
    } else if (kw == "SG_") {
      parse_signal();
    } else if (kw == "CM_") {
      parse_comment();
    } else if (kw == "BA_DEF_") {
      parse_attribute_definition();
    } else if (kw == "BA_DEF_DEF_") {
      parse_attribute_default();
    } else if (kw == "BA_") {
      parse_attribute();
    } else if (kw == "VAL_") {
      parse_value_table();
    } else if (kw == "SIG_VALTYPE_") {
      parse_value_type();
    } else if (kw == "SG_MUL_VAL_") {
      parse_mux_values();
    } else {
      bool keyword_like = true;
      for (char c : kw)
        if (!((c >= 'A' && c <= 'Z') || c == '_' || (c >= '0' && c <= '9'))) keyword_like = false;
      if (!keyword_like) fail("unknown statement '" + core::printable(kw) + "'");
      skip_statement(kw);
    }
  }
  finish();
  return std::move(parts_);
}

void DbcParser::parse_message() {
  const std::uint32_t line = line_;
  const std::uint64_t id = unsigned_number("message id");
  const std::string_view name = identifier("message name");
  expect(':');
  const std::uint64_t length = unsigned_number("message length");
  std::string sender;
  if (!at_eol()) sender = std::string(identifier("sender"));
  skip_to_eol();
  // Vector's container of signals that belong to no message: not a frame.
  if (name == "VECTOR__INDEPENDENT_SIG_MSG") {
    current_ = &pseudo_;
    pseudo_.signals.clear();
    current_is_pseudo_ = true;
    return;
  }
  current_is_pseudo_ = false;
  if (id > 0xFFFFFFFFULL) fail_at(line, "message id " + std::to_string(id) + " out of range");
  const std::uint32_t key = static_cast<std::uint32_t>(id);
  if ((key & kExtendedFlag) ? (key & ~(kExtendedFlag | kExtendedMask)) != 0 : key > kStandardMask)
    fail_at(line, "message id " + std::to_string(id) + " is neither an 11-bit nor a 29-bit id (bit 31 marks 29-bit ids)");
  if (length > kMaxPayload) fail_at(line, "message " + std::string(name) + " is longer than 64 bytes");
  if (by_id_.count(id)) fail_at(line, "message id " + std::to_string(id) + " defined twice");
  Message m;
  m.key = key;
  m.name = std::string(name);
  m.length = static_cast<std::uint32_t>(length);
  m.sender = sender;
  m.line = line;
  by_id_[id] = parts_.messages_.size();
  parts_.messages_.push_back(std::move(m));
  mux_text_.emplace_back();
  mux_values_.emplace_back();
  current_ = &parts_.messages_.back();
}

void DbcParser::parse_signal() {
  if (current_ == nullptr) fail("SG_ outside a BO_ message");
  Signal s;
  s.line = line_;
  s.name = std::string(identifier("signal name"));
  skip_ws();
  std::string mux;
  if (p_ < end_ && *p_ != ':') {
    const char* start = p_;
    while (p_ < end_ && is_ident_char(*p_)) ++p_;
    mux.assign(start, p_);
    bool ok = !mux.empty();
    if (ok && mux != "M") {
      std::size_t i = 0;
      ok = mux[i++] == 'm';
      std::size_t digits = 0;
      while (ok && i < mux.size() && mux[i] >= '0' && mux[i] <= '9') ++i, ++digits;
      ok = ok && digits > 0 && (i == mux.size() || (i + 1 == mux.size() && mux[i] == 'M'));
    }
    if (!ok) fail("bad multiplexer indicator '" + core::printable(mux) + "' for signal " + s.name);
  }
  expect(':');
  const std::uint64_t start = unsigned_number("start bit");
  expect('|');
  const std::uint64_t length = unsigned_number("signal length");
  expect('@');
  skip_ws();
  if (p_ >= end_ || (*p_ != '0' && *p_ != '1')) fail("expected byte order 0 (Motorola) or 1 (Intel) after '@'");
  s.byte_order = *p_++ == '1' ? ByteOrder::little_endian : ByteOrder::big_endian;
  if (p_ >= end_ || (*p_ != '+' && *p_ != '-')) fail("expected '+' or '-' after the byte order");
  s.is_signed = *p_++ == '-';
  expect('(');
  const Number factor = number("factor");
  expect(',');
  const Number offset = number("offset");
  expect(')');
  expect('[');
  const Number minimum = number("minimum");
  expect('|');
  const Number maximum = number("maximum");
  expect(']');
  s.unit = string_literal("unit");
  while (!at_eol()) {
    if (*p_ == ',') {
      ++p_;
      continue;
    }
    s.receivers.emplace_back(identifier("receiver"));
  }
  if (length < 1 || length > 64) fail_at(s.line, "signal " + s.name + " has length " + std::to_string(length) + " (1 to 64 bits)");
  if (start > 511) fail_at(s.line, "signal " + s.name + " starts at bit " + std::to_string(start) + ", beyond 64 bytes");
  if (factor.value == 0 || !std::isfinite(factor.value)) fail_at(s.line, "signal " + s.name + " has a zero or non-finite factor");
  s.start_bit = static_cast<std::uint16_t>(start);
  s.length = static_cast<std::uint16_t>(length);
  s.factor = factor.value;
  s.offset = offset.value;
  s.integer_scaling = factor.is_integer && offset.is_integer;
  s.factor_int = factor.integer;
  s.offset_int = offset.integer;
  s.minimum = minimum.value;
  s.maximum = maximum.value;
  if (current_is_pseudo_) return;
  for (const Signal& other : current_->signals)
    if (other.name == s.name) fail_at(s.line, "signal " + s.name + " defined twice in message " + current_->name);
  s.is_multiplexer = !mux.empty() && mux.back() == 'M';
  mux_text_.back().push_back(mux);
  current_->signals.push_back(std::move(s));
}

void DbcParser::parse_comment() {
  skip_ws();
  if (p_ < end_ && *p_ == '"') {
    string_literal("comment");
    end_statement("CM_");
    return;
  }
  const std::string_view kind = identifier("BU_, BO_, SG_ or EV_ after CM_");
  if (kind == "BO_") {
    const std::uint64_t id = unsigned_number("message id");
    std::string text = string_literal("comment");
    end_statement("CM_");
    if (auto it = by_id_.find(id); it != by_id_.end()) parts_.messages_[it->second].comment = std::move(text);
  } else if (kind == "SG_") {
    const std::uint64_t id = unsigned_number("message id");
    const std::string_view signal = identifier("signal name");
    std::string text = string_literal("comment");
    end_statement("CM_");
    if (auto it = by_id_.find(id); it != by_id_.end()) {
      Message& m = parts_.messages_[it->second];
      for (Signal& s : m.signals)
        if (s.name == signal) s.comment = std::move(text);
    }
  } else {
    skip_statement("CM_");
  }
}

void DbcParser::parse_attribute_definition() {
  skip_ws();
  std::string_view object;
  if (p_ < end_ && *p_ != '"') object = identifier("object type");
  const std::string name = string_literal("attribute name");
  if (name == "VFrameFormat" && object == "BO_") {
    const std::string_view type = identifier("attribute type");
    if (type == "ENUM") {
      frame_format_enum_.clear();
      do {
        frame_format_enum_.push_back(string_literal("enum value"));
      } while (accept(','));
      end_statement("BA_DEF_");
      return;
    }
  }
  skip_statement("BA_DEF_");
}

void DbcParser::parse_attribute_default() {
  const std::string name = string_literal("attribute name");
  skip_ws();
  if (name == "VFrameFormat" && p_ < end_ && *p_ == '"') {
    frame_format_default_ = string_literal("default value");
    end_statement("BA_DEF_DEF_");
    return;
  }
  skip_statement("BA_DEF_DEF_");
}

void DbcParser::parse_attribute() {
  const std::string name = string_literal("attribute name");
  skip_ws();
  if (name == "VFrameFormat" && p_ + 3 <= end_ && std::memcmp(p_, "BO_", 3) == 0) {
    identifier("BO_");
    const std::uint64_t id = unsigned_number("message id");
    skip_ws();
    std::string value;
    if (p_ < end_ && *p_ == '"') {
      value = string_literal("value");
    } else {
      const Number n = number("enum index");
      if (n.is_integer && n.integer >= 0 && static_cast<std::size_t>(n.integer) < frame_format_enum_.size())
        value = frame_format_enum_[static_cast<std::size_t>(n.integer)];
    }
    end_statement("BA_");
    if (auto it = by_id_.find(id); it != by_id_.end()) frame_format_[it->second] = value;
    return;
  }
  skip_statement("BA_");
}

void DbcParser::parse_value_table() {
  skip_ws();
  if (p_ >= end_ || *p_ < '0' || *p_ > '9') {  // VAL_ of an environment variable
    skip_statement("VAL_");
    return;
  }
  const std::uint64_t id = unsigned_number("message id");
  const std::string_view signal = identifier("signal name");
  std::vector<std::pair<std::int64_t, std::string>> choices;
  for (;;) {
    skip_ws();
    if (p_ < end_ && *p_ == ';') {
      ++p_;
      break;
    }
    const Number value = number("value");
    // A description belongs to a raw (integer) value; 3.0 is taken as 3, 1.5 or 1e30 is wrong.
    if (!value.is_integer && !(value.value == std::trunc(value.value) && std::abs(value.value) < 0x1p63))
      fail("value description for a raw value that is not a 64-bit integer");
    std::string text = string_literal("value description");
    choices.emplace_back(value.is_integer ? value.integer : static_cast<std::int64_t>(value.value), std::move(text));
  }
  auto it = by_id_.find(id);
  if (it == by_id_.end()) return;  // cantools ignores tables of unknown messages too
  Message& m = parts_.messages_[it->second];
  for (Signal& s : m.signals)
    if (s.name == signal) s.choices = std::move(choices);
}

void DbcParser::parse_value_type() {
  const std::uint32_t line = line_;
  const std::uint64_t id = unsigned_number("message id");
  const std::string_view signal = identifier("signal name");
  accept(':');
  const std::uint64_t type = unsigned_number("value type");
  end_statement("SIG_VALTYPE_");
  Message* m = message_by_id(id);
  Signal* s = signal_by_name(m, signal);
  if (type == 1) {
    s->value_type = ValueType::float32;
  } else if (type == 2) {
    s->value_type = ValueType::float64;
  } else if (type == 0) {
    s->value_type = ValueType::integer;
  } else {
    fail_at(line, "SIG_VALTYPE_ " + std::to_string(type) + " (expected 0, 1 or 2)");
  }
}

void DbcParser::parse_mux_values() {
  const std::uint32_t line = line_;
  const std::uint64_t id = unsigned_number("message id");
  const std::string_view signal = identifier("signal name");
  const std::string_view parent = identifier("multiplexer switch name");
  PendingMux pending;
  pending.parent = std::string(parent);
  pending.line = line;
  do {
    const std::uint64_t lo = unsigned_number("range start");
    expect('-');
    const std::uint64_t hi = unsigned_number("range end");
    if (hi < lo) fail("range " + std::to_string(lo) + "-" + std::to_string(hi) + " is empty");
    pending.ranges.emplace_back(lo, hi);
  } while (accept(','));
  end_statement("SG_MUL_VAL_");
  auto it = by_id_.find(id);
  if (it == by_id_.end()) fail_at(line, "unknown message id " + std::to_string(id));
  signal_by_name(&parts_.messages_[it->second], signal);
  auto& map = mux_values_[it->second];
  auto [slot, inserted] = map.try_emplace(std::string(signal), pending);
  if (!inserted) {
    if (slot->second.parent != pending.parent) fail_at(line, "signal " + std::string(signal) + " has two multiplexer switches");
    slot->second.ranges.insert(slot->second.ranges.end(), pending.ranges.begin(), pending.ranges.end());
  }
}

namespace {
// Byte window, shift and mask of a signal; throws if it does not fit in `bytes`.
Extraction compute_extraction(const Signal& s, std::uint32_t bytes, std::string_view file, const std::string& message) {
  Extraction e;
  e.mask = s.length == 64 ? ~std::uint64_t{0} : ((std::uint64_t{1} << s.length) - 1);
  const std::uint32_t total_bits = bytes * 8;
  std::uint32_t first_bit, last_bit;  // in the order of the byte order's bit stream
  if (s.byte_order == ByteOrder::little_endian) {
    first_bit = s.start_bit;
    last_bit = first_bit + s.length - 1;
    e.byte = static_cast<std::uint16_t>(first_bit / 8);
    const std::uint32_t rel = first_bit % 8;
    e.wide = rel + s.length > 64;
    e.shift = static_cast<std::uint8_t>(rel);
    e.min_len = static_cast<std::uint16_t>(last_bit / 8 + 1);
  } else {
    // Motorola: the start bit is the MSB, numbered bytewise (bit 7 = MSB of byte 0). In the
    // big-endian bit stream (position 0 = MSB of byte 0) it is at byte*8 + 7 - bit.
    first_bit = (s.start_bit / 8) * 8 + (7 - s.start_bit % 8);
    last_bit = first_bit + s.length - 1;
    e.byte = static_cast<std::uint16_t>(first_bit / 8);
    const std::uint32_t rel = first_bit % 8;
    e.wide = rel + s.length > 64;
    e.shift = static_cast<std::uint8_t>(e.wide ? 128 - (rel + s.length) : 64 - (rel + s.length));
    e.min_len = static_cast<std::uint16_t>(last_bit / 8 + 1);
  }
  if (last_bit >= total_bits) {
    throw Error(located(file, s.line, "signal " + s.name + " (start bit " + std::to_string(s.start_bit) + ", " +
                                          std::to_string(s.length) + " bits, " +
                                          (s.byte_order == ByteOrder::little_endian ? "Intel" : "Motorola") +
                                          ") does not fit in the " + std::to_string(bytes) + " bytes of message " + message));
  }
  return e;
}

}  // namespace

namespace {

constexpr std::size_t kMaxPayloadBits = 8 * kMaxPayload;

// The payload bits a signal occupies, numbered byte * 8 + bit (bit 0 the least significant).
std::bitset<kMaxPayloadBits> signal_bits(const Signal& s) {
  std::bitset<kMaxPayloadBits> bits;
  for (std::uint32_t k = 0; k < s.length; ++k) {
    std::uint32_t bit;
    if (s.byte_order == ByteOrder::little_endian) {
      bit = s.start_bit + k;
    } else {  // Motorola: walk the big-endian bit stream from the MSB, map back to byte and bit
      const std::uint32_t position = (s.start_bit / 8) * 8 + (7 - s.start_bit % 8) + k;
      bit = (position / 8) * 8 + (7 - position % 8);
    }
    if (bit < kMaxPayloadBits) bits.set(bit);
  }
  return bits;
}

// True when signals a and b of `m` can be present in one frame: unless some multiplexer selects
// them through different branches whose value ranges do not meet.
bool can_coexist(const Message& m, std::size_t a, std::size_t b) {
  // The chain from each signal up to its root: the signal, its selector, that one's, ...
  auto chain = [&](std::size_t i) {
    std::vector<std::size_t> out{i};
    while (m.signals[out.back()].mux_parent >= 0) out.push_back(static_cast<std::size_t>(m.signals[out.back()].mux_parent));
    return out;
  };
  const std::vector<std::size_t> up_a = chain(a), up_b = chain(b);
  for (std::size_t ia = 0; ia < up_a.size(); ++ia) {
    for (std::size_t ib = 0; ib < up_b.size(); ++ib) {
      if (up_a[ia] != up_b[ib]) continue;
      // The nearest common selector (or one signal selects the other: both present at once).
      if (ia == 0 || ib == 0) return true;
      const auto& ranges_a = m.signals[up_a[ia - 1]].mux_ranges;
      const auto& ranges_b = m.signals[up_b[ib - 1]].mux_ranges;
      for (const auto& ra : ranges_a)
        for (const auto& rb : ranges_b)
          if (ra.first <= rb.second && rb.first <= ra.second) return true;
      return false;
    }
  }
  return true;  // separate roots: both always present
}

}  // namespace

void DbcParser::refuse_overlaps(const Message& m) const {
  std::vector<std::bitset<kMaxPayloadBits>> bits;
  bits.reserve(m.signals.size());
  for (const Signal& s : m.signals) bits.push_back(signal_bits(s));
  for (std::size_t b = 1; b < m.signals.size(); ++b) {
    for (std::size_t a = 0; a < b; ++a) {
      const auto shared = bits[a] & bits[b];
      if (shared.none() || !can_coexist(m, a, b)) continue;
      std::size_t first = 0;
      while (!shared.test(first)) ++first;
      const Signal& later = m.signals[a].line > m.signals[b].line ? m.signals[a] : m.signals[b];
      const Signal& earlier = &later == &m.signals[a] ? m.signals[b] : m.signals[a];
      throw Error(located(name_, later.line,
                          "signal " + later.name + " overlaps signal " + earlier.name + " (line " +
                              std::to_string(earlier.line) + ") of message " + m.name + " at byte " +
                              std::to_string(first / 8) + " bit " + std::to_string(first % 8) +
                              " (both can be in one frame)"));
    }
  }
}

int Message::find(std::string_view signal_name) const {
  for (std::size_t i = 0; i < signals.size(); ++i)
    if (signals[i].name == signal_name) return static_cast<int>(i);
  return -1;
}

void DbcParser::finish() {
  for (std::size_t mi = 0; mi < parts_.messages_.size(); ++mi) {
    Message& m = parts_.messages_[mi];
    // Frame format: VFrameFormat of the message, else the attribute's default; long payloads
    // are FD whatever the attribute says.
    std::string format = frame_format_default_;
    if (auto it = frame_format_.find(mi); it != frame_format_.end()) format = it->second;
    m.is_fd = m.length > 8 || format.find("_FD") != std::string::npos;

    const std::vector<std::string>& mux = mux_text_[mi];
    const auto& extended = mux_values_[mi];
    int plain_multiplexer = -1, multiplexers = 0;
    for (std::size_t i = 0; i < m.signals.size(); ++i) {
      if (mux[i] == "M") {
        if (plain_multiplexer < 0) plain_multiplexer = static_cast<int>(i);
        ++multiplexers;
      }
    }
    for (std::size_t i = 0; i < m.signals.size(); ++i) {
      Signal& s = m.signals[i];
      if (s.value_type != ValueType::integer && s.length != (s.value_type == ValueType::float32 ? 32 : 64))
        throw Error(located(name_, s.line, "signal " + s.name + " is a " +
                                               (s.value_type == ValueType::float32 ? "float (32 bits)" : "double (64 bits)") +
                                               " but has " + std::to_string(s.length) + " bits"));
      s.extraction = compute_extraction(s, m.length, name_, m.name);
      auto ext = extended.find(s.name);
      if (ext != extended.end()) {
        const int parent = m.find(ext->second.parent);
        if (parent < 0)
          throw Error(located(name_, ext->second.line, "message " + m.name + " has no multiplexer switch " + ext->second.parent));
        if (static_cast<std::size_t>(parent) == i)
          throw Error(located(name_, ext->second.line, "signal " + s.name + " multiplexes itself"));
        s.mux_parent = parent;
        s.mux_ranges = ext->second.ranges;
        m.signals[static_cast<std::size_t>(parent)].is_multiplexer = true;
      } else if (mux[i].size() > 1 || (mux[i].size() == 1 && mux[i] != "M")) {
        // m<k> or m<k>M without SG_MUL_VAL_: selected by the message's plain multiplexer.
        if (plain_multiplexer < 0)
          throw Error(located(name_, s.line, "signal " + s.name + " is multiplexed but message " + m.name + " has no multiplexer (M)"));
        if (multiplexers > 1)
          throw Error(located(name_, s.line, "message " + m.name + " has several multiplexers: signal " + s.name + " needs SG_MUL_VAL_"));
        std::uint64_t k = 0;
        std::from_chars(mux[i].data() + 1, mux[i].data() + mux[i].size(), k);
        s.mux_parent = plain_multiplexer;
        s.mux_ranges = {{k, k}};
      }
    }
    // A cycle of multiplexer references would make presence undefined.
    for (std::size_t i = 0; i < m.signals.size(); ++i) {
      int at = static_cast<int>(i);
      for (std::size_t steps = 0; at >= 0; ++steps) {
        if (steps > m.signals.size())
          throw Error(located(name_, m.signals[i].line, "multiplexer references of signal " + m.signals[i].name + " form a cycle"));
        at = m.signals[static_cast<std::size_t>(at)].mux_parent;
      }
    }
    refuse_overlaps(m);
    // cantools lists signals by start bit (Motorola signals by the stream position of their
    // MSB), ties in file order; keep its order and renumber the parent indices.
    const std::size_t n = m.signals.size();
    std::vector<std::size_t> order(n);
    for (std::size_t i = 0; i < n; ++i) order[i] = i;
    auto sort_key = [&](std::size_t i) {
      const Signal& s = m.signals[i];
      return s.byte_order == ByteOrder::big_endian ? (s.start_bit / 8) * 8 + (7 - s.start_bit % 8) : s.start_bit;
    };
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return sort_key(a) < sort_key(b); });
    std::vector<int> new_index(n);
    for (std::size_t k = 0; k < n; ++k) new_index[order[k]] = static_cast<int>(k);
    std::vector<Signal> sorted;
    sorted.reserve(n);
    for (std::size_t k = 0; k < n; ++k) sorted.push_back(std::move(m.signals[order[k]]));
    for (Signal& s : sorted)
      if (s.mux_parent >= 0) s.mux_parent = new_index[static_cast<std::size_t>(s.mux_parent)];
    m.signals = std::move(sorted);
  }
  parts_.standard_.assign(kStandardMask + 1, -1);
  for (std::size_t mi = 0; mi < parts_.messages_.size(); ++mi) {
    const std::uint32_t key = parts_.messages_[mi].key;
    if (key & kExtendedFlag) {
      parts_.extended_[key] = mi;
    } else {
      parts_.standard_[key] = static_cast<std::int32_t>(mi);
    }
  }
}

Database Database::parse(std::string_view text, std::string_view name) {
  DbcParser parser(core::strip_byte_order_mark(text), name);  // some editors write one
  return parser.run();
}

Database Database::load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open: " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw Error(path + ": read error");
  return parse(text.str(), path);
}

const Message* Database::find_name(std::string_view message_name) const {
  for (const Message& m : messages_)
    if (m.name == message_name) return &m;
  return nullptr;
}

}  // namespace momentum::can
