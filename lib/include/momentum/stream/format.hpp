#pragma once
// The encodings of a sample stream (see mo-log(5)): CSV text and the binary format, which the
// suite reads and writes, and ROS 2 bags in MCAP, which it reads only.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "momentum/core/number.hpp"

namespace momentum::stream {

enum class Encoding { csv, binary, mcap };

// "csv" or "bin" (the encodings a stream is written in); throws momentum::Error for anything
// else.
Encoding parse_encoding(std::string_view name);
std::string_view encoding_name(Encoding encoding);

// A comment as CSV comment lines: "#" + text + "\n", where every line break in the text (LF,
// CR or CR LF) starts a new "#" line. A comment from a binary stream, or from any caller, can
// then never become a data row or a header (mo-log(5)).
std::string csv_comment_lines(std::string_view text);

// The CSV header line of `columns`, with "\n". A name that holds a separator the reader detects
// (comma, semicolon, tab, space) or a double quote, or that starts with '#' or with byte 0x89
// (the first byte of the binary encodings, by which a reader tells them from CSV), is written
// double-quoted with "" for a quote, so that it reads back as itself. Throws momentum::Error
// for an empty name or one with a control character (a line break would end the header).
std::string csv_header_line(const std::vector<std::string>& columns);

// Binary format constants (mo-log(5)). The magic starts with a non-ASCII byte so that no CSV
// file can be mistaken for binary, and holds CR LF so that a text-mode copy is detected.
inline constexpr char kBinaryMagic[8] = {'\x89', 'M', 'O', 'L', 'O', 'G', '\r', '\n'};
inline constexpr std::uint32_t kBinaryVersion = 1;
// The first value of a row record with these bits marks a comment record instead of a row:
// a NaN with a payload that no arithmetic produces (text formatting and parsing give the
// canonical NaN), so data rows never collide with it.
inline constexpr std::uint64_t kCommentRecordBits = 0x7ff84d4f434d4e54ULL;  // "MOCMNT"

// Numbers as text are core's (momentum/core/number.hpp); the stream names stay for callers.
using core::format_double;
using core::parse_double;

}  // namespace momentum::stream
