#include "momentum/stream/rename.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iterator>
#include <numbers>
#include <optional>
#include <unordered_map>
#include <utility>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/core/text.hpp"
#include "momentum/stream/columns.hpp"

namespace momentum::stream {
namespace {

using core::printable;
using core::trim;

// The built-in presets: the text of share/momentum/presets/NAME.preset, which is installed for
// users to copy and adapt. Kept here as well so that every build (CMake's, the fuzz script's,
// a Python extension's) has them without a generated file; tests/stream/rename_test.cpp holds
// the two copies equal.
struct BuiltinPreset {
  const char* name;
  const char* text;
};
constexpr BuiltinPreset kBuiltinPresets[] = {
    {"ur-rtde", R"momentum_preset(# Universal Robots RTDE recordings, as UR's RTDE client writes them (examples/record.py of
# UniversalRobots/RTDE_Python_Client_Library: one header line, fields separated by spaces, a
# vector output VAR written as VAR_0 .. VAR_5 for joints 1..6 from the base). See
# momentum-recipes(7). One mapping per line, as in --rename; "optional" maps only when the
# recording has those columns. Columns not named here are passed through as they are.

# Seconds since the controller started.
timestamp=t
# Joint positions (rad) and velocities (rad/s) measured by the joint encoders.
actual_q_0..5=q1..6
actual_qd_0..5=dq1..6
# Motor currents (A): the observer's torque is the profile's k_i times these.
actual_current_0..5=i1..6
# The controller's own torque signals (Nm), kept beside the currents under names no tool takes
# for the motor torque tau_m: the measured currents converted to joint torque by the controller
# (PolyScope 5.23 and 10.11 on), and the torque its model asks for along the target motion.
optional actual_current_as_torque_0..5=tau_ctrl1..6
optional target_moment_0..5=tau_target1..6
)momentum_preset"},
};

bool all_digits(std::string_view text) {
  return !text.empty() && std::all_of(text.begin(), text.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); });
}

// "name<first>..<last>" or "name<first>-<last>": a run of numbered names.
struct Range {
  std::string prefix;
  long first = 0, last = 0;
};

std::optional<long> whole(std::string_view digits) {
  long value = 0;
  auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (ec != std::errc() || end != digits.data() + digits.size()) return std::nullopt;
  return value;
}

std::optional<Range> parse_range(std::string_view text, const std::string& context) {
  std::size_t split = text.find("..");
  std::size_t after = split + 2;
  if (split == std::string_view::npos) {
    split = text.rfind('-');
    after = split + 1;
    if (split == std::string_view::npos) return std::nullopt;
  }
  const std::string_view left = text.substr(0, split), right = text.substr(after);
  std::size_t digits = left.size();
  while (digits > 0 && std::isdigit(static_cast<unsigned char>(left[digits - 1]))) --digits;
  if (!all_digits(right) || digits == left.size() || digits == 0) return std::nullopt;
  const auto first = whole(left.substr(digits)), last = whole(right);
  if (!first || !last) throw Error(context + ": range '" + std::string(text) + "' is too long");
  if (*last < *first) throw Error(context + ": backwards range '" + std::string(text) + "'");
  if (static_cast<unsigned long>(*last - *first) >= kMaxListedColumns)
    throw Error(context + ": range '" + std::string(text) + "' is too long (at most " +
                std::to_string(kMaxListedColumns) + " columns)");
  return Range{std::string(left.substr(0, digits)), *first, *last};
}

// Units a column can be written in, and the factor to the suite's SI units.
std::optional<double> unit_factor(std::string_view unit) {
  if (unit == "deg") return std::numbers::pi / 180.0;  // deg -> rad, deg/s -> rad/s
  if (unit == "mA" || unit == "ms") return 1e-3;
  if (unit == "us") return 1e-6;
  if (unit == "ns") return 1e-9;
  return std::nullopt;
}

// Parses the modifiers after TO (":deg", "*0.001", "/1000"): their product.
double parse_modifiers(std::string_view text, const std::string& context) {
  double scale = 1.0;
  while (!text.empty()) {
    const char kind = text.front();
    text.remove_prefix(1);
    const std::size_t end = std::min(text.size(), text.find_first_of("*/:"));
    const std::string_view word = trim(text.substr(0, end));
    text.remove_prefix(end);
    if (kind == ':') {
      const auto factor = unit_factor(word);
      if (!factor)
        throw Error(context + ": unknown unit '" + printable(word) + "' (units: deg, mA, ms, us, ns; or *FACTOR)");
      scale *= *factor;
      continue;
    }
    const auto value = core::parse_double(word);
    if (!value || !std::isfinite(*value) || *value == 0)
      throw Error(context + ": '" + printable(word) + "' is not a finite non-zero factor");
    scale = kind == '*' ? scale * *value : scale / *value;
  }
  if (!std::isfinite(scale) || scale == 0) throw Error(context + ": the factors multiply to " + core::exact(scale));
  return scale;
}

}  // namespace

std::vector<ColumnRename> parse_renames(std::string_view text, std::string_view origin, std::size_t first_group) {
  std::vector<ColumnRename> out;
  std::vector<std::string> items = core::split(text);
  if (items.empty()) items.emplace_back();
  std::size_t group = first_group;
  for (const std::string& raw : items) {
    const std::string_view item = trim(raw);
    const std::string context = std::string(origin) + " '" + printable(item, 80) + "'";
    if (item.empty()) throw Error(std::string(origin) + ": empty item in '" + printable(text, 80) + "'");
    const std::size_t eq = item.find('=');
    if (eq == std::string_view::npos) throw Error(context + ": no '=' (write OLD=NEW)");
    const std::string_view from = trim(item.substr(0, eq));
    const std::string_view rhs = trim(item.substr(eq + 1));
    const std::size_t modifiers = std::min(rhs.size(), rhs.find_first_of("*/:"));
    const std::string_view to = trim(rhs.substr(0, modifiers));
    if (from.empty()) throw Error(context + ": no column name before '='");
    if (to.empty()) throw Error(context + ": no new name after '='");
    const double scale = parse_modifiers(rhs.substr(modifiers), context);
    if (to == "_" && scale != 1.0) throw Error(context + ": a dropped column takes no unit or factor");
    const auto from_range = parse_range(from, context);
    const auto to_range = to == "_" ? std::nullopt : parse_range(to, context);
    auto add = [&](std::string f, std::string t) {
      for (const auto& r : out)
        if (r.from == f) throw Error(context + ": column '" + printable(f) + "' is mapped twice");
      out.push_back({std::move(f), std::move(t), scale, false, context, group});
    };
    if (from_range) {
      const long count = from_range->last - from_range->first + 1;
      if (to_range && to_range->last - to_range->first + 1 != count)
        throw Error(context + ": the ranges differ in length (" + std::to_string(count) + " and " +
                    std::to_string(to_range->last - to_range->first + 1) + " columns)");
      if (!to_range && to != "_")
        throw Error(context + ": " + std::to_string(count) + " columns cannot all be named '" + printable(to) +
                    "' (write a range, e.g. q1..6, or _ to drop them)");
      for (long k = 0; k < count; ++k)
        add(from_range->prefix + std::to_string(from_range->first + k),
            to_range ? to_range->prefix + std::to_string(to_range->first + k) : std::string("_"));
    } else {
      if (to_range)
        throw Error(context + ": one column cannot become the range '" + printable(to) + "'");
      add(std::string(from), std::string(to));
    }
    ++group;
  }
  return out;
}

ColumnPreset parse_preset(std::string_view text, const std::string& name) {
  ColumnPreset preset{name, {}};
  std::size_t line_number = 0;
  std::size_t group = 0;
  text = core::strip_byte_order_mark(text);
  while (!text.empty()) {
    const std::size_t end = std::min(text.size(), text.find('\n'));
    std::string_view line = text.substr(0, end);
    text.remove_prefix(std::min(text.size(), end + 1));
    ++line_number;
    if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    line = trim(line);
    if (line.empty()) continue;
    bool optional = false;
    if (line.substr(0, 9) == "optional " || line.substr(0, 9) == "optional\t") {
      optional = true;
      line = trim(line.substr(9));
    }
    const std::string origin = "--preset " + name + " line " + std::to_string(line_number);
    for (ColumnRename& rename : parse_renames(line, origin, group)) {
      for (const auto& r : preset.renames)
        if (r.from == rename.from)
          throw Error(origin + ": column '" + printable(rename.from) + "' is mapped twice (also on " + r.origin + ")");
      rename.optional = optional;
      group = std::max(group, rename.group + 1);
      preset.renames.push_back(std::move(rename));
    }
  }
  if (preset.renames.empty()) throw Error("--preset " + name + ": no mapping in it");
  return preset;
}

std::vector<std::string> builtin_preset_names() {
  std::vector<std::string> names;
  for (const auto& preset : kBuiltinPresets) names.emplace_back(preset.name);
  return names;
}

ColumnPreset load_preset(const std::string& name_or_path) {
  for (const auto& preset : kBuiltinPresets)
    if (name_or_path == preset.name) return parse_preset(preset.text, preset.name);
  std::ifstream in(name_or_path, std::ios::binary);
  if (!in) {
    std::string names;
    for (const auto& name : builtin_preset_names()) names += (names.empty() ? "" : ", ") + name;
    throw Error("--preset: '" + printable(name_or_path) + "' is no built-in preset (" + names +
                ") and no preset file that can be opened");
  }
  // A preset is a few lines: a bound keeps a wrong path (a device, a log) from filling memory.
  constexpr std::size_t kMaxPresetBytes = std::size_t{1} << 20;
  std::string text(kMaxPresetBytes + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<std::size_t>(in.gcount()));
  if (text.size() > kMaxPresetBytes)
    throw Error("--preset " + printable(name_or_path) + ": larger than 1 MiB, not a preset file");
  return parse_preset(text, name_or_path);
}

std::vector<std::string> presets_matching(const std::vector<std::string>& header) {
  std::vector<std::string> out;
  for (const auto& builtin : kBuiltinPresets) {
    const ColumnPreset preset = parse_preset(builtin.text, builtin.name);
    const bool fits = std::all_of(preset.renames.begin(), preset.renames.end(), [&](const ColumnRename& r) {
      return r.optional || std::find(header.begin(), header.end(), r.from) != header.end();
    });
    if (fits) out.push_back(preset.name);
  }
  return out;
}

RenamedHeader apply_renames(const std::vector<std::string>& header, const std::vector<ColumnRename>& renames,
                            const std::string& where) {
  RenamedHeader out{header, std::vector<double>(header.size(), 1.0)};
  std::unordered_map<std::string_view, std::size_t> index;
  for (std::size_t i = 0; i < header.size(); ++i) index.emplace(header[i], i);
  std::vector<std::string> renamed_from(header.size());  // the origin that renamed each column
  // Optional mappings apply by item: all of its columns, or none.
  std::unordered_map<std::size_t, std::pair<std::size_t, std::size_t>> present;  // group -> (found, total)
  for (const auto& r : renames) {
    auto& count = present[r.group];
    ++count.second;
    if (index.count(r.from)) ++count.first;
  }
  for (const auto& r : renames) {
    const auto [found, total] = present[r.group];
    const auto it = index.find(r.from);
    if (it == index.end()) {
      if (r.optional && found == 0) continue;
      std::string text = where + ": " + r.origin + ": no column '" + printable(r.from) + "' in the header";
      if (r.optional)
        text += " (" + std::to_string(found) + " of the " + std::to_string(total) + " columns are there)";
      throw Error(text + "; its columns: " + compact_column_list(header));
    }
    out.names[it->second] = r.to;
    out.scales[it->second] = r.scale;
    renamed_from[it->second] = r.origin;
  }
  std::unordered_map<std::string_view, std::size_t> seen;
  for (std::size_t i = 0; i < out.names.size(); ++i) {
    if (out.names[i] == "_") continue;
    const auto [it, fresh] = seen.emplace(out.names[i], i);
    if (fresh) continue;
    const std::size_t first = it->second;
    const std::string& origin = !renamed_from[i].empty() ? renamed_from[i] : renamed_from[first];
    throw Error(where + ": " + origin + ": two columns would be named '" + printable(out.names[i]) + "' ('" +
                printable(header[first]) + "' and '" + printable(header[i]) + "' of the header)");
  }
  return out;
}

std::string compact_column_list(const std::vector<std::string>& columns, std::size_t max_chars) {
  // Splits a name into the text before its trailing number and the number (no leading zero).
  auto numbered = [](const std::string& name) -> std::optional<std::pair<std::string_view, long>> {
    std::size_t digits = name.size();
    while (digits > 0 && std::isdigit(static_cast<unsigned char>(name[digits - 1]))) --digits;
    if (digits == name.size() || digits == 0 || name.size() - digits > 9) return std::nullopt;
    if (name[digits] == '0' && digits + 1 != name.size()) return std::nullopt;
    return std::make_pair(std::string_view(name).substr(0, digits), *whole(std::string_view(name).substr(digits)));
  };
  std::string out;
  for (std::size_t i = 0; i < columns.size();) {
    std::string item = printable(columns[i]);
    std::size_t next = i + 1;
    if (const auto head = numbered(columns[i])) {
      long last = head->second;
      while (next < columns.size()) {
        const auto more = numbered(columns[next]);
        if (!more || more->first != head->first || more->second != last + 1) break;
        last = more->second;
        ++next;
      }
      if (next > i + 1) item += ".." + std::to_string(last);
    }
    const std::string piece = (out.empty() ? "" : ", ") + item;
    if (out.size() + piece.size() > max_chars) return out + ", ...";
    out += piece;
    i = next;
  }
  return out;
}

}  // namespace momentum::stream
