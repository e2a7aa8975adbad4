#pragma once
// mo-cat's work that is not option parsing: copying streams with their columns selected,
// scaled and mended (cat()), the --stats reports, and the --scale factors. The tool is a thin
// main over cat(): options in, the result out.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "momentum/core/error.hpp"
#include "momentum/stream/reader.hpp"
#include "momentum/stream/stats.hpp"
#include "momentum/stream/time_order.hpp"
#include "momentum/stream/writer.hpp"

namespace momentum::stream {

// The --stats report of a stream, one "label value" line per item (rows, columns, time span,
// steps, gaps, irregular steps, rows backwards, same-time rows, duplicates, frozen runs, NaN
// per column), each anomaly with its first places.
std::string format_stats(const StreamStats& stats);

// The --stats report as one JSON object on one line (mo-cat(1), JSON LINES): every number of
// the text form, the anomalies with their first places, NaN counts per column; time fields
// null without a 't'. `sources`: the inputs' names.
std::string format_stats_json(const StreamStats& stats, const std::vector<std::string>& sources);

// Factors per column of `columns` from --scale specs "LIST=FACTOR" ("q1-6=0.0174532925199433",
// repeatable, multiplying): 1 where none is given. Throws momentum::Error naming --scale for a
// spec without '=', a factor that is not a number, or a column that is not in `columns`.
std::vector<double> parse_scales(const std::vector<std::string>& specs, const std::vector<std::string>& columns);

// An option that does not fit the stream (a --scale of a column that is not there): the tool
// reports it as a usage error.
class OptionError : public Error {
 public:
  using Error::Error;
};

// What mo-cat does with its inputs. Defaults are mo-cat(1)'s.
struct CatOptions {
  std::vector<std::string> inputs;    // read one after the other, same columns; none: stdin
  std::string columns;                // columns to keep, in this order (a column list); empty: all
  std::vector<std::string> names;     // the inputs have no header: these are their columns
  std::vector<std::string> scales;    // --scale specs (parse_scales)
  std::optional<std::uint64_t> head;  // stop after this many rows
  bool zero_time = false;             // shift t so that the first row is at 0
  bool repair = false;                // the time-order policy: drop duplicates, rows out of order
  enum class Stats { none, text, jsonl } stats = Stats::none;  // describe instead of copying
};

struct CatResult {
  std::uint64_t rows = 0;     // rows copied (or described)
  TimeOrder::Summary mended;  // with repair: what the time-order policy kept and dropped
  std::string report;         // the --stats report (empty when copying)
};

// Opens one input (the tool's --strict and row counting); opens the output for the first
// input's encoding and comments.
using OpenInput = std::function<std::unique_ptr<Reader>(const std::string& path, const ReaderOptions& options)>;
using OpenOutput = std::function<std::unique_ptr<Writer>(Reader& first)>;

// Copies (or with options.stats describes) every input in turn: the selected columns, scaled,
// t shifted or mended as asked, comments passed through, the output flushed before a read
// that may wait when it is a pipe. Throws momentum::Error for a header-less input without
// names, inputs whose columns differ, a missing column, OptionError for a bad --scale or a
// --columns list that is too long or names a column twice (before any input is opened), and
// what reading and writing throw. With repair, warns once with what was dropped.
CatResult cat(const CatOptions& options, const OpenInput& open_input, const OpenOutput& open_output);

}  // namespace momentum::stream
