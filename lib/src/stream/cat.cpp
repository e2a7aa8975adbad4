#include "momentum/stream/cat.hpp"

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <nlohmann/json.hpp>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/stream/columns.hpp"
#include "momentum/stream/format.hpp"
#include "momentum/stream/rename.hpp"

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
  // A recording not yet in the suite's names (no column t): what its columns are, and the
  // built-in preset that reads it, if one does.
  if (s.time_column != "t") {
    text += "names       " + compact_column_list(stats.columns()) + "\n";
    for (const auto& preset : presets_matching(stats.columns()))
      text += "preset      " + preset + " (read it with --preset " + preset + ")\n";
  }
  if (s.has_time) {
    auto digits = [](double x, int n) { return core::significant(x, n); };
    text += "time        " + digits(s.t_first, 9) + " .. " + digits(s.t_last, 9) + " s (span " +
            digits(s.t_last - s.t_first, 9) + " s" +
            (s.time_column != "t" ? ", column '" + s.time_column + "'" : std::string()) + ")\n";
    text += "dt          min " + digits(s.dt_min, 6) + "  median " + digits(s.dt_median, 6) + "  max " +
            digits(s.dt_max, 6) + " s\n";
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
    text += "time        no column 't' (nor 'timestamp' or 'time')\n";
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


std::string format_stats_json(const StreamStats& stats, const std::vector<std::string>& sources) {
  const auto s = stats.summary();
  auto number = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  auto anomaly = [](const StreamStats::Anomaly& a) { return nlohmann::json{{"count", a.count}, {"first", a.first}}; };
  nlohmann::json nan = nlohmann::json::object();
  for (std::size_t i = 0; i < s.nan_per_column.size(); ++i) nan[stats.columns()[i]] = s.nan_per_column[i];
  nlohmann::json line = {{"sources", sources}, {"rows", s.rows}, {"columns", stats.columns()}, {"nan", nan}};
  const char* timed[] = {"t_first", "t_last", "dt_min",     "dt_median", "dt_max", "gaps",
                         "irregular", "backwards", "same_time", "duplicates", "frozen"};
  for (const char* key : timed) line[key] = nullptr;
  if (s.has_time) {
    line["t_first"] = number(s.t_first);
    line["t_last"] = number(s.t_last);
    line["dt_min"] = number(s.dt_min);
    line["dt_median"] = number(s.dt_median);
    line["dt_max"] = number(s.dt_max);
    line["gaps"] = anomaly(s.gaps);
    line["irregular"] = s.irregular;
    line["backwards"] = anomaly(s.backwards);
    line["same_time"] = anomaly(s.repeated_time);
    line["duplicates"] = anomaly(s.duplicates);
    line["frozen"] = anomaly(s.frozen);
  }
  return line.dump() + "\n";
}

namespace {

// True for a whole CSV field that is a number ("0.001", "-3", "1e-3", "nan"), as a header-less
// row's fields are and a column name never is.
bool looks_like_number(const std::string& field) {
  if (field.empty()) return false;
  char* end = nullptr;
  std::strtod(field.c_str(), &end);
  return end == field.c_str() + field.size();
}

}  // namespace

CatResult cat(const CatOptions& options, const OpenInput& open_input, const OpenOutput& open_output) {
  std::vector<std::string> inputs = options.inputs;
  if (inputs.empty()) inputs.push_back("-");
  ReaderOptions read_options;
  read_options.names = options.names;
  // Rows as written, unless asked to mend them by the suite's time policy (mo-log(5)).
  read_options.time_order = options.repair;

  // The selection is checked before any input is opened: a list too long to expand, or one
  // that names a column twice (a header with a duplicate name, which no reader accepts).
  std::vector<std::string> listed;
  if (!options.columns.empty()) {
    try {
      listed = expand_column_list(options.columns);
    } catch (const Error& e) {
      throw OptionError(std::string("--columns: ") + e.what());
    }
    if (auto twice = first_duplicate(listed))
      throw OptionError("--columns: column '" + *twice + "' is listed twice (a stream's column names differ)");
  }

  CatResult result;
  std::unique_ptr<Writer> out;
  std::unique_ptr<StreamStats> summary;
  std::vector<std::string> first_columns;
  std::vector<std::size_t> pick;
  std::vector<double> factor, row_out;
  std::optional<std::size_t> t_out;
  std::optional<double> t_origin;
  bool identity = false;
  Reader* current = nullptr;
  auto deliver = [&](const double* row) {
    if (summary) summary->add(row, current->where());
    else out->row(row);
  };

  for (const auto& path : inputs) {
    auto in = open_input(path, read_options);
    current = in.get();
    if (first_columns.empty()) {
      // A vendor export without a header would otherwise have its first row taken as names.
      if (read_options.names.empty() && !in->columns().empty() &&
          std::all_of(in->columns().begin(), in->columns().end(), looks_like_number))
        throw Error(in->name() + ": no header: the first line holds only numbers (" + in->columns().front() +
                    ", ...); name the columns with --names (see man mo-cat)");
      first_columns = in->columns();
      const std::vector<std::string> selected =
          options.columns.empty() ? in->columns() : listed;
      pick = column_indices(in->columns(), selected, in->name());
      try {
        factor = parse_scales(options.scales, selected);
      } catch (const Error& e) {
        throw OptionError(e.what());
      }
      row_out.resize(pick.size());
      identity = !options.zero_time && !options.repair && pick.size() == in->columns().size();
      for (std::size_t i = 0; i < pick.size(); ++i) identity = identity && pick[i] == i && factor[i] == 1.0;
      for (std::size_t i = 0; i < selected.size(); ++i)
        if (selected[i] == "t") t_out = i;
      if ((options.zero_time || options.repair) && !t_out)
        throw Error(in->name() + ": missing column 't' (needed by " + (options.repair ? "--repair" : "--zero-time") +
                    ")");
      if (options.stats != CatOptions::Stats::none) {
        summary = std::make_unique<StreamStats>(selected);
      } else {
        out = open_output(*in);
        out->header(selected);
      }
    } else if (in->columns() != first_columns) {
      throw Error(in->name() + ": columns differ from " + inputs.front() + "'s; cannot concatenate");
    }
    if (out) {
      Writer* raw = out.get();
      in->on_comment([raw](std::string_view c) { raw->comment(c); });
      if (raw->interactive()) in->before_read([raw] { raw->flush(); });
    }
    while (!options.head || result.rows < *options.head) {
      const double* row = in->next();
      if (!row) break;
      if (identity) {  // plain conversion: no copy on the hot path
        deliver(row);
        ++result.rows;
        continue;
      }
      for (std::size_t i = 0; i < pick.size(); ++i) row_out[i] = row[pick[i]];
      if (options.zero_time) {  // before scaling, so that controller ticks subtract exactly
        if (!t_origin) t_origin = row_out[*t_out];
        row_out[*t_out] -= *t_origin;
      }
      for (std::size_t i = 0; i < pick.size(); ++i) row_out[i] *= factor[i];
      deliver(row_out.data());
      ++result.rows;
    }
    if (const TimeOrder::Summary* time = in->time_summary()) {
      result.mended.kept += time->kept;
      result.mended.duplicates += time->duplicates;
      result.mended.not_finite += time->not_finite;
      result.mended.out_of_order += time->out_of_order;
      result.mended.clock_steps += time->clock_steps;
    }
  }
  const TimeOrder::Summary& m = result.mended;
  if (options.repair && (m.dropped() || m.clock_steps))
    warn("--repair kept " + std::to_string(m.kept) + " rows (" + std::to_string(m.clock_steps) +
         " clock steps), dropped " + std::to_string(m.duplicates) + " duplicate, " + std::to_string(m.not_finite) +
         " with a time that is not finite and " + std::to_string(m.out_of_order) + " out of time order");
  if (out) out->close();
  if (summary)
    result.report = options.stats == CatOptions::Stats::jsonl ? format_stats_json(*summary, inputs) : format_stats(*summary);
  return result;
}

}  // namespace momentum::stream
