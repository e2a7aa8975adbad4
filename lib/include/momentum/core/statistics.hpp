#pragma once
// Robust statistics shared by the fitters and the streams.

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <vector>

namespace momentum::core {

// The median of `values` (reordered in place; NaN not allowed), interpolated within its bin
// when the values are quantised: drives report velocity as an integer count (a UR10e in steps
// of 1e-4 rad/s, the simulator by default 1e-3), so the plain median of a noise statistic is a
// multiple of the step and an estimate from it is off by up to half a step. When the median
// value is tied, the bin around it reaches halfway to the neighbouring values on each side
// (from the value itself when it is the smallest) and the median is placed in it by the share
// of ties below the middle (the grouped-data median). Values within 1e-9 of the largest
// magnitude of each other are ties. Empty: NaN.
double grouped_median(std::vector<double>& values);

// Standard deviation of white noise on a signal from |second differences| of consecutive samples
// (reordered in place): white noise of deviation s has second differences of deviation
// s sqrt(6), and their median magnitude is robust to the signal's own curvature and to the odd
// outlier. Empty: 0.
double white_noise_from_second_differences(std::vector<double>& magnitudes);

// The median of the last N values pushed: a stream's typical time step, robust to the gaps and
// the jitter it is there to judge. push() records; update() recomputes, so a caller on a hot
// path may refresh less often than it pushes.
//
// update() selects the median about the last one: the window splits into the values below it
// and the rest (one branch-free pass), and the middle ranks are then selected on their side
// alone: as the few largest of the one side or the few smallest of the other when the middle
// moved by at most kNear ranks since (it moves little between frequent updates), with an
// nth_element over that side otherwise. That costs a fraction of an nth_element over the whole
// window (the signal check's windows of 128 made a third of mo-observe's instructions). With a
// NaN in the window it selects with nth_element over the window. The median is the same value,
// bit for bit, either way: the middle element of the sorted window, or the mean of the two
// middle ones.
template <int N>
class RunningMedian {
 public:
  static_assert(N > 0);
  void push(double value) {
    if (count_ == N && window_[next_] != window_[next_]) --nans_;
    window_[next_] = value;
    if (value != value) ++nans_;
    next_ = (next_ + 1) % N;
    if (count_ < N) ++count_;
    ++pushed_;
  }
  // The median of the window (for an even count, the mean of the two middle values); 0 before
  // the first push.
  double update() {
    pushed_ = 0;
    if (count_ == 0) return median_;
    const int high = count_ / 2;                         // rank of the upper middle value
    const int low = count_ % 2 == 0 ? high - 1 : high;   // and of the lower one
    if (nans_ == 0) return select_about_last(low, high);
    double sorted[N];
    std::copy(window_, window_ + count_, sorted);
    std::nth_element(sorted, sorted + high, sorted + count_);
    median_ = sorted[high];
    if (low != high) median_ = 0.5 * (median_ + *std::max_element(sorted, sorted + high));
    return median_;
  }
  double value() const { return median_; }  // as of the last update()
  bool full() const { return count_ == N; }
  int pushes_since_update() const { return pushed_; }

 private:
  // Ranks the middle may move between updates and still be found beside the last median.
  static constexpr int kNear = N / 8 > 4 ? N / 8 : 4;

  // The mean of the values of ranks low and high (high - low <= 1) of the window, NaN-free.
  double select_about_last(int low, int high) {
    double below[N], rest[N];
    int n_below = 0, n_rest = 0;
    const double pivot = median_;
    double largest_below = -std::numeric_limits<double>::infinity();
    double smallest_rest = std::numeric_limits<double>::infinity();
    for (int k = 0; k < count_; ++k) {
      const double v = window_[k];
      below[n_below] = v;
      rest[n_rest] = v;
      const bool less = v < pivot;
      n_below += less;
      n_rest += !less;
      largest_below = less ? std::max(largest_below, v) : largest_below;
      smallest_rest = less ? smallest_rest : std::min(smallest_rest, v);
    }
    double extreme[kNear];
    double lower, upper;
    if (high < n_below) {
      // Both below the split: among the n_below - low largest values there.
      const int k = n_below - low;
      if (k <= kNear) {
        keep_first(below, n_below, k, extreme, [](double a, double b) { return a > b; });
        upper = extreme[n_below - 1 - high];
        lower = extreme[n_below - 1 - low];
      } else {
        std::nth_element(below, below + high, below + n_below);
        upper = below[high];
        lower = low == high ? upper : *std::max_element(below, below + high);
      }
    } else if (low >= n_below) {
      // Both above: among the high - n_below + 1 smallest values there.
      const int k = high - n_below + 1;
      if (k <= kNear) {
        keep_first(rest, n_rest, k, extreme, [](double a, double b) { return a < b; });
        lower = extreme[low - n_below];
        upper = extreme[high - n_below];
      } else {
        std::nth_element(rest, rest + (high - n_below), rest + n_rest);
        upper = rest[high - n_below];
        lower = low == high ? upper : *std::max_element(rest, rest + (high - n_below));
      }
    } else {
      // Astride the split (low = n_below - 1, high = n_below).
      lower = largest_below;
      upper = smallest_rest;
    }
    median_ = low == high ? upper : 0.5 * (upper + lower);
    return median_;
  }

  // The k values of v[0..n) that come first by `before`, in that order, into out[0..k).
  template <class Before>
  static void keep_first(const double* v, int n, int k, double* out, Before before) {
    int size = 0;
    for (int i = 0; i < n; ++i) {
      const double x = v[i];
      int at;
      if (size < k) {
        at = size++;
      } else if (before(x, out[k - 1])) {
        at = k - 1;
      } else {
        continue;
      }
      for (; at > 0 && before(x, out[at - 1]); --at) out[at] = out[at - 1];
      out[at] = x;
    }
  }

  double window_[N] = {};
  int count_ = 0;
  int next_ = 0;
  double median_ = 0;
  int pushed_ = 0;  // pushes since the last update()
  int nans_ = 0;    // NaN values in the window
};

// The same median of the last N values as RunningMedian (bit for bit: the same element, the same
// mean of the two middle ones), kept up to date on every push by moving the values of a sorted
// copy of the window, for a caller that needs the median after every value (a stream's time
// step, row by row). Finite values only (a NaN has no place in the sorted copy).
template <int N>
class SortedRunningMedian {
 public:
  static_assert(N > 0);
  // Records `value` (finite) and returns the median of the window, as RunningMedian's update().
  double push(double value) {
    if (count_ == N) {
      // The value leaving the window: the first equal to it in the sorted copy (equal values are
      // interchangeable) closes its gap.
      const double old = window_[next_];
      // The same bits coming in as going out (a log's steady time step, most rows): the sorted
      // copy and the median stay as they are.
      if (std::bit_cast<std::uint64_t>(old) == std::bit_cast<std::uint64_t>(value)) {
        next_ = (next_ + 1) % N;
        return median_;
      }
      int at = static_cast<int>(std::lower_bound(sorted_, sorted_ + count_, old) - sorted_);
      std::copy(sorted_ + at + 1, sorted_ + count_, sorted_ + at);
      --count_;
    }
    window_[next_] = value;
    next_ = (next_ + 1) % N;
    int at = static_cast<int>(std::upper_bound(sorted_, sorted_ + count_, value) - sorted_);
    std::copy_backward(sorted_ + at, sorted_ + count_, sorted_ + count_ + 1);
    sorted_[at] = value;
    ++count_;
    const int mid = count_ / 2;
    median_ = count_ % 2 == 0 ? 0.5 * (sorted_[mid] + sorted_[mid - 1]) : sorted_[mid];
    return median_;
  }
  double value() const { return median_; }  // 0 before the first push
  bool full() const { return count_ == N; }

 private:
  double window_[N] = {};
  double sorted_[N] = {};
  int count_ = 0;
  int next_ = 0;
  double median_ = 0;
};

}  // namespace momentum::core
