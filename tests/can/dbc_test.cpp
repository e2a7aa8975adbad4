// DBC parsing: the statements that matter for decoding, Motorola start-bit numbering checked
// against bytes worked out by hand, and errors that name the line.

#include <gtest/gtest.h>

#include <string>

#include "momentum/can/codec.hpp"
#include "momentum/can/dbc.hpp"
#include "momentum/core/error.hpp"

using namespace momentum::can;

namespace {

const char* kSmall = R"dbc(VERSION "1.2"

NS_ :
	CM_
	BA_DEF_
	SG_MUL_VAL_

BS_:

BU_: Drive Host

BO_ 385 Joint1_TPDO: 8 Drive
 SG_ Position : 0|32@1- (0.0001,0) [-3.2|3.2] "rad" Host
 SG_ Velocity : 32|16@1- (0.001,0) [-10|10] "rad/s" Host,Other
 SG_ Current : 48|16@1- (0.001,-0.5) [-20|20] "A"  Host

BO_ 2147484033 Big: 8 Drive
 SG_ Word : 55|16@0+ (1,0) [0|65535] "" Host
 SG_ Nibble : 19|4@0+ (1,0) [0|15] "" Host
 SG_ Across : 5|10@0- (1,0) [0|0] "" Host

BO_ 1600 Fd: 16 Drive
 SG_ Tail : 120|8@1+ (1,0) [0|0] "" Host

CM_ "a database comment";
CM_ BO_ 385 "first line
second line; with a semicolon";
CM_ SG_ 385 Position "actual position
(0x6064)";
BA_DEF_ BO_  "VFrameFormat" ENUM  "StandardCAN","ExtendedCAN","StandardCAN_FD","ExtendedCAN_FD";
BA_DEF_DEF_  "VFrameFormat" "StandardCAN";
BA_ "VFrameFormat" BO_ 1600 2;
VAL_ 385 Current 0 "zero" -1 "minus one" ;
VAL_TABLE_ Unused 1 "one" ;
)dbc";

TEST(Dbc, MessagesSignalsAndAttributes) {
  const Database db = Database::parse(kSmall, "small.dbc");
  EXPECT_EQ(db.version(), "1.2");
  ASSERT_EQ(db.messages().size(), 3U);
  const Message* m = db.find(385);
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->name, "Joint1_TPDO");
  EXPECT_EQ(m->length, 8U);
  EXPECT_EQ(m->sender, "Drive");
  EXPECT_FALSE(m->is_fd);
  EXPECT_EQ(m->comment, "first line\nsecond line; with a semicolon");
  ASSERT_EQ(m->signals.size(), 3U);
  const Signal& pos = m->signals[static_cast<std::size_t>(m->find("Position"))];
  EXPECT_EQ(pos.comment, "actual position\n(0x6064)");
  EXPECT_TRUE(pos.is_signed);
  EXPECT_DOUBLE_EQ(pos.factor, 0.0001);
  EXPECT_FALSE(pos.integer_scaling);
  EXPECT_DOUBLE_EQ(pos.minimum, -3.2);
  EXPECT_DOUBLE_EQ(pos.maximum, 3.2);
  EXPECT_EQ(pos.unit, "rad");
  EXPECT_EQ(pos.line, 13U);
  const Signal& vel = m->signals[static_cast<std::size_t>(m->find("Velocity"))];
  EXPECT_EQ(vel.receivers, (std::vector<std::string>{"Host", "Other"}));
  const Signal& cur = m->signals[static_cast<std::size_t>(m->find("Current"))];
  ASSERT_EQ(cur.choices.size(), 2U);
  EXPECT_EQ(cur.choices[1].first, -1);
  EXPECT_EQ(cur.choices[1].second, "minus one");
  EXPECT_DOUBLE_EQ(cur.offset, -0.5);

  const Message* big = db.find(0x181 | kExtendedFlag);
  ASSERT_NE(big, nullptr);
  EXPECT_EQ(big->name, "Big");
  EXPECT_EQ(db.find(0x181 | kExtendedFlag), db.find_name("Big"));
  const Message* fd = db.find(1600);
  ASSERT_NE(fd, nullptr);
  EXPECT_TRUE(fd->is_fd);
  EXPECT_EQ(db.find(0x7FF), nullptr);
  EXPECT_EQ(db.find(0x1234 | kExtendedFlag), nullptr);
}

TEST(Dbc, IntelAndMotorolaBitsByHand) {
  const Database db = Database::parse(kSmall, "small.dbc");
  Frame f;
  clear(f);
  f.len = 8;
  const std::uint8_t payload[8] = {0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC, 0xDE, 0xF0};
  std::memcpy(f.data, payload, 8);
  const Message& big = *db.find_name("Big");
  // Motorola 55|16: MSB is bit 7 of byte 6, the 16 bits are bytes 6 and 7 in order.
  EXPECT_EQ(extract_bits(big.signals[static_cast<std::size_t>(big.find("Word"))], f.data), 0xDEF0U);
  // Motorola 19|4: MSB bit 3 of byte 2 (0x56 = 0101 0110): the low nibble 0x6.
  EXPECT_EQ(extract_bits(big.signals[static_cast<std::size_t>(big.find("Nibble"))], f.data), 0x6U);
  // Motorola 5|10: bits 5..0 of byte 0 (01 0010 -> 010010) then bits 7..4 of byte 1 (0011):
  // 0100100011 = 0x123, signed 10 bits -> 291.
  const Signal& across = big.signals[static_cast<std::size_t>(big.find("Across"))];
  EXPECT_EQ(extract_bits(across, f.data), 0x123U);
  EXPECT_EQ(raw_signed(across, 0x323), -221);  // 1100100011 as 10-bit two's complement
  const Message& tpdo = *db.find(385);
  // Intel 0|32: little-endian bytes 0..3 = 0x78563412, signed, times 0.0001.
  const Signal& pos = tpdo.signals[static_cast<std::size_t>(tpdo.find("Position"))];
  EXPECT_EQ(extract_bits(pos, f.data), 0x78563412U);
  EXPECT_DOUBLE_EQ(physical_value(pos, 0x78563412U), 2018915346 * 0.0001);
  // Intel 48|16 = bytes 6,7 little-endian: 0xF0DE, signed -3874, * 0.001 - 0.5.
  const Signal& cur = tpdo.signals[static_cast<std::size_t>(tpdo.find("Current"))];
  EXPECT_DOUBLE_EQ(physical_value(cur, extract_bits(cur, f.data)), -3874 * 0.001 + -0.5);
}

TEST(Dbc, CantoolsSignalOrder) {
  const Database db = Database::parse(kSmall, "small.dbc");
  const Message& big = *db.find_name("Big");
  // By the stream position of the MSB: Across (5 -> 2), Nibble (19 -> 20), Word (55 -> 48),
  // not by start bit as written (5, 19, 55 would agree; 7|16 before 5|10 would not).
  ASSERT_EQ(big.signals.size(), 3U);
  EXPECT_EQ(big.signals[0].name, "Across");
  EXPECT_EQ(big.signals[1].name, "Nibble");
  EXPECT_EQ(big.signals[2].name, "Word");
}

TEST(Dbc, Multiplexing) {
  const char* text = R"(
BO_ 100 Mux: 8 X
 SG_ Sel M : 0|8@1+ (1,0) [0|0] "" X
 SG_ A m1 : 8|8@1+ (1,0) [0|0] "" X
 SG_ B m2M : 8|8@1+ (1,0) [0|0] "" X
 SG_ C m7 : 16|8@1+ (1,0) [0|0] "" X
 SG_ D m3 : 24|8@1+ (1,0) [0|0] "" X

SG_MUL_VAL_ 100 C B 5-9, 12-12;
SG_MUL_VAL_ 100 D Sel 3-4;
)";
  const Database db = Database::parse(text, "mux.dbc");
  const Message& m = *db.find(100);
  auto names = [&](std::vector<std::uint8_t> payload) {
    Frame f;
    clear(f);
    f.len = 8;
    std::memcpy(f.data, payload.data(), payload.size());
    SignalValue v[8];
    const std::size_t n = decode(m, f, v);
    std::string out;
    for (std::size_t k = 0; k < n; ++k) out += m.signals[v[k].index].name;
    return out;
  };
  EXPECT_EQ(names({1, 0, 0, 0}), "SelA");
  EXPECT_EQ(names({2, 0, 0, 0}), "SelB");
  EXPECT_EQ(names({2, 7, 0, 0}), "SelBC");
  EXPECT_EQ(names({2, 12, 0, 0}), "SelBC");
  EXPECT_EQ(names({2, 10, 0, 0}), "SelB");
  EXPECT_EQ(names({1, 7, 0, 0}), "SelA");  // C needs B present
  EXPECT_EQ(names({4, 0, 0, 0}), "SelD");
  EXPECT_EQ(names({0, 0, 0, 0}), "Sel");
}

TEST(Dbc, FloatsAndSignedSixtyFourBits) {
  const char* text = R"(
BO_ 1 F: 16 X
 SG_ Single : 0|32@1- (1,0) [0|0] "" X
 SG_ Double : 64|64@1- (1,0) [0|0] "" X
 SG_ Int64 : 32|32@1- (2,-1) [0|0] "" X
SIG_VALTYPE_ 1 Single : 1;
SIG_VALTYPE_ 1 Double : 2;
)";
  const Database db = Database::parse(text, "f.dbc");
  const Message& m = *db.find(1);
  EXPECT_TRUE(m.is_fd);  // longer than 8 bytes
  const Signal& s = m.signals[static_cast<std::size_t>(m.find("Single"))];
  const Signal& d = m.signals[static_cast<std::size_t>(m.find("Double"))];
  EXPECT_EQ(s.value_type, ValueType::float32);
  EXPECT_EQ(d.value_type, ValueType::float64);
  Frame f;
  clear(f);
  f.len = 16;
  const float single = -1.25f;
  const double dbl = 6.02214076e23;
  std::memcpy(f.data, &single, 4);
  std::memcpy(f.data + 8, &dbl, 8);
  EXPECT_EQ(physical_value(s, extract_bits(s, f.data)), -1.25);
  EXPECT_EQ(physical_value(d, extract_bits(d, f.data)), dbl);
  const Signal& i = m.signals[static_cast<std::size_t>(m.find("Int64"))];
  EXPECT_TRUE(i.integer_scaling);
  char buf[48];
  EXPECT_EQ(std::string(buf, format_physical(i, 0x80000000U, buf)), "-4294967297");  // -2^31*2-1
}

void expect_error(const std::string& text, const std::string& message) {
  try {
    Database::parse(text, "bad.dbc");
    FAIL() << "accepted: " << text;
  } catch (const momentum::Error& e) {
    EXPECT_EQ(std::string(e.what()), message);
  }
}

TEST(Dbc, ErrorsNameTheLine) {
  expect_error("BO_ 1 M: 8 X\n SG_ S : 0|65@1+ (1,0) [0|0] \"\" X\n", "bad.dbc:2: signal S has length 65 (1 to 64 bits)");
  expect_error("BO_ 1 M: 8 X\n SG_ S : 60|8@1+ (1,0) [0|0] \"\" X\n",
               "bad.dbc:2: signal S (start bit 60, 8 bits, Intel) does not fit in the 8 bytes of message M");
  expect_error("BO_ 1 M: 2 X\n SG_ S : 3|13@0+ (1,0) [0|0] \"\" X\n",
               "bad.dbc:2: signal S (start bit 3, 13 bits, Motorola) does not fit in the 2 bytes of message M");
  expect_error("BO_ 1 M: 8 X\n SG_ S : 0|8@2+ (1,0) [0|0] \"\" X\n",
               "bad.dbc:2: expected byte order 0 (Motorola) or 1 (Intel) after '@'");
  expect_error("BO_ 1 M: 8 X\n SG_ S : 0|8@1+ (1,0 [0|0] \"\" X\n", "bad.dbc:2: expected ')'");
  expect_error("\n\nBO_ 1 M: 8 X\n SG_ S : 0|16@1+ (1,0) [0|0] \"\" X\nSIG_VALTYPE_ 1 S : 1;\n",
               "bad.dbc:4: signal S is a float (32 bits) but has 16 bits");
  expect_error("BO_ 1 M: 8 X\nSIG_VALTYPE_ 2 S : 1;\n", "bad.dbc:2: unknown message id 2");
  expect_error("BO_ 1 M: 8 X\nBO_ 1 N: 8 X\n", "bad.dbc:2: message id 1 defined twice");
  expect_error("BO_ 1 M: 8 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n SG_ S : 8|8@1+ (1,0) [0|0] \"\" X\n",
               "bad.dbc:3: signal S defined twice in message M");
  expect_error("BO_ 1 M: 8 X\n SG_ S m1 : 0|8@1+ (1,0) [0|0] \"\" X\n",
               "bad.dbc:2: signal S is multiplexed but message M has no multiplexer (M)");
  expect_error("BO_ 1 M: 8 X\n SG_ S q1 : 0|8@1+ (1,0) [0|0] \"\" X\n", "bad.dbc:2: bad multiplexer indicator 'q1' for signal S");
  expect_error(" SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n", "bad.dbc:1: SG_ outside a BO_ message");
  expect_error("CM_ BO_ 1 \"never\nclosed;\n", "bad.dbc:1: unterminated string");
  expect_error("BO_ 2048 M: 8 X\n", "bad.dbc:1: message id 2048 is neither an 11-bit nor a 29-bit id (bit 31 marks 29-bit ids)");
  expect_error("BO_ 1 M: 8 X\n\n\n%%%\n", "bad.dbc:4: unexpected character '%'");
  expect_error("BO_ 1 M: 8 X\nhello world;\n", "bad.dbc:2: unknown statement 'hello'");
  expect_error("BO_ 1 M: 8 X\nEV_ never ends\n", "bad.dbc:2: missing ';' after EV_");
  expect_error("BO_ 1 M: 8 X\n SG_ S : 0|8@1+ (0,0) [0|0] \"\" X\n", "bad.dbc:2: signal S has a zero or non-finite factor");
  // Found by the fuzzer: a raw value beyond int64 was converted with undefined behaviour.
  expect_error("BO_ 1 M: 8 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\nVAL_ 1 S 4.2e44 \"huge\" ;\n",
               "bad.dbc:3: value description for a raw value that is not a 64-bit integer");
  expect_error("BO_ 1 M: 8 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\nVAL_ 1 S 1.5 \"half\" ;\n",
               "bad.dbc:3: value description for a raw value that is not a 64-bit integer");
}

// Two signals that can be in one frame and share a payload bit decode garbage for at least one
// of them: refused at the line of the later one. Signals that one multiplexer selects with
// different values share bits legitimately.
TEST(Dbc, OverlappingSignalsAreRefusedUnlessMultiplexedApart) {
  // Intel 0|16 is bytes 0-1; Intel 12|8 is bits 4-7 of byte 1 and 0-3 of byte 2: first shared
  // bit is byte 1 bit 4.
  expect_error("BO_ 1 M: 8 X\n SG_ A : 0|16@1+ (1,0) [0|0] \"\" X\n SG_ B : 12|8@1+ (1,0) [0|0] \"\" X\n",
               "bad.dbc:3: signal B overlaps signal A (line 2) of message M at byte 1 bit 4 (both can be in one frame)");
  // Motorola 7|8 is all of byte 0; Intel 7|1 is its top bit.
  expect_error("BO_ 1 M: 8 X\n SG_ A : 7|8@0+ (1,0) [0|0] \"\" X\n SG_ B : 7|1@1+ (1,0) [0|0] \"\" X\n",
               "bad.dbc:3: signal B overlaps signal A (line 2) of message M at byte 0 bit 7 (both can be in one frame)");
  // Motorola 15|16 is bytes 1-2, Motorola 23|4 the high nibble of byte 2.
  expect_error("BO_ 1 M: 8 X\n SG_ A : 15|16@0+ (1,0) [0|0] \"\" X\n SG_ B : 23|4@0+ (1,0) [0|0] \"\" X\n",
               "bad.dbc:3: signal B overlaps signal A (line 2) of message M at byte 2 bit 4 (both can be in one frame)");
  // A multiplexed signal over its own multiplexer is in every frame that selects it.
  expect_error("BO_ 1 M: 8 X\n SG_ S M : 0|8@1+ (1,0) [0|0] \"\" X\n SG_ A m1 : 4|8@1+ (1,0) [0|0] \"\" X\n",
               "bad.dbc:3: signal A overlaps signal S (line 2) of message M at byte 0 bit 4 (both can be in one frame)");
  // One multiplexer value, two signals on the same bits.
  expect_error("BO_ 1 M: 8 X\n SG_ S M : 0|8@1+ (1,0) [0|0] \"\" X\n SG_ A m1 : 8|8@1+ (1,0) [0|0] \"\" X\n"
               " SG_ B m1 : 8|8@1+ (1,0) [0|0] \"\" X\n",
               "bad.dbc:4: signal B overlaps signal A (line 3) of message M at byte 1 bit 0 (both can be in one frame)");
  // An always-present signal over a multiplexed one.
  expect_error("BO_ 1 M: 8 X\n SG_ S M : 0|8@1+ (1,0) [0|0] \"\" X\n SG_ A m1 : 8|8@1+ (1,0) [0|0] \"\" X\n"
               " SG_ C : 15|1@1+ (1,0) [0|0] \"\" X\n",
               "bad.dbc:4: signal C overlaps signal A (line 3) of message M at byte 1 bit 7 (both can be in one frame)");
  // Extended multiplexing: ranges 1-3 and 3-5 of one switch meet at 3.
  expect_error("BO_ 1 M: 8 X\n SG_ S M : 0|8@1+ (1,0) [0|0] \"\" X\n SG_ A m1 : 8|8@1+ (1,0) [0|0] \"\" X\n"
               " SG_ B m4 : 8|8@1+ (1,0) [0|0] \"\" X\nSG_MUL_VAL_ 1 A S 1-3;\nSG_MUL_VAL_ 1 B S 3-5;\n",
               "bad.dbc:4: signal B overlaps signal A (line 3) of message M at byte 1 bit 0 (both can be in one frame)");

  // Accepted: different values of one multiplexer (plain and extended, disjoint ranges), and
  // signals selected by two branches of a nested multiplexer.
  EXPECT_NO_THROW(Database::parse("BO_ 1 M: 8 X\n SG_ S M : 0|8@1+ (1,0) [0|0] \"\" X\n"
                                  " SG_ A m1 : 8|8@1+ (1,0) [0|0] \"\" X\n SG_ B m2 : 8|16@1+ (1,0) [0|0] \"\" X\n",
                                  "ok.dbc"));
  EXPECT_NO_THROW(Database::parse("BO_ 1 M: 8 X\n SG_ S M : 0|8@1+ (1,0) [0|0] \"\" X\n"
                                  " SG_ A m1 : 8|8@1+ (1,0) [0|0] \"\" X\n SG_ B m4 : 8|8@1+ (1,0) [0|0] \"\" X\n"
                                  "SG_MUL_VAL_ 1 A S 1-3;\nSG_MUL_VAL_ 1 B S 4-5;\n",
                                  "ok.dbc"));
  EXPECT_NO_THROW(Database::parse("BO_ 1 M: 8 X\n SG_ S M : 0|8@1+ (1,0) [0|0] \"\" X\n"
                                  " SG_ T m1M : 8|8@1+ (1,0) [0|0] \"\" X\n SG_ U m2 : 8|8@1+ (1,0) [0|0] \"\" X\n"
                                  " SG_ A m5 : 16|8@1+ (1,0) [0|0] \"\" X\n SG_ B m3 : 16|8@1+ (1,0) [0|0] \"\" X\n"
                                  "SG_MUL_VAL_ 1 T S 1-1;\nSG_MUL_VAL_ 1 U S 2-2;\n"
                                  "SG_MUL_VAL_ 1 A T 5-5;\nSG_MUL_VAL_ 1 B S 3-3;\n",
                                  "ok.dbc"));
}

TEST(Dbc, LoadNamesTheFile) {
  try {
    Database::load("/nonexistent/x.dbc");
    FAIL();
  } catch (const momentum::Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("/nonexistent/x.dbc: cannot open: ", 0), 0U) << e.what();
  }
}

}  // namespace
