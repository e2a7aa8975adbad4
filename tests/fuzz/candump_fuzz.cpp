// libFuzzer target: candump text. Any input must parse without crashing, leaking or
// undefined behaviour; every frame parsed from a log-format line must survive
// format_log_line() and a second parse unchanged; frames of the fixed DBC below decode.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string_view>

#include "momentum/can/candump.hpp"
#include "momentum/can/codec.hpp"
#include "momentum/can/dbc.hpp"
#include "momentum/core/error.hpp"

using namespace momentum::can;

namespace {

const Database& database() {
  static const Database db = Database::parse(
      "BO_ 385 A: 8 X\n SG_ q1 : 0|32@1- (1E-006,0) [0|0] \"\" X\n SG_ dq1 : 39|32@0- (1E-005,0) [0|0] \"\" X\n"
      "BO_ 2147485568 F: 64 X\n SG_ Sel M : 0|8@1+ (1,0) [0|0] \"\" X\n SG_ W m1 : 8|64@1- (1,0) [0|0] \"\" X\n"
      " SG_ V m2 : 500|12@0+ (0.5,3) [0|0] \"\" X\n SG_ G m3 : 64|64@1- (1,0) [0|0] \"\" X\n"
      "SIG_VALTYPE_ 2147485568 G : 2;\n",
      "fuzz.dbc");
  return db;
}

void check_round_trip(const Frame& f, std::string_view iface) {
  char buf[kMaxLogLine];
  const std::size_t n = format_log_line(f, iface, buf);
  if (n == 0 || n > kMaxLogLine || buf[n - 1] != '\n') __builtin_trap();
  Frame back;
  ParsedLine info;
  if (parse_candump_line(std::string_view(buf, n - 1), back, info) != LineKind::frame) __builtin_trap();
  if (back.key() != f.key() || back.error != f.error || back.rtr != f.rtr || back.fd != f.fd || back.len != f.len ||
      std::memcmp(back.data, f.data, sizeof f.data) != 0 || info.stamp_ns != f.time_ns)
    __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool quiet = [] {
    momentum::set_warning_sink([](std::string_view) {});
    return true;
  }();
  (void)quiet;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  // Line by line, as the reader's parser sees it.
  std::size_t at = 0;
  Frame f;
  ParsedLine info;
  SignalValue values[16];
  while (at <= text.size()) {
    std::size_t nl = text.find('\n', at);
    if (nl == std::string_view::npos) nl = text.size();
    const std::string_view line = text.substr(at, nl - at);
    if (parse_candump_line(line, f, info) == LineKind::frame) {
      if (info.time_kind == TimeKind::log && info.stamp_ns >= 0 && info.interface.size() <= 32 &&
          !(f.rtr && f.len > 8)) {
        f.time_ns = info.stamp_ns;
        std::string_view iface = info.interface;
        if (iface.find_first_of("()#") == std::string_view::npos) check_round_trip(f, iface);
      }
      if (const Message* m = database().find(f.key())) decode(*m, f, values);
    }
    at = nl + 1;
  }
  // The reader, with its timestamp modes, as a stream.
  for (TimestampMode mode : {TimestampMode::automatic, TimestampMode::delta}) {
    CandumpOptions options;
    options.timestamps = mode;
    auto reader = CandumpReader::from_text(text, options);
    std::size_t frames = 0;
    while (reader->next(f)) ++frames;
    if (frames != reader->stats().frames) __builtin_trap();
  }
  return 0;
}
