// Text and numbers as every stage shows and reads them.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "momentum/core/number.hpp"
#include "momentum/core/text.hpp"

using namespace momentum::core;

TEST(Printable, EscapesNulControlAndBytesThatAreNotUtf8) {
  using namespace std::string_literals;
  EXPECT_EQ(printable("abc 1.5"), "abc 1.5");
  EXPECT_EQ(printable("a\0b"s), "a\\x00b");
  EXPECT_EQ(printable("\x01\x7f\xff\xfe"), "\\x01\\x7F\\xFF\\xFE");
  EXPECT_EQ(printable("back\\slash"), "back\\\\slash");
  // Valid UTF-8 is shown as it is; overlong forms and surrogates are not valid.
  EXPECT_EQ(printable("\xC2\xB5m \xE2\x82\xAC \xF0\x9F\x98\x80"), "\xC2\xB5m \xE2\x82\xAC \xF0\x9F\x98\x80");
  EXPECT_EQ(printable("\xC0\xAF"), "\\xC0\\xAF");
  EXPECT_EQ(printable("\xED\xA0\x80"), "\\xED\\xA0\\x80");
  EXPECT_EQ(printable("\xE2\x82"), "\\xE2\\x82");  // cut short
  EXPECT_EQ(printable(std::string(50, 'x'), 40), std::string(40, 'x') + "...");
}

TEST(Text, TrimSplitAndTheByteOrderMark) {
  EXPECT_EQ(trim(" \t a b \r\n"), "a b");
  EXPECT_EQ(trim(""), "");
  EXPECT_EQ(split(""), std::vector<std::string>{});
  EXPECT_EQ(split("a,,b"), (std::vector<std::string>{"a", "", "b"}));
  EXPECT_EQ(split("a:b", ':'), (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(strip_byte_order_mark("\xEF\xBB\xBFt,q1"), "t,q1");
  EXPECT_EQ(strip_byte_order_mark("t,q1"), "t,q1");
  EXPECT_EQ(strip_byte_order_mark("\xEF\xBB"), "\xEF\xBB");
}

TEST(Number, ExactIsTheShortestRoundTrip) {
  for (double x : {0.1, 1.0 / 3.0, 1700000000.001, 1e-300, -2.5, 5e-324}) {
    const std::string text = exact(x);
    ASSERT_TRUE(parse_double(text));
    EXPECT_EQ(*parse_double(text), x) << text;
  }
  EXPECT_EQ(exact(1e9), "1e+09");
  EXPECT_EQ(exact(1700000000.001), "1700000000.001");
  EXPECT_EQ(exact(std::numeric_limits<double>::quiet_NaN()), "nan");
  EXPECT_EQ(exact(-std::numeric_limits<double>::infinity()), "-inf");
  EXPECT_FALSE(parse_double("1.5x"));
  EXPECT_FALSE(parse_double(""));
  EXPECT_EQ(*parse_double(" +2 "), 2.0);
  EXPECT_TRUE(std::isinf(*parse_double("1e999")));
}
