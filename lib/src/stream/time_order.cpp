#include "momentum/stream/time_order.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "momentum/core/number.hpp"

namespace momentum::stream {
namespace {

using core::exact;

bool same(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

}  // namespace

std::string_view time_fault_name(TimeFault fault) {
  switch (fault) {
    case TimeFault::duplicate: return "duplicate row";
    case TimeFault::not_finite: return "time is not finite";
    case TimeFault::out_of_order: return "time out of order";
    case TimeFault::repeated_time: return "repeated time";
  }
  return "time out of order";
}

TimeOrder::TimeOrder(std::size_t width, std::size_t time_column, Dropped dropped)
    : width_(width), time_(time_column), dropped_(std::move(dropped)), previous_(width) {
  current_.values.resize(width);
}

TimeOrder::Row TimeOrder::take(const double* row, std::uint64_t position) {
  Row slot;
  if (!spare_.empty()) {
    slot = std::move(spare_.back());
    spare_.pop_back();
  }
  slot.values.assign(row, row + width_);
  slot.position = position;
  slot.mark = TimeMark::none;
  return slot;
}

void TimeOrder::recycle(Row&& row) {
  if (spare_.size() < 4 && row.values.capacity() >= width_) spare_.push_back(std::move(row));
}

bool TimeOrder::fits(double after, double t) const {
  return t > after && (median_dt_ <= 0 || t - after <= kStepFactor * median_dt_);
}

void TimeOrder::keep(Row&& row) {
  const double t = time(row);
  if (!have_last_) {
    row.mark = TimeMark::none;
  } else if (t <= last_t_) {
    row.mark = TimeMark::clock_step;
    ++summary_.clock_steps;
  } else {
    const double dt = t - last_t_;
    row.mark = median_dt_ > 0 && dt > kStepFactor * median_dt_ ? TimeMark::gap : TimeMark::none;
    if (row.mark == TimeMark::gap) ++summary_.gaps;
    median_dt_ = step_median_.push(dt);
  }
  have_last_ = true;
  last_t_ = t;
  ++summary_.kept;
  ready_.push_back(std::move(row));
}

void TimeOrder::drop(Row&& row, TimeFault fault, const std::string& detail) {
  if (fault == TimeFault::out_of_order || fault == TimeFault::repeated_time) ++summary_.out_of_order;
  if (dropped_) dropped_(row.position, fault, detail);
  recycle(std::move(row));
}

void TimeOrder::drop_late(Row&& row, double after_t, double next_t) {
  const double t = time(row);
  // A time equal to a neighbour's is a repeated sample time, not a step back: say so, rather
  // than "t=5 before t=5".
  if (t == after_t || t == next_t) {
    drop(std::move(row), TimeFault::repeated_time, "t=" + exact(t));
    return;
  }
  std::string detail = "t=" + exact(t);
  if (!std::isnan(after_t)) detail += " after t=" + exact(after_t);
  if (std::isfinite(next_t)) detail += (!std::isnan(after_t) ? ", next t=" : " before t=") + exact(next_t);
  drop(std::move(row), TimeFault::out_of_order, detail);
}

void TimeOrder::drop_held(std::size_t index, double next_t) {
  drop_late(std::move(held_[index]), have_last_ ? last_t_ : NAN, next_t);
}

void TimeOrder::push(const double* row, std::uint64_t position) {
  if (have_previous_ && std::equal(row, row + width_, previous_.begin(), same)) {
    ++summary_.duplicates;
    if (dropped_) dropped_(position, TimeFault::duplicate, "t=" + exact(row[time_]));
    return;
  }
  std::copy(row, row + width_, previous_.begin());
  have_previous_ = true;
  if (!std::isfinite(row[time_])) {
    ++summary_.not_finite;
    if (dropped_) dropped_(position, TimeFault::not_finite, "t=" + exact(row[time_]));
    return;
  }
  held_.push_back(take(row, position));
  resolve(false);
}

bool TimeOrder::pass(const double* row) {
  if (!have_last_ || !idle()) return false;
  const double t = row[time_];
  // (A duplicate of the last kept row has its time: it does not fit.)
  if (!(std::isfinite(t) && fits(last_t_, t))) return false;
  if (have_previous_ && std::equal(row, row + width_, previous_.begin(), same)) return false;
  std::copy(row, row + width_, previous_.begin());
  have_previous_ = true;
  // keep(), for a row that fits: a regular step (fits() allows no more than a gap's length).
  median_dt_ = step_median_.push(t - last_t_);
  last_t_ = t;
  ++summary_.kept;
  return true;
}

void TimeOrder::finish() { resolve(true); }

const TimeOrder::Row* TimeOrder::pop() {
  if (ready_next_ >= ready_.size()) return nullptr;
  recycle(std::move(current_));
  current_ = std::move(ready_[ready_next_++]);
  if (ready_next_ == ready_.size()) {
    ready_.clear();
    ready_next_ = 0;
  }
  return &current_;
}

// Decides the first rows: true when it decided something (call again), false when it waits.
bool TimeOrder::resolve_start(bool at_end) {
  if (held_.size() < 3) {
    if (!at_end) return false;
    // A stream of one or two rows: keep them while time increases.
    for (auto& row : held_) {
      if (!have_last_ || time(row) > last_t_) keep(std::move(row));
      else drop_late(std::move(row), last_t_, NAN);
    }
    held_.clear();
    return false;
  }
  const double t1 = time(held_[0]), t2 = time(held_[1]), t3 = time(held_[2]);
  if (t1 < t2 && t2 < t3) {
    if (t2 - t1 > 10 * (t3 - t2)) {
      // The first step is much longer than the next: the first time is the odd one.
      drop_held(0, t2);
      held_.erase(held_.begin());
      return true;
    }
    keep(std::move(held_[0]));
    keep(std::move(held_[1]));
    held_.erase(held_.begin(), held_.begin() + 2);
    return true;
  }
  // Not increasing: drop the row that two others contradict. When the first and the third
  // agree (t1 < t3 < t2 or t3 <= t1 < t2 ...), the second is the odd one only when it lies far
  // beyond the third (a corrupt time); otherwise the third went back (a row written late).
  std::size_t odd = 0;
  if (t2 < t3) odd = 0;
  else if (t1 < t3) odd = t2 - t1 > 3 * (t3 - t1) ? 1 : 2;
  if (odd == 2) {
    drop_late(std::move(held_[2]), t2, NAN);
  } else {
    drop_held(odd, odd == 0 ? t2 : t3);
  }
  held_.erase(held_.begin() + static_cast<std::ptrdiff_t>(odd));
  return true;
}

void TimeOrder::resolve(bool at_end) {
  while (!held_.empty()) {
    if (!have_last_) {
      if (!resolve_start(at_end)) return;
      continue;
    }
    const std::size_t k = held_.size() - 1;  // rows held before the newest
    const double t = time(held_[k]);
    if (fits(last_t_, t)) {
      // The newest row continues the last kept one: held rows in between are late steps of the
      // same time line (kept), the others were wild (dropped).
      for (std::size_t i = 0; i < k; ++i) {
        const double ti = time(held_[i]);
        if (ti > last_t_ && ti < t) keep(std::move(held_[i]));
        else drop_held(i, t);
      }
      keep(std::move(held_[k]));
      held_.clear();
      return;
    }
    if (k >= 1 && fits(time(held_[k - 1]), t)) {
      // The newest row continues the one before it: that one starts a new time line (a gap
      // forward or a clock step back). Older held rows between the last kept row and it are
      // steps of the same time line after lost samples (kept), the others were wild.
      const double start = time(held_[k - 1]);
      for (std::size_t i = 0; i + 1 < k; ++i) {
        const double ti = time(held_[i]);
        if (ti > last_t_ && ti < start) keep(std::move(held_[i]));
        else drop_held(i, start);
      }
      keep(std::move(held_[k - 1]));
      keep(std::move(held_[k]));
      held_.clear();
      return;
    }
    if (!at_end && k < 2) return;  // wait for another row
    const double t1 = time(held_[0]);
    if (k == 2) {
      // The oldest held row lies between the last kept row and the newest one: a step of the
      // same time line (after lost samples, or a change of rate); keep it, and decide the
      // others against it. Otherwise it was wild.
      // When the next held row lies between the last kept row and the oldest one, the oldest
      // was written early (before it): drop the oldest instead.
      const double t2 = time(held_[1]);
      if (t1 > last_t_ && t1 < t && !(t2 > last_t_ && t2 < t1)) keep(std::move(held_[0]));
      else drop_held(0, t2);
    } else if (t1 > last_t_) {
      keep(std::move(held_[0]));  // end of input: nothing contradicts it
    } else {
      drop_held(0, k >= 1 ? time(held_[1]) : NAN);
    }
    held_.erase(held_.begin());
  }
}

}  // namespace momentum::stream
