#include "momentum/can/frame.hpp"

#include <cstring>

namespace momentum::can {

namespace {
constexpr char kHexDigits[] = "0123456789ABCDEF";

void put_hex(std::uint32_t value, int digits, char* out) {
  for (int i = digits - 1; i >= 0; --i) {
    out[i] = kHexDigits[value & 0xF];
    value >>= 4;
  }
}
}  // namespace

void clear(Frame& frame) {
  frame.time_ns = 0;
  frame.has_time = false;
  frame.id = 0;
  frame.extended = frame.rtr = frame.fd = frame.error = false;
  frame.fd_flags = frame.len = frame.len8_dlc = 0;
  frame.direction = Direction::unknown;
  std::memset(frame.data, 0, sizeof(frame.data));
}

std::size_t format_id(const Frame& frame, char* out) {
  if (frame.error) {
    put_hex((frame.id & kExtendedMask) | kErrorFlag, 8, out);
    return 8;
  }
  if (frame.extended) {
    put_hex(frame.id & kExtendedMask, 8, out);
    return 8;
  }
  put_hex(frame.id & kStandardMask, 3, out);
  return 3;
}

std::size_t format_key(std::uint32_t key, char* out) {
  if (key & kExtendedFlag) {
    put_hex(key & kExtendedMask, 8, out);
    return 8;
  }
  put_hex(key & kStandardMask, 3, out);
  return 3;
}

std::uint8_t len_to_dlc(std::size_t len) {
  if (len <= 8) return static_cast<std::uint8_t>(len);
  if (len <= 12) return 9;
  if (len <= 16) return 10;
  if (len <= 20) return 11;
  if (len <= 24) return 12;
  if (len <= 32) return 13;
  if (len <= 48) return 14;
  return 15;
}

std::size_t dlc_to_len(std::uint8_t dlc, bool fd) {
  static constexpr std::uint8_t kTable[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64};
  dlc &= 0x0F;
  if (!fd) return dlc > 8 ? 8 : dlc;
  return kTable[dlc];
}

}  // namespace momentum::can
