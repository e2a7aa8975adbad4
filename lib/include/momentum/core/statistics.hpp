#pragma once
// Robust statistics shared by the fitters and the streams.

#include <algorithm>
#include <cstring>
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
// update() keeps a sorted copy of the window from one call to the next when it is called every
// few pushes: it moves into the copy each value pushed since in place of one that left (two
// binary searches and a block move of the values between them), where selecting the median afresh (an nth_element
// over N values) costs several times that (the signal check's windows of 128, refreshed every 8
// pushes, made 35% of mo-observe's instructions). After more pushes than a quarter of the
// window it selects afresh. The median is the same value, bit for bit, either way: the middle
// element of the sorted window, or the mean of the two middle ones. A NaN has no place in a
// sorted copy: with one in the window, update() selects with nth_element too.
template <int N>
class RunningMedian {
 public:
  static_assert(N > 0);
  void push(double value) {
    if (count_ == N) {
      const double old = window_[next_];
      if (old != old) {
        --nans_;
      } else if (synced_ && pushed_ < kIncremental) {
        // Pushed before the last update (at most N pushes ago): it is in the sorted copy.
        removed_[removed_count_++] = old;
      }
    }
    window_[next_] = value;
    if (value != value) ++nans_;
    next_ = (next_ + 1) % N;
    if (count_ < N) ++count_;
    if (++pushed_ > kIncremental) synced_ = false;
  }
  // The median of the window (for an even count, the mean of the two middle values); 0 before
  // the first push.
  double update() {
    if (count_ == 0) return median_;
    if (nans_ > 0 || (!synced_ && pushed_ > kIncremental)) return select();
    if (!synced_) {
      std::copy(window_, window_ + count_, sorted_);
      std::sort(sorted_, sorted_ + count_);
    } else {
      int size = count_ - pushed_ + removed_count_;  // as of the last update
      for (int k = 0; k < pushed_; ++k) {
        const double value = window_[(next_ - pushed_ + k + N) % N];
        if (k >= removed_count_) {
          // The window was still filling: one more value.
          double* at = std::upper_bound(sorted_, sorted_ + size, value);
          std::memmove(at + 1, at, static_cast<std::size_t>(sorted_ + size - at) * sizeof(double));
          *at = value;
          ++size;
          continue;
        }
        // One value leaves (the first equal to it: equal values are interchangeable) and one
        // enters: only the values between the two places move, by one.
        double* out = std::lower_bound(sorted_, sorted_ + size, removed_[k]);
        if (value >= *out) {
          double* in = std::upper_bound(out, sorted_ + size, value);
          std::memmove(out, out + 1, static_cast<std::size_t>(in - out - 1) * sizeof(double));
          in[-1] = value;
        } else {
          double* in = std::upper_bound(sorted_, out, value);
          std::memmove(in + 1, in, static_cast<std::size_t>(out - in) * sizeof(double));
          *in = value;
        }
      }
    }
    synced_ = true;
    pushed_ = 0;
    removed_count_ = 0;
    const int mid = count_ / 2;
    median_ = sorted_[mid];
    if (count_ % 2 == 0) median_ = 0.5 * (median_ + sorted_[mid - 1]);
    return median_;
  }
  double value() const { return median_; }  // as of the last update()
  bool full() const { return count_ == N; }

 private:
  // Pushes between updates up to which the sorted copy is kept (each costs a block move of
  // about N/3 values; selecting afresh costs about 30 N).
  static constexpr int kIncremental = N / 4 > 1 ? N / 4 : 1;

  double select() {
    double sorted[N];
    std::copy(window_, window_ + count_, sorted);
    const int mid = count_ / 2;
    std::nth_element(sorted, sorted + mid, sorted + count_);
    median_ = sorted[mid];
    if (count_ % 2 == 0) median_ = 0.5 * (median_ + *std::max_element(sorted, sorted + mid));
    synced_ = false;
    pushed_ = 0;
    removed_count_ = 0;
    return median_;
  }

  double window_[N] = {};
  int count_ = 0;
  int next_ = 0;
  double median_ = 0;
  // The sorted copy of the window as of the last update(), when synced_.
  double sorted_[N] = {};
  bool synced_ = false;
  int pushed_ = 0;  // pushes since the last update()
  double removed_[N] = {};  // values of the sorted copy that left the window since
  int removed_count_ = 0;
  int nans_ = 0;  // NaN values in the window
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
