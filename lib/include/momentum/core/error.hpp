#pragma once
// Errors and warnings shared by every stage of the library (the core stage, below stream).
//
// The library never prints. A runtime failure is thrown as momentum::Error, whose message is
// already in the form a user reads (`file:line: message`, lowercase, no final period); the
// command-line layer prefixes `mo-TOOL: error: `. Recoverable problems (a skipped row, an
// observer restart) go to the warning sink, which tools route to stderr.

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

namespace momentum {

// A runtime failure: bad input, unreadable file, a fit that cannot run. Exit status 1 in tools.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The failure of an options check, `bool IsValid(std::string* why) const`: stores `reason` in
// *why (why may be null) and returns false, so that a check reads
// `if (bad) return invalid(why, "what is wrong");`.
inline bool invalid(std::string* why, std::string reason) {
  if (why) *why = std::move(reason);
  return false;
}

// Receives one warning message (no tool prefix, no trailing newline).
using WarningSink = std::function<void(std::string_view message)>;

// Installs the process-wide warning sink; returns the previous one. The default sink writes
// `warning: message` to stderr. Not thread-safe against concurrent warn() calls.
WarningSink set_warning_sink(WarningSink sink);

// Reports a recoverable problem through the current sink.
void warn(std::string_view message);

// Receives one skipped bad row (or line, or record): its kind, a short fixed phrase such as
// "bad number" or "time out of order", and the whole message (`file:line: ...: skipped`).
using RowWarningSink = std::function<void(std::string_view kind, std::string_view message)>;

// Installs the process-wide sink for skipped rows; returns the previous one. The default sink
// passes the message to warn(). Tools install one that counts the rows by kind and shows only
// the first few of each kind (cli::Tool).
RowWarningSink set_row_warning_sink(RowWarningSink sink);

// Reports a bad row that was skipped. Every stage reports its skipped rows here, so that the
// tool's summary and exit status see all of them.
void warn_row(std::string_view kind, std::string_view message);

// `where: message` where `where` is `file:line` (or `file` when line is 0).
std::string located(std::string_view file, std::uint64_t line, std::string_view message);


}  // namespace momentum
