#pragma once
// One-pass, constant-memory statistics of a sample stream: the first thing a user looks at on a
// new log (mo-cat --stats).

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace momentum::stream {

class StreamStats {
 public:
  // `columns`: the stream's column names. The time column is "t" when present, else one named
  // "timestamp" or "time" (a recording not yet renamed, such as UR's RTDE client's).
  explicit StreamStats(std::vector<std::string> columns);

  // Adds one row; `where` names its location for the first few anomalies of each kind.
  void add(const double* row, const std::string& where);

  struct Anomaly {
    std::uint64_t count = 0;
    std::vector<std::string> first;  // up to 5 locations, in stream order
  };
  struct Summary {
    std::uint64_t rows = 0;
    std::size_t columns = 0;
    bool has_time = false;
    std::string time_column;  // the column taken as time (empty without one)
    double t_first = 0, t_last = 0;
    // Time steps between consecutive rows, s. The median is exact while there are at most 4096
    // distinct steps, else from a log-spaced histogram (within 0.12%).
    double dt_min = 0, dt_median = 0, dt_max = 0;
    Anomaly gaps;             // dt > 1.5 median dt: lost samples
    // Steps more than 10% off the median that are not gaps (sampling jitter, a changed rate).
    // Counted only: which ones they are is known only once the median is.
    std::uint64_t irregular = 0;
    Anomaly backwards;        // dt < 0: rows written early
    Anomaly repeated_time;    // dt == 0 with different values
    Anomaly duplicates;       // a row equal to the previous one in every column
    Anomaly frozen;           // runs of >= 10 rows where every non-time column is unchanged
    std::vector<std::uint64_t> nan_per_column;
  };
  Summary summary() const;
  const std::vector<std::string>& columns() const { return columns_; }

 private:
  static constexpr int kBinsPerDecade = 1000;
  static constexpr int kMinDecade = -9, kMaxDecade = 6;
  std::vector<std::string> columns_;
  std::optional<std::size_t> t_;
  Summary s_;
  std::vector<std::uint64_t> histogram_;
  // Exact step counts while there are few distinct steps (regular logs), for an exact median.
  std::map<double, std::uint64_t> exact_steps_;
  bool exact_overflow_ = false;
  std::vector<double> previous_;
  bool have_previous_ = false;
  std::uint64_t frozen_run_ = 0;
  std::string frozen_start_;
  std::vector<std::pair<double, std::string>> big_steps_;  // candidate gaps, decided at the end
  double min_positive_dt_ = 0;
};

}  // namespace momentum::stream
