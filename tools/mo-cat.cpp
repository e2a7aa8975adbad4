// mo-cat: convert sample streams between CSV and binary, select, rename and scale columns,
// mend timing faults, or describe a log (--stats).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>

#include <nlohmann/json.hpp>

#include "momentum/cli/tool.hpp"
#include "momentum/stream/cat.hpp"
#include "momentum/stream/columns.hpp"
#include "momentum/stream/error.hpp"
#include "momentum/stream/stats.hpp"

using namespace momentum;

namespace {


// --stats as one JSON object (mo-cat(1), JSON LINES): every number of the text form, the
// anomalies with their first places, NaN counts per column; time fields null without a 't'.
void print_stats_json(const stream::StreamStats& stats, const std::vector<std::string>& inputs, std::FILE* out) {
  const auto s = stats.summary();
  auto number = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  auto anomaly = [](const stream::StreamStats::Anomaly& a) {
    return nlohmann::json{{"count", a.count}, {"first", a.first}};
  };
  nlohmann::json nan = nlohmann::json::object();
  for (std::size_t i = 0; i < s.nan_per_column.size(); ++i) nan[stats.columns()[i]] = s.nan_per_column[i];
  nlohmann::json line = {{"sources", inputs}, {"rows", s.rows}, {"columns", stats.columns()}, {"nan", nan}};
  const char* timed[] = {"t_first", "t_last", "dt_min", "dt_median", "dt_max", "gaps", "irregular",
                         "backwards", "same_time", "duplicates", "frozen"};
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
  const std::string text = line.dump() + "\n";
  std::fwrite(text.data(), 1, text.size(), out);
}


// True for a whole CSV field that is a number ("0.001", "-3", "1e-3", "nan"), as a header-less
// row's fields are and a column name never is.
bool looks_like_number(const std::string& field) {
  if (field.empty()) return false;
  char* end = nullptr;
  std::strtod(field.c_str(), &end);
  return end == field.c_str() + field.size();
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("mo-cat", "Convert, select, scale, mend and describe sample streams.");
  tool.app().footer("\nExample:\n  mo-cat --stats arm.csv\n\nMore: man mo-cat");
  tool.add_inputs("input streams, concatenated (same columns); - or none: stdin");
  tool.add_stream_output();
  std::string columns, names;
  std::vector<std::string> scales;
  std::optional<std::uint64_t> head;
  bool stats = false, zero_time = false, repair = false;
  auto& app = tool.app();
  app.add_option("-c,--columns", columns, "columns to keep, in this order (t,q1-6,...)")->type_name("LIST");
  app.add_option("--names", names, "the input has no header: name its columns (_ drops one)")->type_name("LIST");
  app.add_option("--scale", scales, "multiply columns by a factor, e.g. q1-6=0.0174532925199433 (repeatable)")
      ->type_name("LIST=FACTOR")
      ->allow_extra_args(false);
  app.add_flag("--zero-time", zero_time, "shift t so that the first row is at 0");
  app.add_flag("--repair", repair, "drop exact duplicate rows and rows out of time order, and say which");
  app.add_option("--head", head, "stop after N rows")->type_name("N")->check(cli::whole_number());
  app.add_flag("--stats", stats, "describe the stream on stdout instead of copying it");
  std::string stats_format = "text";
  app.add_option("--stats-format", stats_format, "--stats as text (default) or jsonl: one JSON object")
      ->check(CLI::IsMember({"text", "jsonl"}));

  return tool.run(argc, argv, [&] {
    std::vector<std::string> inputs = tool.inputs();
    if (inputs.empty()) inputs.push_back("-");
    if (head && *head == 0) tool.set_no_rows_policy(false);  // the header alone was asked for
    stream::ReaderOptions read_options;
    if (!names.empty()) read_options.names = stream::expand_column_list(names);
    // Rows as written, unless asked to mend them by the suite's time policy (mo-log(5)).
    read_options.time_order = repair;

    std::unique_ptr<stream::Writer> out;
    std::unique_ptr<stream::StreamStats> summary;
    std::vector<std::string> first_columns;
    std::vector<std::size_t> pick;
    std::vector<double> factor, row_out;
    std::optional<std::size_t> t_out;
    std::optional<double> t_origin;
    std::uint64_t rows = 0;
    stream::TimeOrder::Summary mended;
    bool identity = false;
    stream::Reader* current = nullptr;

    auto deliver = [&](const double* row) {
      if (summary) summary->add(row, current->where());
      else out->row(row);
    };

    for (const auto& path : inputs) {
      auto in = tool.open_input(path, read_options);
      current = in.get();
      if (first_columns.empty()) {
        // A vendor export without a header would otherwise have its first row taken as names.
        if (read_options.names.empty() && !in->columns().empty() &&
            std::all_of(in->columns().begin(), in->columns().end(), looks_like_number))
          throw Error(in->name() + ": no header: the first line holds only numbers (" + in->columns().front() +
                      ", ...); name the columns with --names (see man mo-cat)");
        first_columns = in->columns();
        std::vector<std::string> selected = columns.empty() ? in->columns() : stream::expand_column_list(columns);
        pick = stream::column_indices(in->columns(), selected, in->name());
        try {
          factor = stream::parse_scales(scales, selected);
        } catch (const Error& e) {
          throw cli::UsageError(e.what());
        }
        row_out.resize(pick.size());
        identity = !zero_time && !repair && pick.size() == in->columns().size();
        for (std::size_t i = 0; i < pick.size(); ++i) identity = identity && pick[i] == i && factor[i] == 1.0;
        for (std::size_t i = 0; i < selected.size(); ++i)
          if (selected[i] == "t") t_out = i;
        if ((zero_time || repair) && !t_out)
          throw Error(in->name() + ": missing column 't' (needed by " + (repair ? "--repair" : "--zero-time") + ")");
        if (stats) {
          summary = std::make_unique<stream::StreamStats>(selected);
        } else {
          out = tool.open_output(*in);
          out->header(selected);
        }
      } else if (in->columns() != first_columns) {
        throw Error(in->name() + ": columns differ from " + inputs.front() + "'s; cannot concatenate");
      }
      if (out) {
        stream::Writer* raw = out.get();
        in->on_comment([raw](std::string_view c) { raw->comment(c); });
        if (raw->interactive()) in->before_read([raw] { raw->flush(); });
      }
      while (!head || rows < *head) {
        const double* row = in->next();
        if (!row) break;
        if (identity) {  // plain conversion: no copy on the hot path
          deliver(row);
          ++rows;
          continue;
        }
        for (std::size_t i = 0; i < pick.size(); ++i) row_out[i] = row[pick[i]];
        if (zero_time) {  // before scaling, so that controller ticks subtract exactly
          if (!t_origin) t_origin = row_out[*t_out];
          row_out[*t_out] -= *t_origin;
        }
        for (std::size_t i = 0; i < pick.size(); ++i) row_out[i] *= factor[i];
        deliver(row_out.data());
        ++rows;
      }
      if (const stream::TimeOrder::Summary* time = in->time_summary()) {
        mended.kept += time->kept;
        mended.duplicates += time->duplicates;
        mended.not_finite += time->not_finite;
        mended.out_of_order += time->out_of_order;
        mended.clock_steps += time->clock_steps;
      }
    }
    if (repair && (mended.dropped() || mended.clock_steps))
      warn("--repair kept " + std::to_string(mended.kept) + " rows (" + std::to_string(mended.clock_steps) +
           " clock steps), dropped " + std::to_string(mended.duplicates) + " duplicate, " +
           std::to_string(mended.not_finite) + " with a time that is not finite and " +
           std::to_string(mended.out_of_order) + " out of time order");
    if (out) out->close();
    if (summary && stats_format == "jsonl") print_stats_json(*summary, inputs, stdout);
    else if (summary) std::fputs(stream::format_stats(*summary).c_str(), stdout);
    return cli::kSuccess;
  });
}
