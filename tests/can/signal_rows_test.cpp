// mo-can2csv --long rows, frame times and --sync ids, against values worked out by hand.

#include <gtest/gtest.h>

#include <unistd.h>

#include <fstream>
#include <sstream>
#include <string>

#include "momentum/can/dbc.hpp"
#include "momentum/can/signal_rows.hpp"
#include "momentum/core/error.hpp"

using namespace momentum::can;

namespace {

std::string time_of(std::int64_t ns, bool has_time = true) {
  Frame f;
  clear(f);
  f.time_ns = ns;
  f.has_time = has_time;
  char out[32];
  return std::string(out, format_frame_time(f, out));
}

}  // namespace

TEST(SignalRows, FrameTimeKeepsMicrosecondsOrNanoseconds) {
  EXPECT_EQ(time_of(1700000000001000000), "1700000000.001000");
  EXPECT_EQ(time_of(1500), "0.000001500");
  EXPECT_EQ(time_of(-2500000000), "-2.500000");
  EXPECT_EQ(time_of(0, false), "nan");
}

TEST(SignalRows, CanIdsAsCandumpWritesThem) {
  EXPECT_EQ(parse_can_id("080"), 0x080u);
  EXPECT_EQ(parse_can_id("0x80"), 0x080u);
  EXPECT_EQ(parse_can_id("7ff"), 0x7FFu);
  EXPECT_EQ(parse_can_id("800"), 0x800u | kExtendedFlag);       // above 11 bits
  EXPECT_EQ(parse_can_id("00000080"), 0x080u | kExtendedFlag);  // 8 digits: extended
  EXPECT_EQ(parse_can_id("1FFFFFFF"), 0x1FFFFFFFu | kExtendedFlag);
  for (const char* bad : {"", "0x", "12G", "1 2", "123456789", "FFFFFFFF"})
    EXPECT_THROW(parse_can_id(bad), momentum::Error) << bad;
}

TEST(SignalRows, OneRowPerSignalOfKnownFrames) {
  // Position: bytes 0-1 little-endian, scale 0.5, offset 1 -> raw 0x0102 = 258 -> 130.
  // Flag: bit 16 -> 1.
  const Database db = Database::parse(
      "BO_ 385 Drive1: 3 D\n SG_ Position : 0|16@1+ (0.5,1) [0|0] \"\" X\n SG_ Flag : 16|1@1+ (1,0) [0|0] \"\" X\n");
  char path[] = "/tmp/momentum-signal-rows-XXXXXX";
  const int fd = ::mkstemp(path);
  ASSERT_GE(fd, 0);
  ::close(fd);
  {
    SignalRowWriter w(db, path);
    Frame f;
    clear(f);
    f.id = 385;
    f.len = 3;
    f.data[0] = 0x02;
    f.data[1] = 0x01;
    f.data[2] = 0x01;
    f.has_time = true;
    f.time_ns = 1000000;
    w.write(f);
    f.id = 0x123;  // no such message
    w.write(f);
    f.id = 385;
    f.len = 1;  // too short for both signals: no row
    f.data[1] = f.data[2] = 0;
    w.write(f);
    EXPECT_EQ(w.counts().decoded, 2u);
    EXPECT_EQ(w.counts().unknown_ids, 1u);
    EXPECT_EQ(w.counts().short_frames, 1u);
  }
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  ::unlink(path);
  EXPECT_EQ(text.str(),
            "t,can_id,message,signal,raw,value\n"
            "0.001000,181,Drive1,Position,258,130\n"
            "0.001000,181,Drive1,Flag,1,1\n");
}
