#include "momentum/core/number.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace momentum::core {

std::size_t format_double(double value, char* out) {
  if (std::isnan(value)) {
    // to_chars would write "-nan" for a negative NaN too; we keep the sign for a bit-exact
    // round trip of the sign bit, which is all text can carry of a NaN.
    if (std::signbit(value)) {
      std::memcpy(out, "-nan", 4);
      return 4;
    }
    std::memcpy(out, "nan", 3);
    return 3;
  }
  auto result = std::to_chars(out, out + 32, value);
  return static_cast<std::size_t>(result.ptr - out);
}

std::string exact(double value) {
  char buffer[40];
  return std::string(buffer, format_double(value, buffer));
}

std::string short_number(double value) { return significant(value == 0.0 ? 0.0 : value, 6); }

std::string significant(double value, int digits) {
  char text[40];
  std::snprintf(text, sizeof text, "%.*g", digits, value);
  return text;
}

std::string fixed(double value, int decimals) {
  char text[340];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  return text;
}

std::string signed_fixed(double value, int decimals) {
  char text[340];
  std::snprintf(text, sizeof text, "%+.*f", decimals, value);
  return text;
}

std::size_t format_nanoseconds(std::int64_t ns, int second_digits, char* out) {
  char* o = out;
  // The magnitude as unsigned, so that the most negative count has one too.
  std::uint64_t magnitude = static_cast<std::uint64_t>(ns);
  if (ns < 0) {
    *o++ = '-';
    magnitude = ~magnitude + 1;
  }
  std::uint64_t seconds = magnitude / 1000000000, fraction = magnitude % 1000000000;
  char digits[24];
  int n = 0;
  do {
    digits[n++] = static_cast<char>('0' + seconds % 10);
    seconds /= 10;
  } while (seconds > 0);
  for (int pad = n; pad < second_digits; ++pad) *o++ = '0';
  while (n > 0) *o++ = digits[--n];
  *o++ = '.';
  int decimals = 9;
  if (fraction % 1000 == 0) {
    fraction /= 1000;
    decimals = 6;
  }
  for (int i = decimals - 1; i >= 0; --i) {
    o[i] = static_cast<char>('0' + fraction % 10);
    fraction /= 10;
  }
  return static_cast<std::size_t>(o + decimals - out);
}

std::optional<double> parse_double(std::string_view field) {
  // Blanks around a field: spaces and tabs, and the CR of a CRLF line at its end. Not
  // core::trim, which takes a CR at the start too: "\r5" stays no number.
  while (!field.empty() && (field.front() == ' ' || field.front() == '\t')) field.remove_prefix(1);
  while (!field.empty() && (field.back() == ' ' || field.back() == '\t' || field.back() == '\r'))
    field.remove_suffix(1);
  if (field.empty()) return std::nullopt;
  if (field.front() == '+') {
    field.remove_prefix(1);
    if (field.empty() || field.front() == '-' || field.front() == '+') return std::nullopt;
  }
  double value = 0;
  auto result = std::from_chars(field.data(), field.data() + field.size(), value);
  if (result.ec == std::errc::result_out_of_range) {
    // from_chars reports overflow and underflow without a value; follow strtod: +-inf or +-0
    // for beyond-range magnitudes, so that no finite text is rejected as "not a number".
    std::string copy(field);
    return std::strtod(copy.c_str(), nullptr);
  }
  if (result.ec != std::errc() || result.ptr != field.data() + field.size()) return std::nullopt;
  return value;
}

}  // namespace momentum::core
