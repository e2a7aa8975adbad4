// mo-cat: convert sample streams between CSV and binary, select columns, take the head, or
// describe a log (--stats).
#include <cinttypes>
#include <cstdio>
#include <optional>

#include "momentum/cli/tool.hpp"
#include "momentum/stream/columns.hpp"
#include "momentum/stream/error.hpp"
#include "momentum/stream/stats.hpp"

using namespace momentum;

namespace {

void print_stats(const stream::StreamStats& stats, std::FILE* out) {
  auto s = stats.summary();
  std::fprintf(out, "rows        %" PRIu64 "\n", s.rows);
  std::fprintf(out, "columns     %zu\n", s.columns);
  if (s.has_time) {
    std::fprintf(out, "time        %.9g .. %.9g s (span %.9g s)\n", s.t_first, s.t_last, s.t_last - s.t_first);
    std::fprintf(out, "dt          min %.6g  median %.6g  max %.6g s\n", s.dt_min, s.dt_median, s.dt_max);
    auto anomaly = [&](const char* label, const stream::StreamStats::Anomaly& a) {
      std::fprintf(out, "%-11s %" PRIu64, label, a.count);
      for (std::size_t i = 0; i < a.first.size(); ++i) std::fprintf(out, "%s%s", i ? ", " : "  at ", a.first[i].c_str());
      if (a.count > a.first.size()) std::fputs(", ...", out);
      std::fputc('\n', out);
    };
    anomaly("gaps", s.gaps);
    anomaly("backwards", s.backwards);
    anomaly("same-time", s.repeated_time);
    anomaly("duplicates", s.duplicates);
    anomaly("frozen", s.frozen);
  } else {
    std::fputs("time        no column 't'\n", out);
  }
  std::fputs("nan        ", out);
  bool any = false;
  for (std::size_t i = 0; i < s.nan_per_column.size(); ++i)
    if (s.nan_per_column[i]) std::fprintf(out, " %s=%" PRIu64, stats.columns()[i].c_str(), s.nan_per_column[i]), any = true;
  std::fputs(any ? "\n" : " none\n", out);
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("mo-cat", "Convert, select and describe sample streams.");
  tool.add_inputs("input streams, concatenated (same columns); - or none: stdin");
  tool.add_stream_output();
  std::string columns;
  std::optional<std::uint64_t> head;
  bool stats = false;
  tool.app().add_option("-c,--columns", columns, "columns to keep, in this order (t,q1-6,...)")->type_name("LIST");
  tool.app().add_option("--head", head, "stop after N rows")->type_name("N")->check(cli::whole_number());
  tool.app().add_flag("--stats", stats, "describe the stream on stdout instead of copying it");

  return tool.run(argc, argv, [&] {
    std::vector<std::string> inputs = tool.inputs();
    if (inputs.empty()) inputs.push_back("-");
    std::unique_ptr<stream::Writer> out;
    std::unique_ptr<stream::StreamStats> summary;
    std::vector<std::string> first_columns;
    std::vector<std::size_t> pick;
    std::vector<double> row_out;
    std::uint64_t rows = 0, skipped = 0;
    for (const auto& path : inputs) {
      auto in = tool.open_input(path);
      if (first_columns.empty()) {
        first_columns = in->columns();
        std::vector<std::string> selected = columns.empty() ? in->columns() : stream::expand_column_list(columns);
        pick = stream::column_indices(in->columns(), selected, in->name());
        row_out.resize(pick.size());
        if (stats) {
          summary = std::make_unique<stream::StreamStats>(selected);
        } else {
          out = tool.open_output(*in);
          out->header(selected);
          in->on_comment([&](std::string_view c) { out->comment(c); });
        }
      } else {
        if (in->columns() != first_columns)
          throw Error(in->name() + ": columns differ from " + inputs.front() + "'s; cannot concatenate");
        if (out) {
          stream::Writer* raw = out.get();
          in->on_comment([raw](std::string_view c) { raw->comment(c); });
          if (raw->interactive()) in->before_read([raw] { raw->flush(); });
        }
      }
      while (!head || rows < *head) {
        const double* row = in->next();
        if (!row) break;
        for (std::size_t i = 0; i < pick.size(); ++i) row_out[i] = row[pick[i]];
        if (summary) summary->add(row_out.data(), in->where());
        else out->row(row_out.data());
        ++rows;
      }
      skipped += in->rows_skipped();
    }
    if (out) out->close();
    if (summary) print_stats(*summary, stdout);
    if (skipped) {
      warn(std::to_string(skipped) + " bad row" + (skipped == 1 ? "" : "s") + " skipped");
      return cli::kFailure;
    }
    return cli::kSuccess;
  });
}
