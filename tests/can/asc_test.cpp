// Vector ASC logs read by CandumpReader: the same frames as a candump -L capture, frame for
// frame, in both number bases and both timestamp modes; FD, remote and error frames; events
// without a frame skipped; bad lines counted.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "momentum/can/asc.hpp"
#include "momentum/can/candump.hpp"
#include "momentum/core/error.hpp"

using namespace momentum::can;

namespace {

std::vector<Frame> read_all(const std::string& text, CandumpOptions options = {}) {
  auto reader = CandumpReader::from_text(text, options);
  std::vector<Frame> frames;
  Frame f;
  while (reader->next(f)) frames.push_back(f);
  return frames;
}

void expect_same(const std::vector<Frame>& a, const std::vector<Frame>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    EXPECT_EQ(a[k].time_ns, b[k].time_ns);
    EXPECT_EQ(a[k].has_time, b[k].has_time);
    EXPECT_EQ(a[k].key(), b[k].key());
    EXPECT_EQ(a[k].rtr, b[k].rtr);
    EXPECT_EQ(a[k].fd, b[k].fd);
    EXPECT_EQ(a[k].fd_flags, b[k].fd_flags);
    EXPECT_EQ(a[k].len, b[k].len);
    for (int i = 0; i < a[k].len; ++i) EXPECT_EQ(a[k].data[i], b[k].data[i]) << "byte " << i;
  }
}

// The same six frames: classic, extended, remote, FD with BRS, an empty SYNC.
const char* kCandump =
    "(0.000000) can0 080#\n"
    "(0.000120) can0 181#A08601003CF6FFFF\n"
    "(0.000180) can0 281#DC05\n"
    "(0.000240) can0 18FEF100#0102\n"
    "(0.000300) can0 282#R2\n"
    "(0.000360) can0 780##10000000000000000D2041FEF\n";

TEST(Asc, SameFramesAsCandump) {
  const std::string asc =
      "date Tue Nov 14 10:13:20.000 pm 2023\n"
      "base hex  timestamps absolute\n"
      "internal events logged\n"
      "// version 13.0.0\n"
      "Begin Triggerblock Tue Nov 14 10:13:20.000 pm 2023\n"
      "   0.000000 Start of measurement\n"
      "   0.000000 1  80              Rx   d 0  Length = 0 BitCount = 44 ID = 128\n"
      "   0.000120 1  181             Rx   d 8 A0 86 01 00 3C F6 FF FF  Length = 228000 BitCount = 117 ID = 385\n"
      "   0.000180 1  281             Rx   d 2 DC 05  Length = 0 BitCount = 0 ID = 641\n"
      "   0.000200 1  Statistic: D 3 R 0 XD 0 XR 0 E 0 O 0 B 0.45%\n"
      "   0.000240 1  18FEF100x       Tx   d 2 01 02\n"
      "   0.000300 1  282             Rx   r 2\n"
      "   0.000360 CANFD   1 Rx        780  Motors                           1 0 9 12 00 00 00 00 00 00 00 00 D2 04 1F EF  0 0 1000 0 0 0 0 0\n"
      "End TriggerBlock\n";
  expect_same(read_all(asc), read_all(kCandump));
  const auto frames = read_all(asc);
  ASSERT_EQ(frames.size(), 6u);
  EXPECT_TRUE(frames[3].extended);
  EXPECT_EQ(frames[3].direction, Direction::tx);
  EXPECT_TRUE(frames[4].rtr);
  EXPECT_EQ(frames[5].fd_flags, 1);  // BRS
}

TEST(Asc, DecimalBaseAndRelativeTimestamps) {
  // "base dec": ids and bytes in decimal; "timestamps relative": each time since the previous.
  const std::string asc =
      "date Tue Nov 14 10:13:20.000 pm 2023\n"
      "base dec  timestamps relative\n"
      "   0.000000 1  128             Rx   d 0\n"
      "   0.000120 1  385             Rx   d 8 160 134 1 0 60 246 255 255\n"
      "   0.000060 1  641             Rx   d 2 220 5\n"
      "   0.000060 1  419361024x      Rx   d 2 1 2\n"
      "   0.000060 1  642             Rx   r 2\n"
      "   0.000060 CANFD   1 Rx        1920 1 0 9 12 0 0 0 0 0 0 0 0 210 4 31 239\n";
  expect_same(read_all(asc), read_all(kCandump));
}

TEST(Asc, ChannelIsTheInterfaceAndErrorFramesCount) {
  const std::string asc =
      "date Tue Nov 14 10:13:20.000 pm 2023\n"
      "base hex  timestamps absolute\n"
      "   1.000000 1  181             Rx   d 1 01\n"
      "   1.000100 2  181             Rx   d 1 02\n"
      "   1.000200 1  ErrorFrame\n";
  CandumpOptions options;
  options.interface = "2";
  auto reader = CandumpReader::from_text(asc, options);
  Frame f;
  ASSERT_TRUE(reader->next(f));
  EXPECT_EQ(f.data[0], 2);
  EXPECT_EQ(f.time_ns, 1000100000);
  EXPECT_FALSE(reader->next(f));
  EXPECT_EQ(reader->stats().filtered, 2u);

  auto all = CandumpReader::from_text(asc);
  int frames = 0;
  while (all->next(f)) ++frames;
  EXPECT_EQ(frames, 3);
  EXPECT_EQ(all->stats().error_frames, 1u);
}

TEST(Asc, BadLinesAreCountedOrStopStrictReading) {
  const std::string asc =
      "date Tue Nov 14 10:13:20.000 pm 2023\n"
      "   0.1 1  181  Rx   d 4 01 02\n"        // fewer bytes than the DLC
      "   0.2 1  181  Rx   d 1 0G\n"           // not hex
      "garbage\n"
      "   0.3 1  181  Rx   d 1 07\n";
  momentum::WarningSink previous = momentum::set_warning_sink([](std::string_view) {});
  auto reader = CandumpReader::from_text(asc);
  Frame f;
  ASSERT_TRUE(reader->next(f));
  EXPECT_EQ(f.data[0], 7);
  EXPECT_EQ(reader->stats().bad_lines, 3u);
  momentum::set_warning_sink(previous);
  CandumpOptions strict;
  strict.strict = true;
  auto stops = CandumpReader::from_text(asc, strict);
  EXPECT_THROW(stops->next(f), momentum::Error);
}

TEST(Asc, OnlyAnAscFirstLineSwitchesFormat) {
  EXPECT_TRUE(is_asc_header("date Tue Nov 14 10:13:20.000 pm 2023"));
  EXPECT_TRUE(is_asc_header("base hex  timestamps absolute"));
  EXPECT_FALSE(is_asc_header("(0.1) can0 181#01"));
  // A candump capture that happens to hold the word "date" later stays candump.
  const auto frames = read_all("(0.000120) can0 181#A0\n# date of capture\n");
  EXPECT_EQ(frames.size(), 1u);
}

}  // namespace
