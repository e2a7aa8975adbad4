#include "momentum/can/socketcan.hpp"

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "momentum/core/error.hpp"

#ifndef SO_RXQ_OVFL
#define SO_RXQ_OVFL 40
#endif

namespace momentum::can {

namespace {
[[noreturn]] void fail(const std::string& who, const std::string& what) {
  throw Error(who + ": " + what + ": " + std::strerror(errno));
}
}  // namespace

void enable_receive_timestamps(int fd) {
  const int on = 1;
  if (setsockopt(fd, SOL_SOCKET, SO_TIMESTAMP, &on, sizeof on) < 0) fail("socket", "cannot enable SO_TIMESTAMP");
}

int open_can_socket(const std::string& interface) {
  if (interface.empty() || interface.size() >= IFNAMSIZ) {
    errno = EINVAL;
    fail(interface.empty() ? "<empty>" : interface, "bad interface name");
  }
  const int fd = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    const int saved = errno;
    errno = saved;
    if (saved == EAFNOSUPPORT || saved == EPROTONOSUPPORT)
      throw Error(interface + ": cannot open a CAN socket: " + std::strerror(saved) + " (no SocketCAN in this kernel)");
    fail(interface, "cannot open a CAN socket");
  }
  try {
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    if (interface != "any") {
      const unsigned index = if_nametoindex(interface.c_str());
      if (index == 0) fail(interface, "no such CAN interface");
      addr.can_ifindex = static_cast<int>(index);
    }
    const int on = 1;
    if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on) < 0) fail(interface, "cannot enable CAN FD frames");
    enable_receive_timestamps(fd);
    // Drop counting is optional: old kernels lack it and the frames still come.
    (void)setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on);
    if (bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) < 0) fail(interface, "cannot bind the CAN socket");
  } catch (...) {
    ::close(fd);
    throw;
  }
  return fd;
}

SocketCanReader::SocketCanReader(int fd, bool owns, std::string name) : fd_(fd), owns_(owns), name_(std::move(name)) {}

SocketCanReader::~SocketCanReader() {
  if (owns_ && fd_ >= 0) ::close(fd_);
}

SocketCanReader::Status SocketCanReader::next(Frame& frame) {
  for (;;) {
    // One extra byte tells an oversized record from a CANFD_MTU one.
    alignas(8) unsigned char record[CANFD_MTU + 1];
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timeval)) + CMSG_SPACE(sizeof(std::uint32_t)) + 64];
    iovec iov{record, sizeof record};
    msghdr msg{};
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control;
    msg.msg_controllen = sizeof control;
    const ssize_t got = recvmsg(fd_, &msg, 0);
    if (got < 0) {
      if (errno == EINTR) return Status::interrupted;
      throw Error(name_ + ": read error: " + std::strerror(errno));
    }
    if (got == 0) return Status::end;

    bool timed = false;
    timeval tv{};
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level != SOL_SOCKET) continue;
      if (c->cmsg_type == SO_TIMESTAMP) {
        std::memcpy(&tv, CMSG_DATA(c), sizeof tv);
        timed = true;
      } else if (c->cmsg_type == SO_RXQ_OVFL) {
        std::uint32_t drops = 0;
        std::memcpy(&drops, CMSG_DATA(c), sizeof drops);
        stats_.lost_frames += drops - last_drop_count_;  // the kernel's counter wraps as u32
        last_drop_count_ = drops;
      }
    }

    if (got != static_cast<ssize_t>(CAN_MTU) && got != static_cast<ssize_t>(CANFD_MTU)) {
      ++stats_.bad_records;
      warn(name_ + ": record of " + std::to_string(got) + " bytes is neither a can_frame (" +
           std::to_string(CAN_MTU) + ") nor a canfd_frame (" + std::to_string(CANFD_MTU) + "): skipped");
      continue;
    }

    clear(frame);
    canid_t id;
    std::memcpy(&id, record, sizeof id);
    frame.extended = (id & CAN_EFF_FLAG) != 0;
    frame.rtr = (id & CAN_RTR_FLAG) != 0;
    frame.error = (id & CAN_ERR_FLAG) != 0;
    if (frame.error) {
      frame.extended = false;
      frame.id = id & CAN_ERR_MASK;
    } else {
      frame.id = id & (frame.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
    }
    if (got == static_cast<ssize_t>(CAN_MTU)) {
      can_frame cf;
      std::memcpy(&cf, record, sizeof cf);
      frame.len = cf.len > CAN_MAX_DLEN ? CAN_MAX_DLEN : cf.len;
      if (frame.len == CAN_MAX_DLEN && cf.len8_dlc > CAN_MAX_DLEN && cf.len8_dlc <= CAN_MAX_RAW_DLC)
        frame.len8_dlc = cf.len8_dlc;
      if (!frame.rtr) std::memcpy(frame.data, cf.data, frame.len);
    } else {
      canfd_frame fd;
      std::memcpy(&fd, record, sizeof fd);
      frame.fd = true;
      frame.rtr = false;  // there are no remote frames in CAN FD
      frame.fd_flags = fd.flags & 0x0F;
      frame.len = fd.len > CANFD_MAX_DLEN ? CANFD_MAX_DLEN : fd.len;
      std::memcpy(frame.data, fd.data, frame.len);
    }
    frame.direction = (msg.msg_flags & MSG_DONTROUTE) ? Direction::tx : Direction::rx;
    if (!timed) {
      ++stats_.untimed;
      timespec now{};
      clock_gettime(CLOCK_REALTIME, &now);
      frame.time_ns = static_cast<std::int64_t>(now.tv_sec) * 1000000000 + now.tv_nsec;
    } else {
      frame.time_ns = static_cast<std::int64_t>(tv.tv_sec) * 1000000000 + static_cast<std::int64_t>(tv.tv_usec) * 1000;
    }
    frame.has_time = true;
    ++stats_.frames;
    return Status::frame;
  }
}

}  // namespace momentum::can
