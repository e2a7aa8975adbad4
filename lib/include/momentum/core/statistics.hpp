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

namespace detail {

// A double's bits as an unsigned integer of the same order (-0 just below +0; NaN-free input):
// a negative value's bits all flipped, a positive value's sign bit set.
inline std::uint64_t order_key(double value) {
  const std::uint64_t bits = std::bit_cast<std::uint64_t>(value);
  const std::uint64_t negative = static_cast<std::uint64_t>(static_cast<std::int64_t>(bits) >> 63);
  return bits ^ (negative | (std::uint64_t{1} << 63));
}
inline double from_order_key(std::uint64_t key) {
  const std::uint64_t positive = static_cast<std::uint64_t>(static_cast<std::int64_t>(key) >> 63);
  return std::bit_cast<double>(key ^ (~positive | (std::uint64_t{1} << 63)));
}

// The keys of ranks low and high = low or low + 1 (0-based) among keys[0..n) (reordered,
// n <= kMaxN; from and to their smallest and largest) by buckets: each pass counts the keys into
// 2^kBits buckets of equal width over [from, to], keeps the bucket that holds rank high and
// takes the span of its keys for the next pass, until few keys or one value are left; rank low
// in an earlier bucket is that bucket's largest key. A double's order key is close to its
// logarithm, so a noise scale's window spread over decades fills the buckets evenly; a lone
// zero or outlier stretches the span and costs a pass or two more. No comparison sort.
template <int kMaxN>
void select_ranks(std::uint64_t* keys, int n, std::uint64_t from, std::uint64_t to, int low, int high,
                  std::uint64_t* low_key, std::uint64_t* high_key) {
  constexpr int kBits = kMaxN >= 64 ? 6 : 3;
  constexpr int kBuckets = 1 << kBits;
  bool low_found = low == high;
  for (;;) {
    if (n <= 8) {
      std::sort(keys, keys + n);
      *high_key = keys[high];
      if (!low_found) *low_key = keys[low];
      return;
    }
    const int shift = std::max(0, static_cast<int>(std::bit_width(to - from)) - kBits);
    std::uint8_t bucket_of[kMaxN];
    std::uint16_t counts[kBuckets] = {};
    for (int k = 0; k < n; ++k) {
      const std::uint64_t key = keys[k];
      const int b = static_cast<int>((key - from) >> shift);
      bucket_of[k] = static_cast<std::uint8_t>(b);
      ++counts[b];
    }
    int bucket = 0, before = 0;
    while (before + counts[bucket] <= high) before += counts[bucket++];
    if (!low_found && low < before) {
      // Rank low = high - 1 = before - 1: the largest key of the nonempty bucket before.
      int low_bucket = bucket - 1;
      while (counts[low_bucket] == 0) --low_bucket;
      std::uint64_t largest = 0;
      for (int k = 0; k < n; ++k)
        largest = bucket_of[k] == low_bucket ? std::max(largest, keys[k]) : largest;
      *low_key = largest;
      low_found = true;
    }
    int kept = 0;
    for (int k = 0; k < n; ++k) {
      keys[kept] = keys[k];
      kept += bucket_of[k] == bucket;
    }
    n = kept;
    low -= before;
    high -= before;
    from = *std::min_element(keys, keys + n);
    to = *std::max_element(keys, keys + n);
    if (from == to) {
      *high_key = from;
      if (!low_found) *low_key = from;
      return;
    }
  }
}

}  // namespace detail

// The median of the last N values pushed: a stream's typical time step, robust to the gaps and
// the jitter it is there to judge. push() records; update() recomputes, so a caller on a hot
// path may refresh less often than it pushes.
//
// Between updates it keeps a lower bound of the window's median at the cost of two comparisons
// a push: kBoundFraction times the lower middle value last computed, for as long as no more
// than the lower half of the window's values lie below it (counted as values come and go). A
// caller that accepts what lies within a multiple of the median can accept on the bound
// without computing the median, and update() only when bound_holds() turns false or a value
// lies beyond the bound.
//
// update() selects the middle ranks by buckets of the values' order keys (detail::select_ranks),
// or for a window of fewer than 32 with nth_element.
// For the signal check's windows of 128, with half the window new, that costs
// 5,100 instructions where an nth_element beside the last median cost 7,100 (the middle moves
// too far between such updates for a neighbourhood search). With a NaN in the window it
// selects with nth_element over the window. The median is the same value, bit for bit, either
// way: the middle element of the sorted window, or the mean of the two middle ones.
//
// With KeepsBound false, a window whose median alone is read (the signal check's torque
// curvature, the observer's time step) skips the bound's bookkeeping: the two comparisons a
// push makes against it, and the count update() makes.
template <int N, bool KeepsBound = true>
class RunningMedian {
 public:
  static_assert(N > 0);
  // Fraction of the lower middle value last computed that lower_bound() is: the window's
  // values below it are, for normal noise, 39% of the window (|x| < 0.51 sigma), so it holds
  // through the fluctuations of a steady window and fails with one whose scale falls by a
  // quarter.
  static constexpr double kBoundFraction = 0.75;

  void push(double value) {
    if (count_ == N) {
      if constexpr (KeepsBound) below_ -= window_[next_] < bound_;
    } else {
      ++count_;
    }
    window_[next_] = value;
    if constexpr (KeepsBound) below_ += value < bound_;
    if (++next_ == N) next_ = 0;
    ++pushed_;
  }
  // The median of the window (for an even count, the mean of the two middle values); 0 before
  // the first push.
  double update() {
    pushed_ = 0;
    if (count_ == 0) return median_;
    const int high = count_ / 2;                         // rank of the upper middle value
    const int low = count_ % 2 == 0 ? high - 1 : high;   // and of the lower one
    double lower = 0, upper = 0;  // the values of ranks low and high
    // NaNs are looked for here, not counted as they come: a caller that pushes on every row and
    // updates rarely (the signal check) pays for them rarely.
    bool nan = false;
    for (int k = 0; k < count_; ++k) nan = nan || window_[k] != window_[k];
    // A small window (a stream's time step, 16) selects faster with nth_element: about 510
    // against 960 instructions an update (callgrind, mo-observe on the UR5 bench stream).
    if (!nan && N >= 32) {
      select_middle(low, high, &lower, &upper);
    } else {
      double sorted[N];
      std::copy(window_, window_ + count_, sorted);
      std::nth_element(sorted, sorted + high, sorted + count_);
      upper = lower = sorted[high];
      if (low != high) lower = *std::max_element(sorted, sorted + high);
    }
    median_ = low == high ? upper : 0.5 * (upper + lower);
    if constexpr (KeepsBound) {
      // Of the lower middle value: the mean of the two middle ones may lie far above it.
      bound_ = kBoundFraction * lower;
      int below = 0;
      for (int k = 0; k < count_; ++k) below += window_[k] < bound_;
      below_ = below;
    }
    return median_;
  }
  double value() const { return median_; }  // as of the last update()
  // At most the window's median now while bound_holds() (for values >= 0; kBoundFraction times
  // the lower middle value last computed).
  double lower_bound() const {
    static_assert(KeepsBound);
    return bound_;
  }
  // Whether the lower middle value of the window is still at least lower_bound(), so the
  // median is.
  bool bound_holds() const {
    static_assert(KeepsBound);
    return below_ <= (count_ - 1) / 2;
  }
  bool full() const { return count_ == N; }
  int pushes_since_update() const { return pushed_; }

 private:
  // The values of ranks low and high (high - low <= 1) of the window, NaN-free.
  void select_middle(int low, int high, double* lower_value, double* upper_value) const {
    std::uint64_t keys[N];
    std::uint64_t from = ~std::uint64_t{0}, to = 0;
    for (int k = 0; k < count_; ++k) {
      const std::uint64_t key = detail::order_key(window_[k]);
      keys[k] = key;
      from = std::min(from, key);
      to = std::max(to, key);
    }
    std::uint64_t lower = 0, upper = 0;
    detail::select_ranks<N>(keys, count_, from, to, low, high, &lower, &upper);
    *upper_value = detail::from_order_key(upper);
    *lower_value = low == high ? *upper_value : detail::from_order_key(lower);
  }

  double window_[N] = {};
  int count_ = 0;
  int next_ = 0;
  double median_ = 0;
  int pushed_ = 0;  // pushes since the last update()
  double bound_ = 0;
  int below_ = 0;   // values in the window below bound_
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
        if (++next_ == N) next_ = 0;
        return median_;
      }
      int at = static_cast<int>(std::lower_bound(sorted_, sorted_ + count_, old) - sorted_);
      std::copy(sorted_ + at + 1, sorted_ + count_, sorted_ + at);
      --count_;
    }
    window_[next_] = value;
    if (++next_ == N) next_ = 0;
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
