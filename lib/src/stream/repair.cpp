#include "momentum/stream/repair.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace momentum::stream {

TimeOrderRepair::TimeOrderRepair(std::size_t width, std::size_t time_column, Emit emit, Dropped dropped)
    : TimeOrderRepair(width, time_column, std::move(emit), std::move(dropped), Options{}) {}

TimeOrderRepair::TimeOrderRepair(std::size_t width, std::size_t time_column, Emit emit, Dropped dropped,
                                 Options options)
    : width_(width), time_(time_column), emit_(std::move(emit)), dropped_(std::move(dropped)), options_(options) {
  options_.window = std::max<std::size_t>(options_.window, 4);
}

void TimeOrderRepair::push(const double* row, const std::string& where) {
  if (have_last_pushed_ && std::memcmp(row, last_pushed_.data(), width_ * sizeof(double)) == 0) {
    ++summary_.duplicates;
    dropped_(where, "duplicate row");
    return;
  }
  last_pushed_.assign(row, row + width_);
  have_last_pushed_ = true;
  pending_.push_back({std::vector<double>(row, row + width_), where});
  if (pending_.size() >= options_.window) decide(options_.window / 2);
}

void TimeOrderRepair::finish() { decide(pending_.size()); }

// Keeps the longest strictly increasing subsequence of time stamps among the pending rows
// (all above the last emitted time), then emits or drops the first `count` of them; the rest
// wait for more context.
void TimeOrderRepair::decide(std::size_t count) {
  std::size_t n = pending_.size();
  if (n == 0) return;
  // Patience sorting with predecessor links: O(n log n).
  std::vector<std::size_t> tails, previous(n, SIZE_MAX);
  std::vector<bool> eligible(n);
  for (std::size_t i = 0; i < n; ++i) {
    double t = pending_[i].values[time_];
    eligible[i] = !have_emitted_ || t > last_emitted_t_;
    if (!eligible[i] || t != t) continue;
    auto it = std::lower_bound(tails.begin(), tails.end(), t,
                               [&](std::size_t k, double value) { return pending_[k].values[time_] < value; });
    // Of rows with the same time the first is kept: skipping the later one leaves the tails'
    // values, and so the length of the run, unchanged.
    if (it != tails.end() && pending_[*it].values[time_] == t) continue;
    std::size_t pos = static_cast<std::size_t>(it - tails.begin());
    if (pos > 0) previous[i] = tails[pos - 1];
    if (it == tails.end()) tails.push_back(i);
    else *it = i;
  }
  std::vector<bool> keep(n, false);
  for (std::size_t k = tails.empty() ? SIZE_MAX : tails.back(); k != SIZE_MAX; k = previous[k]) keep[k] = true;
  for (std::size_t i = 0; i < count; ++i) {
    Pending& p = pending_.front();
    if (keep[i]) {
      emit_(p.values.data());
      last_emitted_t_ = p.values[time_];
      have_emitted_ = true;
      ++summary_.kept;
    } else {
      ++summary_.out_of_order;
      dropped_(p.where, std::isnan(p.values[time_]) ? "time is nan" : "out of time order");
    }
    pending_.pop_front();
  }
}

}  // namespace momentum::stream
