#include "momentum/stream/format.hpp"

#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>

#include "momentum/stream/error.hpp"

namespace momentum::stream {

Encoding parse_encoding(std::string_view name) {
  if (name == "csv") return Encoding::csv;
  if (name == "bin" || name == "binary") return Encoding::binary;
  throw Error("unknown output format '" + std::string(name) + "' (expected csv or bin)");
}

std::string_view encoding_name(Encoding encoding) {
  return encoding == Encoding::csv ? "csv" : "bin";
}



}  // namespace momentum::stream
