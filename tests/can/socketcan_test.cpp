// The live reader core, fed raw `struct can_frame` / `struct canfd_frame` records through
// socketpair(AF_UNIX, SOCK_SEQPACKET) (record boundaries kept, as on a CAN_RAW socket), with
// kernel receive timestamps (SO_TIMESTAMP works on AF_UNIX sockets too).

#include <gtest/gtest.h>
#include <linux/can.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cstring>
#include <string>
#include <vector>

#include "momentum/can/socketcan.hpp"
#include "momentum/core/error.hpp"

using namespace momentum::can;

namespace {

struct Pair {
  int reader = -1, writer = -1;
  Pair() {
    int fds[2];
    EXPECT_EQ(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, fds), 0);
    reader = fds[0];
    writer = fds[1];
  }
  ~Pair() {
    if (writer >= 0) close(writer);
  }
  void send_raw(const void* data, std::size_t size) const {
    ASSERT_EQ(send(writer, data, size, 0), static_cast<ssize_t>(size));
  }
};

std::int64_t now_ns() {
  timeval tv{};
  gettimeofday(&tv, nullptr);
  return static_cast<std::int64_t>(tv.tv_sec) * 1000000000 + tv.tv_usec * 1000LL;
}

TEST(SocketCan, ClassicFdRemoteErrorAndEnd) {
  Pair pair;
  enable_receive_timestamps(pair.reader);
  SocketCanReader reader(pair.reader, true, "pair");

  can_frame classic{};
  classic.can_id = 0x181;
  classic.len = 4;
  const unsigned char payload[4] = {0xDE, 0xAD, 0xBE, 0xEF};
  std::memcpy(classic.data, payload, 4);
  pair.send_raw(&classic, sizeof classic);

  canfd_frame fd{};
  fd.can_id = 0x1ABCDEF | CAN_EFF_FLAG;
  fd.len = 64;
  fd.flags = CANFD_BRS | CANFD_FDF;
  for (int i = 0; i < 64; ++i) fd.data[i] = static_cast<__u8>(i);
  pair.send_raw(&fd, sizeof fd);

  can_frame rtr{};
  rtr.can_id = 0x7FF | CAN_RTR_FLAG;
  rtr.len = 8;
  rtr.len8_dlc = 12;
  pair.send_raw(&rtr, sizeof rtr);

  can_frame err{};
  err.can_id = CAN_ERR_FLAG | 0x4;
  err.len = 8;
  err.data[1] = 0x04;
  pair.send_raw(&err, sizeof err);

  const char junk[10] = {};
  pair.send_raw(junk, sizeof junk);  // neither size: reported and skipped

  const std::int64_t before = now_ns() - 1000000000;
  Frame f;
  ASSERT_EQ(reader.next(f), SocketCanReader::Status::frame);
  EXPECT_EQ(f.id, 0x181U);
  EXPECT_FALSE(f.extended);
  EXPECT_FALSE(f.fd);
  EXPECT_EQ(f.len, 4);
  EXPECT_EQ(std::vector<int>(f.data, f.data + 4), (std::vector<int>{0xDE, 0xAD, 0xBE, 0xEF}));
  EXPECT_TRUE(f.has_time);
  EXPECT_GT(f.time_ns, before);
  EXPECT_LE(f.time_ns, now_ns());

  ASSERT_EQ(reader.next(f), SocketCanReader::Status::frame);
  EXPECT_TRUE(f.fd);
  EXPECT_TRUE(f.extended);
  EXPECT_EQ(f.id, 0x1ABCDEFU);
  EXPECT_EQ(f.fd_flags, CANFD_BRS | CANFD_FDF);
  EXPECT_EQ(f.len, 64);
  EXPECT_EQ(f.data[63], 63);

  ASSERT_EQ(reader.next(f), SocketCanReader::Status::frame);
  EXPECT_TRUE(f.rtr);
  EXPECT_EQ(f.id, 0x7FFU);
  EXPECT_EQ(f.len, 8);
  EXPECT_EQ(f.len8_dlc, 12);
  EXPECT_EQ(f.data[0], 0);  // no payload is copied for a remote frame

  ASSERT_EQ(reader.next(f), SocketCanReader::Status::frame);
  EXPECT_TRUE(f.error);
  EXPECT_EQ(f.id, 4U);
  EXPECT_EQ(f.data[1], 4);

  std::vector<std::string> warnings;
  auto previous = momentum::set_warning_sink([&](std::string_view m) { warnings.emplace_back(m); });
  close(pair.writer);
  pair.writer = -1;
  EXPECT_EQ(reader.next(f), SocketCanReader::Status::end);
  momentum::set_warning_sink(previous);
  ASSERT_EQ(warnings.size(), 1U);
  EXPECT_EQ(warnings[0], "pair: record of 10 bytes is neither a can_frame (16) nor a canfd_frame (72): skipped");
  EXPECT_EQ(reader.stats().frames, 4U);
  EXPECT_EQ(reader.stats().bad_records, 1U);
  EXPECT_EQ(reader.stats().untimed, 0U);
}

TEST(SocketCan, WithoutTimestampsUsesTheHostClock) {
  Pair pair;
  SocketCanReader reader(pair.reader, true, "pair");
  can_frame classic{};
  classic.can_id = 0x80;
  pair.send_raw(&classic, sizeof classic);
  const std::int64_t before = now_ns();
  Frame f;
  ASSERT_EQ(reader.next(f), SocketCanReader::Status::frame);
  EXPECT_GE(f.time_ns, before - 1000);
  EXPECT_EQ(reader.stats().untimed, 1U);
}

TEST(SocketCan, NoSocketCanIsAClearError) {
  // This machine's kernel has no SocketCAN; on one that has it, the interface does not exist.
  try {
    const int fd = open_can_socket("nosuchcan0");
    close(fd);
    FAIL() << "opened a CAN socket on a missing interface";
  } catch (const momentum::Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("nosuchcan0: ", 0), 0U) << e.what();
  }
}

}  // namespace
