// mo-cat: convert sample streams between CSV and binary, select, rename and scale columns,
// mend timing faults, or describe a log (--stats). The work is stream::cat()'s; this file is
// the command line.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "momentum/cli/tool.hpp"
#include "momentum/cli/whole_number.hpp"
#include "momentum/core/file.hpp"
#include "momentum/stream/cat.hpp"
#include "momentum/stream/columns.hpp"

using namespace momentum;

int main(int argc, char** argv) {
  cli::Tool tool("mo-cat", "Convert, select, scale, mend and describe sample streams.");
  tool.app().footer("\nExample:\n  mo-cat --stats arm.csv\n\nMore: man mo-cat");
  tool.add_stream_inputs("input streams, concatenated (same columns); - or none: stdin");
  tool.add_stream_output();
  stream::CatOptions o;
  std::string names, stats_format = "text";
  bool stats = false;
  auto& app = tool.app();
  app.add_option("-c,--columns", o.columns, "columns to keep, in this order (t,q1-6,...)")->type_name("LIST");
  app.add_option("--names", names, "the input has no header: name its columns (_ drops one)")->type_name("LIST");
  app.add_option("--scale", o.scales, "multiply columns by a factor, e.g. q1-6=0.0174532925199433 (repeatable)")
      ->type_name("LIST=FACTOR")
      ->allow_extra_args(false);
  app.add_flag("--zero-time", o.zero_time, "shift t so that the first row is at 0");
  app.add_flag("--repair", o.repair, "drop exact duplicate rows and rows out of time order, and say which");
  app.add_option("--head", o.head, "stop after N rows")->type_name("N")->check(cli::whole_number_in(0, UINT64_MAX));
  app.add_flag("--stats", stats, "describe the stream on stdout instead of copying it");
  app.add_option("--stats-format", stats_format, "--stats as text (default) or jsonl: one JSON object")
      ->check(CLI::IsMember({"text", "jsonl"}));

  return tool.run(argc, argv, [&] {
    o.inputs = tool.inputs();
    if (!names.empty()) {
      try {
        o.names = stream::expand_column_list(names);
      } catch (const Error& e) {
        throw cli::UsageError(std::string("--names: ") + e.what());
      }
    }
    if (stats) o.stats = stats_format == "jsonl" ? stream::CatOptions::Stats::jsonl : stream::CatOptions::Stats::text;
    if (o.head && *o.head == 0) tool.set_no_rows_policy(false);  // the header alone was asked for
    stream::CatResult result;
    try {
      result = stream::cat(
          o, [&](const std::string& path, const stream::ReaderOptions& options) { return tool.open_input(path, options); },
          [&](stream::Reader& first) { return tool.open_output(first); });
    } catch (const stream::OptionError& e) {
      throw cli::UsageError(e.what());
    }
    if (!result.report.empty()) core::write_document("-", result.report);
    return cli::kSuccess;
  });
}
