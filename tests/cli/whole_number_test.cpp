// Whole-number options: decimal digits in a range, and nothing CLI11's base-0 strtoull would
// read otherwise (octal, hex, saturation, wrap-around).

#include <gtest/gtest.h>

#include <cstdint>
#include <string>

#include "momentum/cli/whole_number.hpp"

using momentum::cli::parse_whole_number;

TEST(WholeNumber, DecimalDigitsInTheRangeOnly) {
  std::uint64_t v = 0;
  EXPECT_TRUE(parse_whole_number("0", 0, 10, &v));
  EXPECT_EQ(v, 0u);
  EXPECT_TRUE(parse_whole_number("10", 0, 10, &v));
  EXPECT_EQ(v, 10u);
  EXPECT_TRUE(parse_whole_number("18446744073709551615", 0, UINT64_MAX, &v));
  EXPECT_EQ(v, UINT64_MAX);
  EXPECT_FALSE(parse_whole_number("11", 0, 10, &v));
  EXPECT_FALSE(parse_whole_number("9", 10, 20, &v));
  // 2^64: one more than fits; CLI11 alone saturated it (and 1e23) to 2^64 - 1.
  EXPECT_FALSE(parse_whole_number("18446744073709551616", 0, UINT64_MAX, &v));
  EXPECT_FALSE(parse_whole_number("99999999999999999999999", 0, UINT64_MAX, &v));
  // "010" was octal 8 and "0x10" hex 16 through CLI11; "-1" wrapped to 2^64 - 1.
  EXPECT_FALSE(parse_whole_number("010", 0, 100, &v));
  EXPECT_FALSE(parse_whole_number("0x10", 0, 100, &v));
  EXPECT_FALSE(parse_whole_number("-1", 0, UINT64_MAX, &v));
  EXPECT_FALSE(parse_whole_number("+1", 0, 10, &v));
  EXPECT_FALSE(parse_whole_number("1e3", 0, 10000, &v));
  EXPECT_FALSE(parse_whole_number("", 0, 10, &v));
  EXPECT_FALSE(parse_whole_number(" 1", 0, 10, &v));
}

TEST(WholeNumber, TheCheckSaysTheRange) {
  CLI::Validator check = momentum::cli::whole_number_in(10, 100000);
  std::string text = "5";
  EXPECT_EQ(check(text), "'5' is not a whole number from 10 to 100000");
  text = "2000";
  EXPECT_EQ(check(text), "");
  CLI::Validator unbounded = momentum::cli::whole_number_in(0, UINT64_MAX);
  text = "010";
  EXPECT_EQ(unbounded(text), "'010' is not a whole number >= 0");
}
