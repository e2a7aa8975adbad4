#pragma once
// Numbers as text, the one way every stage writes and reads them: the shortest text that
// reads back to exactly the same double (streams, exact times in messages), six significant
// digits for people (reports, messages), and a parser that accepts what the writer writes.

#include <cstddef>
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

// Parses a whole field as a double (std::from_chars, plus "inf", "-inf", "nan", "-nan" and a
// leading '+'; blanks around it are allowed); nullopt if the field is empty or not entirely a
// number. Magnitudes beyond the range of double give +-inf or +-0, as strtod does.
std::optional<double> parse_double(std::string_view field);

}  // namespace momentum::core
