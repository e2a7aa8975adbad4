#pragma once
// Numbers as text, the one way every stage writes and reads them: the shortest text that
// reads back to exactly the same double (streams, exact times in messages), six significant
// digits for people (reports, messages) or as many as a report's column asks for, times of
// integer nanoseconds with a decimal point (CAN captures), and a parser that accepts what the
// writer writes.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace momentum::core {

// Writes the shortest text that parses back to exactly `value` (std::to_chars), into `out`
// (at least 32 bytes); returns the number of characters. NaN is "nan" or "-nan", infinities
// "inf" and "-inf".
std::size_t format_double(double value, char* out);

// format_double as a string: "0.1", "1e+09", "1700000000.001", "nan".
std::string exact(double value);

// A number as messages and reports show it to people: 6 significant digits, as printf's %.6g
// ("0.1", "1e-07", "123457", "inf", "nan"), and -0 as "0".
std::string short_number(double value);

// `value` with `digits` (1 to 17) significant digits, exactly as printf's %.*g writes it
// ("0.333", "1e+06", "-0", "-nan"): for reports whose columns want more or fewer digits than
// short_number's six.
std::string significant(double value, int digits);

// `value` with `decimals` (0 to 17) digits after the decimal point, exactly as printf's %.*f
// writes it ("0.3", "12.000", "-0.0", "inf", "nan"): for columns of fixed precision (delays
// in ms, percentages). Magnitudes up to 1e300 fit; larger ones are cut short.
std::string fixed(double value, int decimals);

// fixed with a sign always, exactly as printf's %+.*f ("+12.5", "-0.3", "+0.0", "+inf"): for
// changes, where the direction is the news.
std::string signed_fixed(double value, int decimals);

// A time of `ns` nanoseconds as seconds with a decimal point, allocating nothing (a capture's
// every frame): 6 decimals when it is a whole number of microseconds (candump's "%010lu.%06lu"
// of can-utils lib.c), else 9; the seconds padded with zeros to at least `second_digits`
// digits (at most 20); a '-' first when negative. Writes into `out` (at least 32 bytes) and
// returns the number of characters: "1700000000.000100", "0.000000001", "-1.500000".
std::size_t format_nanoseconds(std::int64_t ns, int second_digits, char* out);

// Parses a whole field as a double (std::from_chars, plus "inf", "-inf", "nan", "-nan" and a
// leading '+'; blanks around it are allowed); nullopt if the field is empty or not entirely a
// number. Magnitudes beyond the range of double give +-inf or +-0, as strtod does.
std::optional<double> parse_double(std::string_view field);

// Whether the n values of each of a, b and c are all finite: one sample's q, dq and tau. Every
// row of a stream asks it twice (the signal check, the observer). x - x is 0 for a finite x and
// NaN otherwise, and a sum of them stays 0 only if every one is: no branch per value, about
// half the instructions of std::isfinite on each.
inline bool all_finite(const double* a, const double* b, const double* c, int n) {
  double zero = 0.0;
  for (int j = 0; j < n; ++j) zero += (a[j] - a[j]) + (b[j] - b[j]) + (c[j] - c[j]);
  return zero == 0.0;
}

}  // namespace momentum::core
