#include "momentum/stream/stats.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace momentum::stream {

namespace {
void note(StreamStats::Anomaly& a, const std::string& where) {
  if (a.first.size() < 5) a.first.push_back(where);
  ++a.count;
}
bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }
}  // namespace

StreamStats::StreamStats(std::vector<std::string> columns) : columns_(std::move(columns)) {
  for (const char* name : {"t", "timestamp", "time"}) {
    const auto it = std::find(columns_.begin(), columns_.end(), name);
    if (it == columns_.end()) continue;
    t_ = static_cast<std::size_t>(it - columns_.begin());
    s_.time_column = name;
    break;
  }
  s_.columns = columns_.size();
  s_.has_time = t_.has_value();
  s_.nan_per_column.assign(columns_.size(), 0);
  histogram_.assign(static_cast<std::size_t>((kMaxDecade - kMinDecade) * kBinsPerDecade), 0);
  previous_.assign(columns_.size(), 0.0);
}

void StreamStats::add(const double* row, const std::string& where) {
  for (std::size_t i = 0; i < columns_.size(); ++i)
    if (std::isnan(row[i])) ++s_.nan_per_column[i];
  if (have_previous_) {
    bool all_same = true, values_same = true;
    for (std::size_t i = 0; i < columns_.size(); ++i) {
      if (!same_bits(row[i], previous_[i])) {
        all_same = false;
        if (!t_ || i != *t_) values_same = false;
      }
    }
    if (all_same) note(s_.duplicates, where);
    if (values_same && !all_same) {
      if (++frozen_run_ == 1) frozen_start_ = where;
      if (frozen_run_ == 9) note(s_.frozen, frozen_start_);  // 10 rows with the same values
    } else {
      frozen_run_ = 0;
    }
    if (t_ && !all_same) {
      double dt = row[*t_] - previous_[*t_];
      if (dt < 0) {
        note(s_.backwards, where);
      } else if (dt == 0) {
        note(s_.repeated_time, where);
      } else if (std::isfinite(dt)) {
        s_.dt_min = s_.rows == 1 || s_.dt_min == 0 ? dt : std::min(s_.dt_min, dt);
        s_.dt_max = std::max(s_.dt_max, dt);
        double bin = (std::log10(dt) - kMinDecade) * kBinsPerDecade;
        auto index = static_cast<std::size_t>(std::clamp(bin, 0.0, double(histogram_.size() - 1)));
        ++histogram_[index];
        if (!exact_overflow_) {
          ++exact_steps_[dt];
          if (exact_steps_.size() > 4096) exact_overflow_ = true;
        }
        // Gaps are decided against the median at the end. Any gap exceeds 1.5 times the
        // smallest step so far, so those steps are the candidates whose places we keep.
        if (min_positive_dt_ == 0 || dt < min_positive_dt_) min_positive_dt_ = dt;
        if (dt > 1.5 * min_positive_dt_ && big_steps_.size() < 256) big_steps_.emplace_back(dt, where);
      }
    }
  } else if (t_) {
    s_.t_first = row[*t_];
  }
  if (t_ && std::isfinite(row[*t_])) s_.t_last = std::max(s_.t_last, row[*t_]);
  std::copy(row, row + columns_.size(), previous_.begin());
  have_previous_ = true;
  ++s_.rows;
}

StreamStats::Summary StreamStats::summary() const {
  Summary out = s_;
  std::uint64_t total = 0;
  for (auto c : histogram_) total += c;
  if (total == 0) return out;
  std::uint64_t half = (total + 1) / 2, seen = 0;
  std::size_t median_bin = 0;
  for (std::size_t i = 0; i < histogram_.size(); ++i) {
    seen += histogram_[i];
    if (seen >= half) {
      median_bin = i;
      break;
    }
  }
  out.dt_median = std::pow(10.0, kMinDecade + (median_bin + 0.5) / kBinsPerDecade);
  if (!exact_overflow_) {
    seen = 0;
    for (const auto& [dt, count] : exact_steps_) {
      seen += count;
      if (seen >= half) {
        out.dt_median = dt;
        break;
      }
    }
  }
  out.dt_median = std::clamp(out.dt_median, out.dt_min, out.dt_max);
  // Steps with lo < dt <= hi: exact from the distinct steps while they fit in memory (a log at
  // a fixed rate has few), else the histogram's bins wholly inside the interval.
  auto steps_between = [&](double lo, double hi) {
    std::uint64_t count = 0;
    if (!exact_overflow_) {
      for (const auto& [dt, n] : exact_steps_)
        if (dt > lo && dt <= hi) count += n;
      return count;
    }
    auto bin_of = [](double dt) { return dt > 0 ? (std::log10(dt) - kMinDecade) * kBinsPerDecade : -INFINITY; };
    for (std::size_t i = 0; i < histogram_.size(); ++i)
      if (static_cast<double>(i) >= bin_of(lo) && static_cast<double>(i) + 1 <= bin_of(hi)) count += histogram_[i];
    return count;
  };
  // Gaps: every step above 1.5 median; the places come from the kept steps (the first ones,
  // in order). Irregular: more than 10% off the median, not a gap.
  const double limit = 1.5 * out.dt_median;
  out.gaps.count = steps_between(limit, INFINITY);
  out.irregular = steps_between(0, std::nextafter(0.9 * out.dt_median, 0.0)) + steps_between(1.1 * out.dt_median, limit);
  std::uint64_t listed = 0;
  for (const auto& [dt, where] : big_steps_) {
    if (!(dt > limit)) continue;
    ++listed;
    if (out.gaps.first.size() < 5) out.gaps.first.push_back(where);
  }
  out.gaps.count = std::max(out.gaps.count, listed);
  return out;
}

}  // namespace momentum::stream
