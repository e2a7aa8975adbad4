#pragma once
// The one time-order policy of the suite: which rows of a stream keep their place in time.
//
// A row whose time does not fit its neighbours costs that row only: a corrupt time far in the
// future or the past, a NaN time, a repeated time or an exact duplicate row is dropped (and
// reported by the caller), and the rows after it go on as if it had not been there. A real
// clock step, where the stream continues consistently from the new time, is kept and marked,
// so that a tool whose state depends on time (the observer, the detector) starts again there.
//
// How: a row that follows the last kept row by more than 0 and at most 1.5 running-median
// steps is kept at once (no delay on a regular stream). Any other row is held, with at most
// one more after it, until a later row shows which time line goes on:
//   - the next row continues the last kept row: the held rows are wild and dropped, except
//     those that fall in between (a jittered or lost-sample step);
//   - the next row continues the newest held row: that row starts a new time line (a gap
//     forward, or a clock step back), the older held row is dropped;
//   - three rows increasing after the last kept one: a change of rate; the oldest is kept.
// At the start, the first three rows are compared with each other the same way, so a corrupt
// first time does not become the origin. Memory is constant: at most three rows are held.

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "momentum/core/statistics.hpp"

namespace momentum::stream {

// How a kept row relates to the kept row before it.
enum class TimeMark {
  none,        // a regular step (or the first row)
  gap,         // more than 1.5 median steps after the previous kept row: samples were lost, or
               // the clock stepped forward
  clock_step,  // at or before the previous kept row, and the stream continued from it: the
               // clock stepped back; time-dependent state must start again here
};

// Why a row was dropped.
enum class TimeFault {
  duplicate,     // equal to the previous row in every column
  not_finite,    // t is NaN or infinite
  out_of_order,   // t does not fit between its neighbours
  repeated_time,  // t equals a neighbour's time, the other values differ
};

// The text used in messages: "duplicate row", "time is not finite", "time out of order",
// "repeated time".
std::string_view time_fault_name(TimeFault fault);

class TimeOrder {
 public:
  // A kept row: `values` (width numbers), `position` as pushed, and its mark.
  struct Row {
    std::vector<double> values;
    std::uint64_t position = 0;
    TimeMark mark = TimeMark::none;
  };
  // Receives each dropped row: its position, the fault, its time and a short explanation
  // naming the neighbouring times ("t=1e+09 after t=5.6, next t=5.608").
  using Dropped = std::function<void(std::uint64_t position, TimeFault fault, const std::string& detail)>;

  struct Summary {
    std::uint64_t kept = 0;
    std::uint64_t duplicates = 0;
    std::uint64_t not_finite = 0;
    std::uint64_t out_of_order = 0;  // out_of_order and repeated_time faults
    std::uint64_t gaps = 0;         // kept rows marked gap
    std::uint64_t clock_steps = 0;  // kept rows marked clock_step
    std::uint64_t dropped() const { return duplicates + not_finite + out_of_order; }
  };

  // `width`: values per row (>= 1); `time_column` < width.
  TimeOrder(std::size_t width, std::size_t time_column, Dropped dropped);

  // Takes one row (copied). Kept rows become available through pop(), in input order.
  void push(const double* row, std::uint64_t position);
  // End of input: decides every held row.
  void finish();
  // The fast path of a stream in time order: when no row is held or waiting and `row` (width
  // values) is the next step of the time line (finite t, later than the last kept row by at
  // most 1.5 median steps, not a duplicate), takes it as push() would keep it, marked none,
  // without copying it, and returns true: the caller hands `row` itself on. Otherwise changes
  // nothing and returns false (the caller pushes it).
  bool pass(const double* row);
  // The next kept row, or nullptr when none is ready. The pointer stays valid until the next
  // call of push(), finish() or pop().
  const Row* pop();

  const Summary& summary() const { return summary_; }
  // Whether no row is held or waiting for pop(): the next row that fits is the next returned.
  bool idle() const { return held_.empty() && ready_next_ >= ready_.size(); }
  // Running median of the last 16 steps between kept rows, s; 0 before the first step.
  double median_dt() const { return median_dt_; }

 private:
  using Slots = std::vector<Row>;
  Row take(const double* row, std::uint64_t position);
  void recycle(Row&& row);
  void resolve(bool at_end);
  bool resolve_start(bool at_end);
  bool fits(double after, double t) const;
  // Keeps a row, marking it by its step from the last kept row.
  void keep(Row&& row);
  void drop(Row&& row, TimeFault fault, const std::string& detail);
  // Drops a row whose time does not fit: `after_t` the kept (or held) time before it, NaN for
  // none; `next_t` the time after it, NaN for none. A time equal to either is a repeated time.
  void drop_late(Row&& row, double after_t, double next_t);
  void drop_held(std::size_t index, double next_t);
  double time(const Row& row) const { return row.values[time_]; }

  std::size_t width_, time_;
  Dropped dropped_;
  Summary summary_;
  Slots held_;   // rows not decided yet, oldest first (at most 3)
  Slots ready_;  // kept rows not popped yet, oldest first
  std::size_t ready_next_ = 0;
  Row current_;  // the row pop() returned last
  Slots spare_;
  std::vector<double> previous_;  // the previous row as pushed
  bool have_previous_ = false;
  bool have_last_ = false;
  double last_t_ = 0;
  static constexpr double kStepFactor = 1.5;
  core::SortedRunningMedian<16> step_median_;
  double median_dt_ = 0;
};

}  // namespace momentum::stream
