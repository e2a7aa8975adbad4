#pragma once
// Live frames from a SocketCAN CAN_RAW socket. The reader core works on any descriptor that
// delivers one `struct can_frame` (CAN_MTU bytes) or `struct canfd_frame` (CANFD_MTU bytes)
// per record, so that tests can feed it through socketpair(AF_UNIX, SOCK_SEQPACKET), which
// keeps record boundaries as CAN_RAW does.

#include <cstdint>
#include <string>

#include "momentum/can/frame.hpp"

namespace momentum::can {

// Opens a CAN_RAW socket bound to `interface` ("any" for all), with CAN FD frames enabled
// (CAN_RAW_FD_FRAMES), kernel receive timestamps (SO_TIMESTAMP) and drop counting
// (SO_RXQ_OVFL, when the kernel has it). Returns the descriptor. Throws momentum::Error
// (`IFACE: message`) when the kernel has no SocketCAN, the interface does not exist, or a
// socket option is refused.
int open_can_socket(const std::string& interface);

// Asks for SO_TIMESTAMP on any socket (used on the test socketpair too). Throws on failure.
void enable_receive_timestamps(int fd);

// Counters of a socket reader; all start at zero.
struct SocketStats {
  std::uint64_t frames = 0;       // records returned as frames
  std::uint64_t bad_records = 0;  // records of a size that is neither CAN_MTU nor CANFD_MTU
  std::uint64_t lost_frames = 0;  // drops reported by the kernel (SO_RXQ_OVFL)
  std::uint64_t untimed = 0;      // records without a kernel timestamp (host clock used)
};

class SocketCanReader {
 public:
  // Reads from `fd`; closes it at destruction when `owns` is true. `name` is used in messages.
  SocketCanReader(int fd, bool owns, std::string name);
  ~SocketCanReader();
  SocketCanReader(const SocketCanReader&) = delete;
  SocketCanReader& operator=(const SocketCanReader&) = delete;

  enum class Status { frame, end, interrupted };
  // Blocks for the next record. frame: `frame` holds it, timed by the kernel's SO_TIMESTAMP
  // (the host's CLOCK_REALTIME when the record carries none), direction TX when the kernel
  // marks it MSG_DONTROUTE (our own transmission). end: the peer closed the socket.
  // interrupted: a signal arrived (call again to go on). Records of a wrong size are reported
  // through momentum::warn, counted and skipped. Throws momentum::Error on a socket error.
  Status next(Frame& frame);

  const SocketStats& stats() const { return stats_; }
  const std::string& name() const { return name_; }

 private:
  int fd_;
  bool owns_;
  std::string name_;
  std::uint32_t last_drop_count_ = 0;
  SocketStats stats_;
};

}  // namespace momentum::can
