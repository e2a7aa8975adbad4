#include "momentum/can/signal_rows.hpp"

#include <algorithm>
#include <charconv>
#include <cstring>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"

namespace momentum::can {

namespace {
constexpr std::size_t kBufferSize = 1 << 16;
}

SignalRowWriter::SignalRowWriter(const Database& database, const std::string& path)
    : database_(database), out_(path) {
  buffer_.reserve(kBufferSize + 512);
  std::size_t most = 0;
  for (const auto& m : database_.messages()) most = std::max(most, m.signals.size());
  values_.resize(most);
  append("t,can_id,message,signal,raw,value\n");
}

SignalRowWriter::~SignalRowWriter() {
  try {
    flush();
  } catch (...) {
  }
}

void SignalRowWriter::append(std::string_view text) {
  buffer_.append(text);
  if (buffer_.size() >= kBufferSize) flush();
}

void SignalRowWriter::flush() {
  const std::string out = std::move(buffer_);
  buffer_.clear();
  out_.write(out);
}

void SignalRowWriter::write(const Frame& frame) {
  if (frame.error || frame.rtr) return;
  const Message* m = database_.find(frame.key());
  if (m == nullptr) {
    ++counts_.unknown_ids;
    return;
  }
  ++counts_.decoded;
  bool truncated = false;
  const std::size_t n = decode(*m, frame, values_.data(), &truncated);
  if (truncated) ++counts_.short_frames;
  char t[48], id[8], raw[48], value[48];
  const std::size_t t_len = format_frame_time(frame, t);
  const std::size_t id_len = format_id(frame, id);
  for (std::size_t k = 0; k < n; ++k) {
    const Signal& s = m->signals[values_[k].index];
    row_.assign(t, t_len);
    row_ += ',';
    row_.append(id, id_len);
    row_ += ',';
    row_ += m->name;
    row_ += ',';
    row_ += s.name;
    row_ += ',';
    row_.append(raw, format_raw(s, values_[k].bits, raw));
    row_ += ',';
    row_.append(value, format_physical(s, values_[k].bits, value));
    row_ += '\n';
    append(row_);
  }
}

std::size_t format_frame_time(const Frame& frame, char* out) {
  if (!frame.has_time) {
    std::memcpy(out, "nan", 3);
    return 3;
  }
  return core::format_nanoseconds(frame.time_ns, 0, out);
}

std::uint32_t parse_can_id(std::string_view text) {
  const std::string shown(text);
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) text.remove_prefix(2);
  if (text.empty() || text.size() > 8 || text.find_first_not_of("0123456789abcdefABCDEF") != std::string_view::npos)
    throw Error("'" + shown + "' is not a hexadecimal can id");
  std::uint32_t id = 0;
  std::from_chars(text.data(), text.data() + text.size(), id, 16);
  if (id > kExtendedMask) throw Error("'" + shown + "' is above 1FFFFFFF");
  return (text.size() == 8 || id > kStandardMask) ? (id | kExtendedFlag) : id;
}

}  // namespace momentum::can
