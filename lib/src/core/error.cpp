#include "momentum/core/error.hpp"

#include <cstdio>
#include <utility>


namespace momentum {
namespace {
void default_sink(std::string_view message) {
  std::fprintf(stderr, "warning: %.*s\n", static_cast<int>(message.size()), message.data());
}
WarningSink& sink() {
  static WarningSink current = default_sink;
  return current;
}
void default_row_sink(std::string_view, std::string_view message) { warn(message); }
RowWarningSink& row_sink() {
  static RowWarningSink current = default_row_sink;
  return current;
}
}  // namespace

RowWarningSink set_row_warning_sink(RowWarningSink new_sink) {
  return std::exchange(row_sink(), new_sink ? std::move(new_sink) : RowWarningSink(default_row_sink));
}

void warn_row(std::string_view kind, std::string_view message) { row_sink()(kind, message); }

WarningSink set_warning_sink(WarningSink new_sink) {
  return std::exchange(sink(), new_sink ? std::move(new_sink) : WarningSink(default_sink));
}

void warn(std::string_view message) { sink()(message); }

std::string located(std::string_view file, std::uint64_t line, std::string_view message) {
  std::string out(file);
  if (line > 0) {
    out += ':';
    out += std::to_string(line);
  }
  out += ": ";
  out += message;
  return out;
}


}  // namespace momentum
