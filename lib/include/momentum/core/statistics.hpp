#pragma once
// Robust statistics shared by the fitters and the streams.

#include <algorithm>
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
// the jitter it is there to judge. push() records; update() recomputes (an nth_element over
// at most N values), so a caller on a hot path may refresh less often than it pushes.
template <int N>
class RunningMedian {
 public:
  static_assert(N > 0);
  void push(double value) {
    window_[next_] = value;
    next_ = (next_ + 1) % N;
    if (count_ < N) ++count_;
  }
  // The median of the window (for an even count, the mean of the two middle values); 0 before
  // the first push.
  double update() {
    if (count_ == 0) return median_;
    double sorted[N];
    std::copy(window_, window_ + count_, sorted);
    const int mid = count_ / 2;
    std::nth_element(sorted, sorted + mid, sorted + count_);
    median_ = sorted[mid];
    if (count_ % 2 == 0) median_ = 0.5 * (median_ + *std::max_element(sorted, sorted + mid));
    return median_;
  }
  double value() const { return median_; }  // as of the last update()
  bool full() const { return count_ == N; }

 private:
  double window_[N] = {};
  int count_ = 0;
  int next_ = 0;
  double median_ = 0;
};

// The same median of the last N values as RunningMedian (bit for bit: the same element, the same
// mean of the two middle ones), kept up to date on every push by moving the values of a sorted
// copy of the window instead of selecting from it: about N/2 moves a push where update() is an
// nth_element a call, for a caller that needs the median after every value (a stream's time
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
