#pragma once
// mo-cat's work that is not option parsing: the --stats report and the --scale factors.

#include <string>
#include <vector>

#include "momentum/stream/stats.hpp"

namespace momentum::stream {

// The --stats report of a stream, one "label value" line per item (rows, columns, time span,
// steps, gaps, irregular steps, rows backwards, same-time rows, duplicates, frozen runs, NaN
// per column), each anomaly with its first places.
std::string format_stats(const StreamStats& stats);

// Factors per column of `columns` from --scale specs "LIST=FACTOR" ("q1-6=0.0174532925199433",
// repeatable, multiplying): 1 where none is given. Throws momentum::Error naming --scale for a
// spec without '=', a factor that is not a number, or a column that is not in `columns`.
std::vector<double> parse_scales(const std::vector<std::string>& specs, const std::vector<std::string>& columns);

}  // namespace momentum::stream
