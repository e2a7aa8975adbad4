#include "momentum/stream/columns.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <unordered_set>

#include "momentum/core/error.hpp"
#include "momentum/core/text.hpp"

namespace momentum::stream {

std::vector<std::string> expand_column_list(std::string_view list) {
  std::vector<std::string> out;
  std::vector<std::string> items = core::split(list);
  if (items.empty()) items.emplace_back();  // "": one empty item, refused below
  for (const std::string& text : items) {
    const std::string_view item = text;
    if (item.empty()) throw Error("empty item in column list '" + std::string(list) + "'");
    // "name<a>-<b>": both ends numbers, the name before <a> not ending in a digit.
    std::size_t dash = item.rfind('-');
    bool ranged = false;
    if (dash != std::string_view::npos && dash + 1 < item.size()) {
      std::string_view last = item.substr(dash + 1);
      std::size_t digits = dash;
      while (digits > 0 && std::isdigit(static_cast<unsigned char>(item[digits - 1]))) --digits;
      std::string_view first = item.substr(digits, dash - digits);
      int a = 0, b = 0;
      bool ok_a = !first.empty() && std::from_chars(first.data(), first.data() + first.size(), a).ptr == first.data() + first.size();
      bool ok_b = std::all_of(last.begin(), last.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }) &&
                  std::from_chars(last.data(), last.data() + last.size(), b).ptr == last.data() + last.size();
      if (ok_a && ok_b && digits > 0) {
        if (b < a) throw Error("backwards range '" + std::string(item) + "' in column list");
        // Checked before expanding: "q1-20000000" would otherwise take a gigabyte of names.
        if (static_cast<std::size_t>(b - a) >= kMaxListedColumns - out.size())
          throw Error("range '" + std::string(item) + "' in column list is too long (a list names at most " +
                      std::to_string(kMaxListedColumns) + " columns)");
        std::string name(item.substr(0, digits));
        for (int j = a; j <= b; ++j) out.push_back(name + std::to_string(j));
        ranged = true;
      }
    }
    if (!ranged) {
      if (out.size() >= kMaxListedColumns)
        throw Error("column list names more than " + std::to_string(kMaxListedColumns) + " columns");
      out.emplace_back(item);
    }
  }
  return out;
}

std::optional<std::string> first_duplicate(const std::vector<std::string>& names) {
  std::unordered_set<std::string_view> seen;
  for (const std::string& name : names)
    if (!seen.insert(name).second) return name;
  return std::nullopt;
}

std::string missing_column_message(const std::vector<std::string>& columns, std::string_view name,
                                   const std::string& where) {
  std::string text = where + ": missing column '" + std::string(name) + "'";
  // A header read as one column: its separator is none that the reader detects.
  if (columns.size() == 1 && columns.front() != name)
    text += " (the header is one column, '" + core::printable(columns.front()) +
            "': columns are separated by commas, semicolons, tabs or blanks)";
  else if (const std::string zero = zero_based_joint_message(columns); !zero.empty())
    text += " (" + zero + ")";
  return text;
}

std::vector<std::size_t> column_indices(const std::vector<std::string>& columns,
                                        const std::vector<std::string>& wanted, const std::string& where) {
  std::vector<std::size_t> out;
  out.reserve(wanted.size());
  for (const auto& name : wanted) {
    auto it = std::find(columns.begin(), columns.end(), name);
    if (it == columns.end()) throw Error(missing_column_message(columns, name, where));
    out.push_back(static_cast<std::size_t>(it - columns.begin()));
  }
  return out;
}

namespace {

bool has_column(const std::vector<std::string>& columns, const std::string& name) {
  return std::find(columns.begin(), columns.end(), name) != columns.end();
}

// The joint-column kinds a stream may number from 0, and how many from 0 each has.
std::vector<std::pair<std::string, std::size_t>> zero_based_runs(const std::vector<std::string>& columns) {
  std::vector<std::pair<std::string, std::size_t>> runs;
  for (const char* prefix : {"q", "dq", "ddq", "i", "tau_m"}) {
    std::size_t n = 0;
    while (n < kMaxListedColumns && has_column(columns, prefix + std::to_string(n))) ++n;
    if (n > 0) runs.emplace_back(prefix, n);
  }
  return runs;
}

}  // namespace

std::string zero_based_joint_rename(const std::vector<std::string>& columns) {
  std::string text;
  for (const auto& [prefix, n] : zero_based_runs(columns)) {
    text += text.empty() ? "" : ",";
    text += n == 1 ? prefix + "0=" + prefix + "1"
                   : prefix + "0.." + std::to_string(n - 1) + "=" + prefix + "1.." + std::to_string(n);
  }
  return text;
}

std::string zero_based_joint_message(const std::vector<std::string>& columns) {
  const auto runs = zero_based_runs(columns);
  if (runs.empty()) return {};
  std::string seen;
  for (const auto& [prefix, n] : runs)
    seen += (seen.empty() ? "" : ", ") + prefix + "0" + (n > 1 ? ".." + std::to_string(n - 1) : "");
  return "the stream's joint columns are numbered from 0 (" + seen +
         ") where the suite numbers joints from 1: read it with --rename " + zero_based_joint_rename(columns);
}

std::size_t count_joint_columns(const std::vector<std::string>& columns, std::string_view prefix) {
  std::size_t n = 0;
  while (std::find(columns.begin(), columns.end(), std::string(prefix) + std::to_string(n + 1)) != columns.end()) ++n;
  return n;
}

std::vector<std::string> joint_columns(std::string_view prefix, std::size_t n) {
  std::vector<std::string> out;
  for (std::size_t j = 1; j <= n; ++j) out.push_back(std::string(prefix) + std::to_string(j));
  return out;
}

}  // namespace momentum::stream
