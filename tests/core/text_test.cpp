// Text and numbers as every stage shows and reads them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

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

TEST(Number, ShortAndSignificantAreWhatPrintfWrites) {
  EXPECT_EQ(short_number(0.1), "0.1");
  EXPECT_EQ(short_number(123456.7), "123457");
  EXPECT_EQ(short_number(1e-7), "1e-07");
  EXPECT_EQ(short_number(-0.0), "0");  // a message never shows -0
  EXPECT_EQ(short_number(std::numeric_limits<double>::infinity()), "inf");
  EXPECT_EQ(significant(1.0 / 3.0, 3), "0.333");
  EXPECT_EQ(significant(1700000000.123456789, 9), "1.7e+09");
  EXPECT_EQ(significant(170000.123456789, 9), "170000.123");
  EXPECT_EQ(significant(12.5, 9), "12.5");
  EXPECT_EQ(significant(-0.0, 6), "-0");  // as printf: reports that want "0" use short_number
  EXPECT_EQ(significant(1e6, 3), "1e+06");
}

TEST(Number, FixedDecimalsAsPrintfWritesThem) {
  EXPECT_EQ(fixed(12.345, 1), "12.3");
  EXPECT_EQ(fixed(2.0 / 3.0, 3), "0.667");
  EXPECT_EQ(fixed(12.0, 0), "12");
  EXPECT_EQ(fixed(-0.04, 1), "-0.0");  // as printf: the sign of a value rounded to zero stays
  EXPECT_EQ(fixed(1e20, 1), "100000000000000000000.0");
  EXPECT_EQ(fixed(std::numeric_limits<double>::infinity(), 2), "inf");
  EXPECT_EQ(signed_fixed(12.5, 1), "+12.5");
  EXPECT_EQ(signed_fixed(-0.25, 2), "-0.25");
  EXPECT_EQ(signed_fixed(0.0, 1), "+0.0");
  EXPECT_EQ(signed_fixed(std::numeric_limits<double>::infinity(), 1), "+inf");
}

TEST(Number, NanosecondsAsCandumpWritesThem) {
  char out[40];
  auto text = [&](std::int64_t ns, int digits) { return std::string(out, format_nanoseconds(ns, digits, out)); };
  // can-utils: "(%010lu.%06lu)" for whole microseconds; nine decimals only when needed.
  EXPECT_EQ(text(1700000000000100000, 10), "1700000000.000100");
  EXPECT_EQ(text(12000000, 10), "0000000000.012000");
  EXPECT_EQ(text(1, 0), "0.000000001");
  EXPECT_EQ(text(1500000001, 0), "1.500000001");
  EXPECT_EQ(text(-1500000000, 0), "-1.500000");
  EXPECT_EQ(text(std::numeric_limits<std::int64_t>::min(), 0), "-9223372036.854775808");
}

TEST(Text, WordsSplitAtBlanksWithoutAllocating) {
  Words words(" \t12.5 can0  123#11\t");
  EXPECT_EQ(words.next(), "12.5");
  const Words after_time = words;  // a cursor: a copy comes back to here
  EXPECT_EQ(words.next(), "can0");
  EXPECT_EQ(words.next(), "123#11");
  EXPECT_EQ(words.next(), "");
  EXPECT_EQ(words.next(), "");
  Words again = after_time;
  EXPECT_EQ(again.next(), "can0");
  EXPECT_EQ(again.rest(), "  123#11\t");
  EXPECT_EQ(Words("").next(), "");
  EXPECT_EQ(Words(" \t ").next(), "");
}

// all_finite against std::isfinite on every value: one value that is not finite, at any place
// of any of the three arrays, makes it false; the largest, smallest and subnormal finite values
// do not.
TEST(Number, AllFiniteIsEveryValueFinite) {
  using momentum::core::all_finite;
  const double kInf = std::numeric_limits<double>::infinity();
  const double kNan = std::numeric_limits<double>::quiet_NaN();
  const double kMax = std::numeric_limits<double>::max();
  double a[3] = {kMax, -kMax, 5e-324}, b[3] = {0.0, -0.0, 1e-310}, c[3] = {1.0, -2.5, 1e308};
  EXPECT_TRUE(all_finite(a, b, c, 3));
  EXPECT_TRUE(all_finite(a, b, c, 0));
  for (double bad : {kInf, -kInf, kNan, -kNan}) {
    for (double* array : {a, b, c}) {
      for (int k = 0; k < 3; ++k) {
        const double kept = array[k];
        array[k] = bad;
        EXPECT_FALSE(all_finite(a, b, c, 3)) << bad << " at " << k;
        EXPECT_EQ(all_finite(a, b, c, k), true) << "only the first " << k << " values are read";
        array[k] = kept;
      }
    }
  }
}
