#include "momentum/cli/whole_number.hpp"

#include <limits>

namespace momentum::cli {

bool parse_whole_number(const std::string& text, std::uint64_t min, std::uint64_t max, std::uint64_t* value) {
  if (text.empty() || (text.size() > 1 && text.front() == '0')) return false;
  std::uint64_t v = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return false;
    const auto digit = static_cast<std::uint64_t>(c - '0');
    if (v > (std::numeric_limits<std::uint64_t>::max() - digit) / 10) return false;  // beyond 64 bits
    v = v * 10 + digit;
  }
  if (v < min || v > max) return false;
  if (value) *value = v;
  return true;
}

CLI::Validator whole_number_in(std::uint64_t min, std::uint64_t max) {
  return CLI::Validator(
      [min, max](std::string& text) -> std::string {
        if (parse_whole_number(text, min, max, nullptr)) return std::string();
        if (max == std::numeric_limits<std::uint64_t>::max())  // any that fits: no upper bound to speak of
          return "'" + text + "' is not a whole number >= " + std::to_string(min);
        return "'" + text + "' is not a whole number from " + std::to_string(min) + " to " + std::to_string(max);
      },
      "");
}

}  // namespace momentum::cli
