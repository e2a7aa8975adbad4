#pragma once
// Whole-number options with a range. CLI11 converts integers with strtoull/strtoll in base 0,
// so "010" is 8 (octal), "0x10" is 16, "99999999999999999999" saturates to 2^64 - 1 and "-1"
// wraps to 2^64 - 1 for an unsigned option, all without an error. Options that count (rows,
// cycles, points, pixels) go through this check instead: decimal digits only, and a range.

#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

namespace momentum::cli {

// A CLI11 check: the text is decimal digits only (no sign, no leading zero except "0") and its
// value lies in [min, max]; otherwise "'<text>' is not a whole number from <min> to <max>"
// (">= <min>" when max is 2^64 - 1).
CLI::Validator whole_number_in(std::uint64_t min, std::uint64_t max);

// The value of `text` when it is decimal digits only (no sign, no leading zero except "0") and
// in [min, max]; false otherwise, without overflow for any length of text.
bool parse_whole_number(const std::string& text, std::uint64_t min, std::uint64_t max, std::uint64_t* value);

}  // namespace momentum::cli
