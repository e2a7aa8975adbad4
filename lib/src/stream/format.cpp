#include "momentum/stream/format.hpp"

#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>

#include "momentum/core/error.hpp"
#include "momentum/core/text.hpp"

namespace momentum::stream {

Encoding parse_encoding(std::string_view name) {
  if (name == "csv") return Encoding::csv;
  if (name == "bin" || name == "binary") return Encoding::binary;
  throw Error("unknown output format '" + std::string(name) + "' (expected csv or bin)");
}

std::string_view encoding_name(Encoding encoding) {
  return encoding == Encoding::csv ? "csv" : encoding == Encoding::binary ? "bin" : "mcap";
}

std::string csv_comment_lines(std::string_view text) {
  std::string out = "#";
  out.reserve(text.size() + 2);
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\r' || c == '\n') {
      if (c == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;  // CR LF: one break
      out += "\n#";
    } else {
      out += c;
    }
  }
  return out + "\n";
}

namespace {

// Why `name` cannot be a CSV column name, or nullptr when it can.
const char* csv_name_problem(std::string_view name) {
  if (name.empty()) return "is empty";
  for (char c : name) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte < 0x20 || byte == 0x7f) return "holds a control character, which a CSV header cannot";
  }
  return nullptr;
}

// True when `name` must be quoted to read back as itself: it holds a separator the reader
// detects or a quote, has blanks at either end, starts like a comment, or starts with the
// binary encodings' first byte 0x89 (a file that begins with it is read as binary or MCAP).
bool csv_name_needs_quotes(std::string_view name) {
  if (name.find_first_of(",;\t\" ") != std::string_view::npos) return true;
  return name.front() == '#' || static_cast<unsigned char>(name.front()) == 0x89;
}

}  // namespace

std::string csv_header_line(const std::vector<std::string>& columns) {
  std::string out;
  for (std::size_t i = 0; i < columns.size(); ++i) {
    const std::string& name = columns[i];
    if (const char* problem = csv_name_problem(name))
      throw Error("column " + std::to_string(i + 1) + " name '" + core::printable(name) + "' " + problem);
    if (i) out += ',';
    if (csv_name_needs_quotes(name)) {
      out += '"';
      for (char c : name) out += c == '"' ? std::string("\"\"") : std::string(1, c);
      out += '"';
    } else {
      out += name;
    }
  }
  return out + "\n";
}

}  // namespace momentum::stream
