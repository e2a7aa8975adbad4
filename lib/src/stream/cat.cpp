#include "momentum/stream/cat.hpp"

#include <cinttypes>
#include <cstdio>

#include "momentum/stream/columns.hpp"
#include "momentum/stream/error.hpp"
#include "momentum/stream/format.hpp"

namespace momentum::stream {

std::string format_stats(const StreamStats& stats) {
  std::string text;
  char line[512];
  auto put = [&](const char* format, auto... values) {
    std::snprintf(line, sizeof line, format, values...);
    text += line;
  };
  auto s = stats.summary();
  put("rows        %" PRIu64 "\n", s.rows);
  put("columns     %zu\n", s.columns);
  if (s.has_time) {
    put("time        %.9g .. %.9g s (span %.9g s)\n", s.t_first, s.t_last, s.t_last - s.t_first);
    put("dt          min %.6g  median %.6g  max %.6g s\n", s.dt_min, s.dt_median, s.dt_max);
    auto anomaly = [&](const char* label, const StreamStats::Anomaly& a) {
      put("%-11s %" PRIu64, label, a.count);
      for (std::size_t i = 0; i < a.first.size(); ++i) put("%s%s", i ? ", " : "  at ", a.first[i].c_str());
      if (a.count > a.first.size()) text += ", ...";
      text += '\n';
    };
    anomaly("gaps", s.gaps);
    put("irregular   %" PRIu64 "  (steps more than 10%% off the median, not gaps)\n", s.irregular);
    anomaly("backwards", s.backwards);
    anomaly("same-time", s.repeated_time);
    anomaly("duplicates", s.duplicates);
    anomaly("frozen", s.frozen);
  } else {
    text += "time        no column 't'\n";
  }
  text += "nan        ";
  bool any = false;
  for (std::size_t i = 0; i < s.nan_per_column.size(); ++i)
    if (s.nan_per_column[i]) put(" %s=%" PRIu64, stats.columns()[i].c_str(), s.nan_per_column[i]), any = true;
  text += any ? "\n" : " none\n";
  return text;
}

std::vector<double> parse_scales(const std::vector<std::string>& specs, const std::vector<std::string>& columns) {
  std::vector<double> factor(columns.size(), 1.0);
  for (const auto& spec : specs) {
    auto eq = spec.rfind('=');
    if (eq == std::string::npos) throw Error("--scale: expected LIST=FACTOR, got '" + spec + "'");
    auto value = parse_double(spec.substr(eq + 1));
    if (!value) throw Error("--scale: '" + spec.substr(eq + 1) + "' is not a number");
    for (auto index : column_indices(columns, expand_column_list(spec.substr(0, eq)), "--scale"))
      factor[index] *= *value;
  }
  return factor;
}


}  // namespace momentum::stream
