#pragma once
// Robust statistics shared by the fitters and the streams.

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include "momentum/core/lanes.hpp"

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

// The median of window[0..count) (count <= N; any order; for an even count the mean of the two
// middle values; 0 when empty), and the lower middle value in `lower`: selected by buckets of the
// values' order keys (select_ranks) for N >= 32, with nth_element for a smaller window or one
// that holds a NaN. The same value, bit for bit, either way.
template <int N>
double window_median(const double* window, int count, double* lower) {
  *lower = 0;
  if (count <= 0) return 0;
  const int high = count / 2;                        // rank of the upper middle value
  const int low = count % 2 == 0 ? high - 1 : high;  // and of the lower one
  double lower_value = 0, upper_value = 0;
  // NaNs are looked for here, not counted as they come: a caller that pushes on every row and
  // updates rarely (the signal check) pays for them rarely.
  bool nan = false;
  for (int k = 0; k < count; ++k) nan = nan || window[k] != window[k];
  // A small window (a stream's time step, 16) selects faster with nth_element: about 510
  // against 960 instructions an update (callgrind, mo-observe on the UR5 bench stream).
  if (!nan && N >= 32) {
    std::uint64_t keys[N];
    std::uint64_t from = ~std::uint64_t{0}, to = 0;
    for (int k = 0; k < count; ++k) {
      const std::uint64_t key = order_key(window[k]);
      keys[k] = key;
      from = std::min(from, key);
      to = std::max(to, key);
    }
    std::uint64_t low_key = 0, high_key = 0;
    select_ranks<N>(keys, count, from, to, low, high, &low_key, &high_key);
    upper_value = from_order_key(high_key);
    lower_value = low == high ? upper_value : from_order_key(low_key);
  } else {
    double sorted[N];
    std::copy(window, window + count, sorted);
    std::nth_element(sorted, sorted + high, sorted + count);
    upper_value = lower_value = sorted[high];
    if (low != high) lower_value = *std::max_element(sorted, sorted + high);
  }
  *lower = lower_value;
  return low == high ? upper_value : 0.5 * (upper_value + lower_value);
}

}  // namespace detail

// The median of the last N values pushed: a stream's typical time step, robust to the gaps and
// the jitter it is there to judge. push() records; update() recomputes, so a caller on a hot
// path may refresh less often than it pushes. update() is detail::window_median: the middle
// element of the sorted window, or the mean of the two middle ones.
template <int N>
class RunningMedian {
 public:
  static_assert(N > 0);
  void push(double value) {
    count_ += count_ < N;
    window_[next_] = value;
    if (++next_ == N) next_ = 0;
    ++pushed_;
  }
  // The median of the window (for an even count, the mean of the two middle values); 0 before
  // the first push.
  double update() {
    pushed_ = 0;
    if (count_ == 0) return median_;
    double lower = 0;
    median_ = detail::window_median<N>(window_, count_, &lower);
    return median_;
  }
  double value() const { return median_; }  // as of the last update()
  bool full() const { return count_ == N; }
  int pushes_since_update() const { return pushed_; }

 private:
  double window_[N] = {};
  int count_ = 0;
  int next_ = 0;
  double median_ = 0;
  int pushed_ = 0;  // pushes since the last update()
};

// K running medians of the last N values each, pushed together, one value per window: the
// signal check's scales, a window per joint. Each window's median is RunningMedian<N>'s, bit
// for bit, for the same values pushed. The ring's position, fill and push count are kept once
// for all K windows, and a push is one pass over K adjacent values (the ring is N rows of K).
//
// With KeepsBound, between updates each window keeps a lower bound of its median at the cost
// of two comparisons a push: kBoundFraction times the lower middle value last computed, for as
// long as no more than the lower half of the window's values lie below it (counted as values
// come and go). A caller that accepts what lies within a multiple of the median can accept on
// the bound without computing the median, and update() only when bound_holds() turns false or
// a value lies beyond the bound. A window whose median alone is read (the signal check's
// torque curvature) skips that bookkeeping without it.
//
// update() selects the middle ranks by buckets of the values' order keys (detail::select_ranks):
// for the signal check's windows of 128, with half the window new, that costs 5,100
// instructions where an nth_element beside the last median cost 7,100 (the middle moves too far
// between such updates for a neighbourhood search).
template <int N, bool KeepsBound = true>
class RunningMedianBank {
 public:
  static_assert(N > 0);
  // Fraction of the lower middle value last computed that lower_bound() is: the window's
  // values below it are, for normal noise, 39% of the window (|x| < 0.51 sigma), so it holds
  // through the fluctuations of a steady window and fails with one whose scale falls by a
  // quarter.
  static constexpr double kBoundFraction = 0.75;

  // `windows` (>= 0) medians, each 0 until its first update().
  explicit RunningMedianBank(int windows)
      : windows_(windows),
        ring_(static_cast<std::size_t>(N) * static_cast<std::size_t>(windows)),
        median_(static_cast<std::size_t>(windows)),
        bound_(KeepsBound ? static_cast<std::size_t>(windows) : 0),
        below_(KeepsBound ? static_cast<std::size_t>(windows) : 0),
        updated_at_(static_cast<std::size_t>(windows)) {}

  // Records values[k] in window k, for every k < windows().
  void push(const double* values) {
    const int windows = windows_;  // held in a register: the stores below may alias the member
    double* row = ring_.data() + static_cast<std::size_t>(next_) * static_cast<std::size_t>(windows);
    if constexpr (KeepsBound) {
      // The row's values leave their windows once the ring is full.
      const bool leaving = count_ == N;
      count_ += count_ < N;
      const double most_below = (count_ - 1) / 2;
      const double* bound = bound_.data();
      double* below = below_.data();
      // Two windows at a time (lanes.hpp): a comparison gives all ones where it holds, and so
      // 1.0 and 0.0 through a mask. The counts are whole numbers far below 2^53, exact in
      // doubles, which SSE2 compares where it cannot compare 64-bit integers.
      using lanes::Pair;
      using lanes::PairMask;
      const PairMask one = reinterpret_cast<PairMask>(Pair{} + 1.0);
      const PairMask one_leaving = leaving ? one : PairMask{};
      const Pair most = Pair{} + most_below;
      PairMask beyond{};
      int k = 0;
      for (; k + 2 <= windows; k += 2) {
        Pair value, limit, old, count;
        std::memcpy(&value, values + k, sizeof value);
        std::memcpy(&limit, bound + k, sizeof limit);
        std::memcpy(&old, row + k, sizeof old);
        std::memcpy(&count, below + k, sizeof count);
        count += reinterpret_cast<Pair>((value < limit) & one);
        count -= reinterpret_cast<Pair>((old < limit) & one_leaving);
        beyond |= count > most;
        std::memcpy(below + k, &count, sizeof count);
        std::memcpy(row + k, &value, sizeof value);
      }
      bool held = (beyond[0] | beyond[1]) == 0;
      for (; k < windows; ++k) {
        below[k] += static_cast<double>(values[k] < bound[k]) - static_cast<double>(leaving && row[k] < bound[k]);
        held = held && below[k] <= most_below;
        row[k] = values[k];
      }
      bounds_held_ = held;
    } else {
      lanes::for_joints(static_cast<std::size_t>(windows),
                        [&]<class V>(std::size_t k) { lanes::store(row + k, lanes::load<V>(values + k)); });
      count_ += count_ < N;
    }
    if (++next_ == N) next_ = 0;
    ++pushed_;
  }
  // Window k's median (for an even count, the mean of the two middle values); 0 before the
  // first push.
  double update(int k) {
    const std::size_t w = static_cast<std::size_t>(k);
    updated_at_[w] = pushed_;
    if (count_ == 0) return median_[w];
    double window[N];
    for (int m = 0; m < count_; ++m) window[m] = ring_[static_cast<std::size_t>(m * windows_ + k)];
    double lower = 0;
    median_[w] = detail::window_median<N>(window, count_, &lower);
    if constexpr (KeepsBound) {
      bound_[w] = kBoundFraction * lower;
      int below = 0;
      for (int m = 0; m < count_; ++m) below += window[m] < bound_[w];
      below_[w] = below;
    }
    return median_[w];
  }
  double value(int k) const { return median_[static_cast<std::size_t>(k)]; }  // as of its last update()
  // At most window k's median now while bound_holds(k) (for values >= 0).
  double lower_bound(int k) const {
    static_assert(KeepsBound);
    return bound_[static_cast<std::size_t>(k)];
  }
  // Every window's lower_bound(), window k's at [k].
  const double* lower_bounds() const {
    static_assert(KeepsBound);
    return bound_.data();
  }
  // Whether window k's lower middle value is still at least lower_bound(k), so its median is.
  bool bound_holds(int k) const {
    static_assert(KeepsBound);
    return below_[static_cast<std::size_t>(k)] <= (count_ - 1) / 2;
  }
  // Whether every window's bound held after the last push (as bound_holds(k) for every k
  // then): when it did, no window needs an update for its bound.
  bool bounds_held_at_push() const {
    static_assert(KeepsBound);
    return bounds_held_;
  }
  int pushes_since_update(int k) const {
    const std::uint64_t since = pushed_ - updated_at_[static_cast<std::size_t>(k)];
    return static_cast<int>(std::min<std::uint64_t>(since, std::numeric_limits<int>::max()));
  }
  int windows() const { return windows_; }
  bool full() const { return count_ == N; }

 private:
  int windows_;
  std::vector<double> ring_;  // value m of window k at m * windows_ + k
  int count_ = 0;
  int next_ = 0;
  std::uint64_t pushed_ = 0;
  bool bounds_held_ = true;
  std::vector<double> median_, bound_;
  std::vector<double> below_;              // values of each window below its bound
  std::vector<std::uint64_t> updated_at_;  // pushed_ at each window's last update()
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
