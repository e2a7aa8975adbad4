#pragma once
// One CAN frame as read from a capture (candump text or a SocketCAN socket), independent of
// where it came from. Classic CAN (0..8 bytes, optional raw DLC 9..15), CAN FD (0..64 bytes)
// and error frames share the one struct; the payload array is padded with zeros beyond `len`
// so that signal extraction may read 8 bytes past any signal without a bounds check.

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace momentum::can {

// Flag bit of a message key (and of a DBC BO_ id) marking a 29-bit identifier. The value is
// the kernel's CAN_EFF_FLAG, which DBC files use for the same purpose.
inline constexpr std::uint32_t kExtendedFlag = 0x80000000U;
// The kernel's CAN_ERR_FLAG: set in the id of an error frame (candump prints it in the id).
inline constexpr std::uint32_t kErrorFlag = 0x20000000U;
inline constexpr std::uint32_t kStandardMask = 0x7FFU;
inline constexpr std::uint32_t kExtendedMask = 0x1FFFFFFFU;
// Largest payload of a CAN FD frame, bytes.
inline constexpr std::size_t kMaxPayload = 64;
// Payload storage: kMaxPayload plus zero padding for unaligned 8-byte loads past the end.
inline constexpr std::size_t kPayloadStorage = kMaxPayload + 16;

// Whether the frame was received from the bus or sent by this host (candump -x, python-can
// ` R`/` T`, MSG_DONTROUTE on a socket). Unknown when the capture does not say.
enum class Direction : std::uint8_t { unknown, rx, tx };

struct Frame {
  // Capture time in nanoseconds: since the epoch for absolute captures, since the start of
  // the capture for relative ones (candump -t d/-t z). Meaningless when has_time is false.
  std::int64_t time_ns = 0;
  bool has_time = false;
  // 11-bit or 29-bit identifier without flags. For an error frame: the error class bits
  // (CAN_ERR_MASK part of the id).
  std::uint32_t id = 0;
  bool extended = false;  // 29-bit identifier
  bool rtr = false;       // remote transmission request (classic CAN only)
  bool fd = false;        // CAN FD frame (`##` in candump text, CANFD_MTU on a socket)
  bool error = false;     // error frame (CAN_ERR_FLAG)
  // CAN FD flags nibble as candump prints it after `##` (bit 0 BRS, bit 1 ESI), 0 otherwise.
  std::uint8_t fd_flags = 0;
  // Payload length in bytes (0..8 classic, 0..64 FD). For an RTR frame: the requested length.
  std::uint8_t len = 0;
  // Raw DLC 9..15 of a classic frame carrying 8 bytes (candump `_E` suffix), 0 otherwise.
  std::uint8_t len8_dlc = 0;
  Direction direction = Direction::unknown;
  // Payload; bytes at len and beyond are zero.
  alignas(8) std::uint8_t data[kPayloadStorage] = {};

  // The key under which a DBC file knows this frame: id, plus kExtendedFlag for 29-bit ids.
  std::uint32_t key() const { return extended ? (id | kExtendedFlag) : id; }
  // Capture time in seconds (double): whole seconds plus the fraction, each exact in a double,
  // so that 1700000000.003 reads as the double nearest to it rather than 1700000000.0030003.
  double seconds() const {
    const std::int64_t whole = time_ns / 1000000000;
    const std::int64_t part = time_ns % 1000000000;
    return static_cast<double>(whole) + static_cast<double>(part) / 1e9;
  }
};

// Clears a frame for reuse (zero payload, no time, no flags).
void clear(Frame& frame);

// Writes the identifier as candump prints it: 3 upper-case hex digits for a standard id, 8 for
// an extended id or an error frame (with CAN_ERR_FLAG); returns the number of characters (3 or
// 8). `out` must hold 8 characters.
std::size_t format_id(const Frame& frame, char* out);

// The identifier of a DBC message key as candump prints it (3 or 8 hex digits).
std::size_t format_key(std::uint32_t key, char* out);

// Data length code of a payload length (CAN FD table: 12 -> 9, ..., 64 -> 15); lengths
// between table entries round up. Lengths above 64 give 15.
std::uint8_t len_to_dlc(std::size_t len);
// Payload length of a DLC (0..15); classic frames cap at 8 only when `fd` is false.
std::size_t dlc_to_len(std::uint8_t dlc, bool fd);

}  // namespace momentum::can
