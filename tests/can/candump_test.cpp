// candump text: one case per format candump and python-can print, written here character by
// character as can-utils' lib.c (sprint_canframe, sprint_long_canframe) and candump.c build
// them, and malformed lines with their file:line reports.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "momentum/can/candump.hpp"
#include "momentum/core/error.hpp"

using namespace momentum::can;

namespace {

Frame parse_ok(const std::string& line, ParsedLine* out_info = nullptr) {
  Frame f;
  ParsedLine info;
  const LineKind kind = parse_candump_line(line, f, info);
  EXPECT_EQ(kind, LineKind::frame) << "'" << line << "': " << info.error;
  if (out_info != nullptr) *out_info = info;
  return f;
}

std::string parse_bad(const std::string& line) {
  Frame f;
  ParsedLine info;
  EXPECT_EQ(parse_candump_line(line, f, info), LineKind::bad) << "'" << line << "' was accepted";
  return info.error;
}

CandumpOptions options(bool strict, TimestampMode mode, std::string interface, std::string name) {
  CandumpOptions o;
  o.strict = strict;
  o.timestamps = mode;
  o.interface = std::move(interface);
  o.display_name = std::move(name);
  return o;
}

std::vector<int> bytes(const Frame& f) { return std::vector<int>(f.data, f.data + f.len); }

// Captures warnings for the life of the object.
struct Warnings {
  std::vector<std::string> messages;
  momentum::WarningSink previous;
  Warnings() {
    previous = momentum::set_warning_sink([this](std::string_view m) { messages.emplace_back(m); });
  }
  ~Warnings() { momentum::set_warning_sink(previous); }
};

TEST(CandumpLog, SixAndNineFractionDigits) {
  ParsedLine info;
  const std::string line = "(1436509052.249713) can0 123#11223344";
  Frame f = parse_ok(line, &info);
  EXPECT_EQ(info.time_kind, TimeKind::log);
  EXPECT_EQ(info.stamp_ns, 1436509052249713000LL);
  EXPECT_EQ(info.interface, "can0");
  EXPECT_EQ(f.id, 0x123U);
  EXPECT_FALSE(f.extended);
  EXPECT_EQ(bytes(f), (std::vector<int>{0x11, 0x22, 0x33, 0x44}));
  parse_ok("(1436509052.249713123) can0 123#11", &info);
  EXPECT_EQ(info.stamp_ns, 1436509052249713123LL);
}

TEST(CandumpLog, PaddedInterfaceNamesAndPythonCanTimes) {
  ParsedLine info;
  // candump any pads names to the longest one: "%*s".
  const std::string padded = "(1436509052.249713)  can0 123#11";
  parse_ok(padded, &info);
  EXPECT_EQ(info.interface, "can0");
  parse_ok("(0.5) vcan0 123#11", &info);
  EXPECT_EQ(info.stamp_ns, 500000000);
  const std::string python = "(12) 0 123#";
  parse_ok(python, &info);
  EXPECT_EQ(info.stamp_ns, 12000000000LL);
  EXPECT_EQ(info.interface, "0");
}

TEST(CandumpLog, DirectionSuffix) {
  EXPECT_EQ(parse_ok("(1.000000) can0 123#11 R").direction, Direction::rx);
  EXPECT_EQ(parse_ok("(1.000000) can0 123#11 T").direction, Direction::tx);
  EXPECT_EQ(parse_ok("(1.000000) can0 123#11").direction, Direction::unknown);
}

TEST(CandumpLog, ExtendedIdsAndErrorFrames) {
  Frame f = parse_ok("(1.0) can0 12345678#DEADBEEF");
  EXPECT_TRUE(f.extended);
  EXPECT_EQ(f.id, 0x12345678U);
  EXPECT_EQ(f.key(), 0x92345678U);
  f = parse_ok("(1.0) can0 00000123#");
  EXPECT_TRUE(f.extended);  // 8 digits: extended even when the value is small
  EXPECT_EQ(f.len, 0);
  f = parse_ok("(1.0) can0 20000080#0000000000000000");
  EXPECT_TRUE(f.error);
  EXPECT_FALSE(f.extended);
  EXPECT_EQ(f.id, 0x80U);
  EXPECT_EQ(f.len, 8);
}

TEST(CandumpLog, RemoteFrames) {
  Frame f = parse_ok("(1.0) can0 123#R");
  EXPECT_TRUE(f.rtr);
  EXPECT_EQ(f.len, 0);
  f = parse_ok("(1.0) can0 123#R5");
  EXPECT_TRUE(f.rtr);
  EXPECT_EQ(f.len, 5);
  f = parse_ok("(1.0) can0 123#r8_E");
  EXPECT_EQ(f.len, 8);
  EXPECT_EQ(f.len8_dlc, 0xE);
}

TEST(CandumpLog, CanFdAnyFlagsNibble) {
  Frame f = parse_ok("(1.0) can0 123##1112233");
  EXPECT_TRUE(f.fd);
  EXPECT_EQ(f.fd_flags, 1);
  EXPECT_EQ(bytes(f), (std::vector<int>{0x11, 0x22, 0x33}));
  f = parse_ok("(1.0) can0 123##F");
  EXPECT_EQ(f.fd_flags, 0xF);
  EXPECT_EQ(f.len, 0);
  std::string line = "(1.0) can0 1ABCDEF0##5";
  for (int i = 0; i < 64; ++i) line += "A5";
  f = parse_ok(line);
  EXPECT_TRUE(f.extended);
  EXPECT_EQ(f.len, 64);
  EXPECT_EQ(f.data[63], 0xA5);
  EXPECT_EQ(f.data[64], 0);  // padding stays zero
  EXPECT_EQ(parse_bad(line + "A5"), "more than 64 data bytes");
}

TEST(CandumpLog, Len8DlcAndSeparators) {
  Frame f = parse_ok("(1.0) can0 123#1122334455667788_E");
  EXPECT_EQ(f.len, 8);
  EXPECT_EQ(f.len8_dlc, 0xE);
  f = parse_ok("(1.0) can0 123#11.22.33");
  EXPECT_EQ(bytes(f), (std::vector<int>{0x11, 0x22, 0x33}));
  f = parse_ok("(1.0) can0 123##0.11.22");  // sprint_canframe with sep: "##0." then bytes
  EXPECT_EQ(bytes(f), (std::vector<int>{0x11, 0x22}));
  EXPECT_EQ(parse_bad("(1.0) can0 123#112233_E"), "bad raw dlc after _");
  EXPECT_EQ(parse_bad("(1.0) can0 123#1122334455667788_3"), "bad raw dlc after _");
}

TEST(CandumpDefault, NoTimestamp) {
  ParsedLine info;
  // printf(" %s", "") + no timestamp + printf(" %s", "") + "%*s" devname + "  " + frame
  const std::string line = "  can0  123   [4]  11 22 33 44";
  Frame f = parse_ok(line, &info);
  EXPECT_EQ(info.time_kind, TimeKind::none);
  EXPECT_EQ(info.interface, "can0");
  EXPECT_EQ(f.id, 0x123U);
  EXPECT_EQ(bytes(f), (std::vector<int>{0x11, 0x22, 0x33, 0x44}));
}

TEST(CandumpDefault, AbsoluteAndDateTimestamps) {
  ParsedLine info;
  parse_ok(" (1436509052.249713)  can0  123   [4]  11 22 33 44", &info);
  EXPECT_EQ(info.time_kind, TimeKind::absolute);
  EXPECT_EQ(info.stamp_ns, 1436509052249713000LL);
  parse_ok(" (2015-07-10 06:17:32.249713)  can0  123   [4]  11 22 33 44", &info);
  EXPECT_EQ(info.time_kind, TimeKind::date);
  EXPECT_EQ(info.stamp_ns, 1436509052249713000LL);  // read as UTC
  parse_ok(" (000.001000)  can0  123   [1]  11", &info);
  EXPECT_EQ(info.time_kind, TimeKind::relative);
  EXPECT_EQ(info.stamp_ns, 1000000);
}

TEST(CandumpDefault, AsciiColumn) {
  // -a: j = 3*(8-len)+4 -> "%*s" of "'" then the printable bytes.
  Frame f = parse_ok("  can0  123   [4]  11 22 33 44               '.\"3D'");
  EXPECT_EQ(bytes(f), (std::vector<int>{0x11, 0x22, 0x33, 0x44}));
  f = parse_ok("  can0  123   [8]  41 20 27 42 43 44 45 46   'A 'BCDEF'");
  EXPECT_EQ(f.len, 8);
  EXPECT_EQ(f.data[7], 0x46);
  f = parse_ok("  can0  123   [0]                               ''");
  EXPECT_EQ(f.len, 0);
}

TEST(CandumpDefault, DirectionAndFdFlags) {
  Frame f = parse_ok(" (1436509052.249713)  can0  TX - -  123   [2]  11 22");
  EXPECT_EQ(f.direction, Direction::tx);
  f = parse_ok("  can0  RX B E  123  [12]  00 01 02 03 04 05 06 07 08 09 0A 0B");
  EXPECT_EQ(f.direction, Direction::rx);
  EXPECT_TRUE(f.fd);
  EXPECT_EQ(f.fd_flags, 3);
  EXPECT_EQ(f.len, 12);
  EXPECT_EQ(f.data[11], 0x0B);
}

TEST(CandumpDefault, ExtendedAndIndentedStandardIds) {
  Frame f = parse_ok("  can0  12345678   [1]  11");
  EXPECT_TRUE(f.extended);
  EXPECT_EQ(f.id, 0x12345678U);
  f = parse_ok("  can0       123   [1]  11");  // CANLIB_VIEW_INDENT_SFF after an EFF frame
  EXPECT_FALSE(f.extended);
  EXPECT_EQ(f.id, 0x123U);
}

TEST(CandumpDefault, FdLengthsAndRawDlc) {
  Frame f = parse_ok("  can0  123  [08]  11 22 33 44 55 66 77 88");
  EXPECT_TRUE(f.fd);
  EXPECT_EQ(f.len, 8);
  f = parse_ok("  can0  123   {F}  11 22 33 44 55 66 77 88");  // -8
  EXPECT_FALSE(f.fd);
  EXPECT_EQ(f.len, 8);
  EXPECT_EQ(f.len8_dlc, 0xF);
  f = parse_ok("  can0  123   {3}  11 22 33");
  EXPECT_EQ(f.len, 3);
  EXPECT_EQ(f.len8_dlc, 0);
}

TEST(CandumpDefault, RemoteRequestErrorFrameSwapBinary) {
  Frame f = parse_ok("  can0  123   [2]  remote request");
  EXPECT_TRUE(f.rtr);
  EXPECT_EQ(f.len, 2);
  f = parse_ok("  can0  20000004   [8]  00 04 00 00 00 00 00 00   ERRORFRAME");
  EXPECT_TRUE(f.error);
  EXPECT_EQ(f.id, 4U);
  EXPECT_EQ(f.data[1], 4);
  f = parse_ok("  can0  123   [4]  44`33`22`11");  // -S
  EXPECT_EQ(bytes(f), (std::vector<int>{0x11, 0x22, 0x33, 0x44}));
  f = parse_ok("  can0  123   [2]  00010001 00100010");  // -i
  EXPECT_EQ(bytes(f), (std::vector<int>{0x11, 0x22}));
  f = parse_ok("  can0  123   [2]  00100010`00010001");  // -i -S
  EXPECT_EQ(bytes(f), (std::vector<int>{0x11, 0x22}));
}

TEST(CandumpLines, DropcountErrorDetailsAndBlanks) {
  Frame f;
  ParsedLine info;
  EXPECT_EQ(parse_candump_line("DROPCOUNT: dropped 3 CAN frames on 'can0' socket (total drops 7)", f, info),
            LineKind::dropcount);
  EXPECT_EQ(info.dropped, 3U);
  EXPECT_EQ(parse_candump_line("DROPCOUNT: dropped 1 CAN frame on 'can0' socket (total drops 1)", f, info),
            LineKind::dropcount);
  EXPECT_EQ(info.dropped, 1U);
  EXPECT_EQ(parse_candump_line("\tcontroller-problem{rx-error-warning}", f, info), LineKind::detail);
  EXPECT_EQ(parse_candump_line("", f, info), LineKind::skip);
  EXPECT_EQ(parse_candump_line("   \r", f, info), LineKind::skip);
}

TEST(CandumpLines, MalformedLinesSayWhy) {
  EXPECT_EQ(parse_bad("(1.0) can0 12#11"), "expected ID#DATA");
  EXPECT_EQ(parse_bad("(1.0) can0 12G#11"), "bad can id");
  EXPECT_EQ(parse_bad("(1.0) can0 800#11"), "standard can id above 7FF");
  EXPECT_EQ(parse_bad("(1.0) can0 123#112"), "odd number of hex digits in data");
  EXPECT_EQ(parse_bad("(1.0) can0 123#11ZZ"), "bad hex digit in data");
  EXPECT_EQ(parse_bad("(1.0) can0 123#112233445566778899"), "more than 8 data bytes (can fd frames use ##)");
  EXPECT_EQ(parse_bad("(1.0) can0 123#R9"), "bad rtr length");
  EXPECT_EQ(parse_bad("(1.0) can0 123##"), "missing can fd flags after ##");
  EXPECT_EQ(parse_bad("(1.0) can0 123#11 X"), "unexpected text after the frame");
  EXPECT_EQ(parse_bad("(1.0 can0 123#11"), "bad timestamp");
  EXPECT_EQ(parse_bad("(abc) can0 123#11"), "bad timestamp");
  EXPECT_EQ(parse_bad("(1.0)"), "missing interface name");
  EXPECT_EQ(parse_bad("(1.0) can0"), "missing frame");
  EXPECT_EQ(parse_bad("garbage"), "not candump text");
  EXPECT_EQ(parse_bad("can0 123#11"), "log format line without a timestamp");
  EXPECT_EQ(parse_bad("(1.0) can0 12345#00:00:11223344#11"), "can xl frames are not supported");
  EXPECT_EQ(parse_bad("  can0  123   [4]  11 22 33"), "fewer data bytes than the length field says");
  EXPECT_EQ(parse_bad("  can0  123   [9]  11"), "bad length field");
  EXPECT_EQ(parse_bad("  can0  123   8  11"), "expected [LEN] after the can id");
  EXPECT_EQ(parse_bad("  can0  123   [2]  1 22"), "bad data byte");
  EXPECT_EQ(parse_bad(" (1.000000)  can0  QQ  [2]  11 22"), "bad can id");
  EXPECT_EQ(parse_bad("  can0  XX - -  123  [1]  11"), "not candump text");
  EXPECT_EQ(parse_bad("  can0  RX Q -  123  [1]  11"), "bad -x fields");
  EXPECT_EQ(parse_bad("DROPCOUNT: lost some"), "bad DROPCOUNT line");
  EXPECT_EQ(parse_bad(" (2015-13-10 06:17:32.249713)  can0  123   [1]  11"), "bad date in timestamp");
}

TEST(CandumpReader, CountsReportsAndSkipsBadLines) {
  Warnings warnings;
  auto reader = CandumpReader::from_text(
      "(1.000000) can0 123#11\n"
      "garbage\n"
      "DROPCOUNT: dropped 4 CAN frames on 'can0' socket (total drops 4)\n"
      "(2.000000) can0 123#22\r\n"
      "(3.000000) can0 123#3\n"
      "(4.000000) can1 123#44",
      options(false, TimestampMode::automatic, "", "x.log"));
  Frame f;
  ASSERT_TRUE(reader->next(f));
  EXPECT_EQ(f.time_ns, 1000000000);
  EXPECT_EQ(reader->where(), "x.log:1");
  ASSERT_TRUE(reader->next(f));
  EXPECT_EQ(f.data[0], 0x22);
  EXPECT_EQ(reader->line(), 4U);
  ASSERT_TRUE(reader->next(f));
  EXPECT_EQ(f.time_ns, 4000000000);
  EXPECT_EQ(reader->line(), 6U);
  EXPECT_FALSE(reader->next(f));
  EXPECT_EQ(reader->stats().lines, 6U);
  EXPECT_EQ(reader->stats().frames, 3U);
  EXPECT_EQ(reader->stats().bad_lines, 2U);
  EXPECT_EQ(reader->stats().lost_frames, 4U);
  ASSERT_EQ(warnings.messages.size(), 2U);
  EXPECT_EQ(warnings.messages[0], "x.log:2: not candump text");
  EXPECT_EQ(warnings.messages[1], "x.log:5: odd number of hex digits in data");
}

TEST(CandumpReader, TabLinesAreDetailsOnlyBelowAnErrorFrame) {
  // candump -e prints the decoded error below an error frame, indented by a tab; anywhere
  // else a tab-indented line is not candump text and must not vanish unreported.
  Warnings warnings;
  auto reader = CandumpReader::from_text(
      "(1.000000) can0 20000004#0004000000000000\n"
      "\tcontroller-problem{rx-error-warning}\n"
      "\terror-counter-tx-rx{{0}{97}}\n"
      "(2.000000) can0 123#11\n"
      "\tgarbage\n",
      options(false, TimestampMode::automatic, "", "e.log"));
  Frame f;
  ASSERT_TRUE(reader->next(f));
  EXPECT_TRUE(f.error);
  ASSERT_TRUE(reader->next(f));
  EXPECT_EQ(f.data[0], 0x11);
  EXPECT_FALSE(reader->next(f));
  EXPECT_EQ(reader->stats().bad_lines, 1U);
  ASSERT_EQ(warnings.messages.size(), 1U);
  EXPECT_EQ(warnings.messages[0], "e.log:5: tab-indented line not below an error frame (only candump -e details are)");
}

TEST(CandumpReader, StrictStopsAtFirstBadLine) {
  auto reader = CandumpReader::from_text("(1.0) can0 123#11\nnonsense here\n(2.0) can0 123#11\n",
                                         options(true, TimestampMode::automatic, "", "s.log"));
  Frame f;
  ASSERT_TRUE(reader->next(f));
  try {
    reader->next(f);
    FAIL() << "no error in strict mode";
  } catch (const momentum::Error& e) {
    EXPECT_STREQ(e.what(), "s.log:2: not candump text");
  }
}

TEST(CandumpReader, InterfaceFilter) {
  auto reader = CandumpReader::from_text("(1.0) can0 123#11\n(2.0) can1 123#22\n(3.0) can0 123#33\n",
                                         options(false, TimestampMode::automatic, "can1", ""));
  Frame f;
  ASSERT_TRUE(reader->next(f));
  EXPECT_EQ(f.data[0], 0x22);
  EXPECT_FALSE(reader->next(f));
  EXPECT_EQ(reader->stats().filtered, 2U);
}

std::vector<std::int64_t> times(const std::string& text, TimestampMode mode = TimestampMode::automatic,
                                TimestampMode* decided = nullptr) {
  auto reader = CandumpReader::from_text(text, options(false, mode, "", ""));
  std::vector<std::int64_t> out;
  Frame f;
  while (reader->next(f)) out.push_back(f.time_ns / 1000);
  if (decided != nullptr) *decided = reader->timestamp_mode();
  return out;
}

TEST(CandumpReader, DeltaTimestampsBecomeRunningTime) {
  // candump -t d: gaps between frames, jittering.
  const std::string text =
      " (000.000000)  can0  080   [0] \n"
      " (000.000150)  can0  181   [2]  11 22\n"
      " (000.000140)  can0  182   [2]  11 22\n"
      " (000.000710)  can0  080   [0] \n";
  TimestampMode decided;
  EXPECT_EQ(times(text, TimestampMode::automatic, &decided), (std::vector<std::int64_t>{0, 150, 290, 1000}));
  EXPECT_EQ(decided, TimestampMode::delta);
}

TEST(CandumpReader, ConstantDeltasAreDeltas) {
  std::string text;
  for (int i = 0; i < 5; ++i) text += std::string(" (000.") + (i == 0 ? "000000" : "001000") + ")  can0  080   [0]\n";
  EXPECT_EQ(times(text), (std::vector<std::int64_t>{0, 1000, 2000, 3000, 4000}));
}

TEST(CandumpReader, ZeroBasedTimestampsStayAsTheyAre) {
  std::string text;
  for (int i = 0; i < 40; ++i) {
    char line[64];
    std::snprintf(line, sizeof line, " (%03d.%06d)  can0  080   [0]\n", i / 1000, (i % 1000) * 1000 + (i % 3) * 7);
    text += line;
  }
  TimestampMode decided;
  const auto t = times(text, TimestampMode::automatic, &decided);
  EXPECT_EQ(decided, TimestampMode::zero);
  ASSERT_EQ(t.size(), 40U);
  for (int i = 0; i < 40; ++i) EXPECT_EQ(t[static_cast<std::size_t>(i)], i * 1000 + (i % 3) * 7);
}

TEST(CandumpReader, ForcedModes) {
  const std::string text = " (000.000000)  can0  080   [0]\n (000.002000)  can0  080   [0]\n (000.003000)  can0  080   [0]\n";
  EXPECT_EQ(times(text, TimestampMode::delta), (std::vector<std::int64_t>{0, 2000, 5000}));
  EXPECT_EQ(times(text, TimestampMode::zero), (std::vector<std::int64_t>{0, 2000, 3000}));
}

TEST(CandumpReader, LinesWithoutTimestampHaveNoTime) {
  auto reader = CandumpReader::from_text("  can0  123   [1]  11\n");
  Frame f;
  ASSERT_TRUE(reader->next(f));
  EXPECT_FALSE(f.has_time);
}

TEST(CandumpWriter, LogLinesParseBack) {
  Frame f;
  clear(f);
  f.time_ns = 1436509052249713000LL;
  f.id = 0x123;
  f.len = 3;
  f.data[0] = 0x11;
  f.data[1] = 0xAB;
  f.data[2] = 0x00;
  char buf[kMaxLogLine];
  EXPECT_EQ(std::string(buf, format_log_line(f, "can0", buf)), "(1436509052.249713) can0 123#11AB00\n");
  f.time_ns = 1500000001;
  f.fd = true;
  f.fd_flags = 5;
  f.extended = true;
  f.id = 0x1ABCDEF;
  EXPECT_EQ(std::string(buf, format_log_line(f, "can0", buf)), "(0000000001.500000001) can0 01ABCDEF##511AB00\n");
  Frame back;
  ParsedLine info;
  std::string line(buf, format_log_line(f, "can0", buf) - 1);
  ASSERT_EQ(parse_candump_line(line, back, info), LineKind::frame);
  EXPECT_EQ(info.stamp_ns, f.time_ns);
  EXPECT_EQ(back.key(), f.key());
  EXPECT_TRUE(back.fd);
  EXPECT_EQ(back.fd_flags, 5);
  EXPECT_EQ(bytes(back), bytes(f));
  clear(f);
  f.id = 0x7FF;
  f.rtr = true;
  f.len = 8;
  f.len8_dlc = 0xC;
  f.direction = Direction::tx;
  EXPECT_EQ(std::string(buf, format_log_line(f, "vcan0", buf)), "(0000000000.000000) vcan0 7FF#R8_C T\n");
}

}  // namespace
