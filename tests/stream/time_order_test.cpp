// The suite's time-order policy: a row whose time does not fit its neighbours costs that row
// only; a clock step is kept and marked; memory stays constant.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "momentum/core/error.hpp"
#include "momentum/stream/reader.hpp"
#include "momentum/stream/time_order.hpp"

namespace ms = momentum::stream;

namespace {

struct Outcome {
  std::vector<double> kept;                // times of the kept rows, in order
  std::vector<std::uint64_t> kept_at;      // their positions
  std::vector<ms::TimeMark> marks;
  std::vector<std::uint64_t> dropped;      // positions of the dropped rows
  std::vector<ms::TimeFault> faults;
  std::uint64_t most_held = 0;             // largest number of rows pushed but not yet decided
};

// Runs the policy over rows (t, i) at positions 1..n; `value` is a second column (the row's
// index unless given), so that rows with equal times are not exact duplicates.
Outcome run(const std::vector<double>& times) {
  Outcome out;
  ms::TimeOrder order(2, 0, [&](std::uint64_t position, ms::TimeFault fault, const std::string&) {
    out.dropped.push_back(position);
    out.faults.push_back(fault);
  });
  std::uint64_t pushed = 0;
  auto drain = [&] {
    while (const auto* row = order.pop()) {
      out.kept.push_back(row->values[0]);
      out.kept_at.push_back(row->position);
      out.marks.push_back(row->mark);
    }
  };
  for (std::size_t i = 0; i < times.size(); ++i) {
    const double row[2] = {times[i], static_cast<double>(i)};
    order.push(row, i + 1);
    ++pushed;
    drain();
    out.most_held = std::max<std::uint64_t>(out.most_held, pushed - out.kept.size() - out.dropped.size());
  }
  order.finish();
  drain();
  EXPECT_EQ(out.kept.size() + out.dropped.size(), times.size());
  return out;
}

std::vector<double> regular(std::size_t n, double dt = 0.008, double t0 = 0) {
  std::vector<double> t(n);
  for (std::size_t i = 0; i < n; ++i) t[i] = t0 + dt * static_cast<double>(i);
  return t;
}

std::size_t count_marks(const Outcome& o, ms::TimeMark mark) {
  return static_cast<std::size_t>(std::count(o.marks.begin(), o.marks.end(), mark));
}

}  // namespace

TEST(TimeOrder, ARegularStreamPassesAtOnceAndUnmarked) {
  const auto t = regular(1000);
  const Outcome o = run(t);
  EXPECT_EQ(o.kept, t);
  EXPECT_TRUE(o.dropped.empty());
  EXPECT_EQ(count_marks(o, ms::TimeMark::none), t.size());
  // Only the first rows wait (the start is decided on three rows); then no delay at all.
  EXPECT_LE(o.most_held, 2u);
}

TEST(TimeOrder, ALoneCorruptFutureTimeCostsOnlyItsRow) {
  for (double wild : {1e9, 5.608 + 0.02, -1.0, 0.0, 3.0}) {
    auto t = regular(1000);
    t[700] = wild;  // row 701
    const Outcome o = run(t);
    EXPECT_EQ(o.dropped, (std::vector<std::uint64_t>{701})) << wild;
    EXPECT_EQ(o.kept.size(), 999u) << wild;
    EXPECT_EQ(count_marks(o, ms::TimeMark::clock_step), 0u) << wild;
    EXPECT_LE(o.most_held, 2u);
  }
}

TEST(TimeOrder, TwoConsecutiveCorruptTimesCostTwoRows) {
  for (auto pair : {std::pair{1e9, 1e9}, std::pair{1e9, 2e9}, std::pair{2e9, 1e9}, std::pair{-5.0, 1e9},
                    std::pair{0.0, 0.0}}) {
    auto t = regular(2500);
    t[700] = pair.first;
    t[701] = pair.second;
    const Outcome o = run(t);
    EXPECT_EQ(o.dropped, (std::vector<std::uint64_t>{701, 702})) << pair.first << " " << pair.second;
    EXPECT_EQ(count_marks(o, ms::TimeMark::clock_step), 0u);
  }
}

TEST(TimeOrder, NaNAndInfiniteTimesAreDroppedAlone) {
  auto t = regular(100);
  t[10] = std::numeric_limits<double>::quiet_NaN();
  t[50] = std::numeric_limits<double>::infinity();
  const Outcome o = run(t);
  EXPECT_EQ(o.dropped, (std::vector<std::uint64_t>{11, 51}));
  EXPECT_EQ(o.faults, (std::vector<ms::TimeFault>{ms::TimeFault::not_finite, ms::TimeFault::not_finite}));
}

TEST(TimeOrder, AClockStepBackIsKeptAndMarked) {
  auto t = regular(1000, 0.008, 100);
  for (std::size_t i = 400; i < t.size(); ++i) t[i] -= 10;  // the host clock stepped back 10 s
  const Outcome o = run(t);
  EXPECT_TRUE(o.dropped.empty());
  EXPECT_EQ(o.kept, t);
  ASSERT_EQ(count_marks(o, ms::TimeMark::clock_step), 1u);
  EXPECT_EQ(o.marks[400], ms::TimeMark::clock_step);
}

TEST(TimeOrder, AClockStepForwardIsAGap) {
  auto t = regular(1000);
  for (std::size_t i = 400; i < t.size(); ++i) t[i] += 10;
  const Outcome o = run(t);
  EXPECT_TRUE(o.dropped.empty());
  EXPECT_EQ(o.kept, t);
  EXPECT_EQ(o.marks[400], ms::TimeMark::gap);
  EXPECT_EQ(count_marks(o, ms::TimeMark::gap), 1u);
}

TEST(TimeOrder, LostSamplesAreAGapAndCostNothing) {
  auto t = regular(100);
  t.erase(t.begin() + 40, t.begin() + 43);  // three samples lost
  const Outcome o = run(t);
  EXPECT_EQ(o.kept, t);
  EXPECT_EQ(o.marks[40], ms::TimeMark::gap);
}

TEST(TimeOrder, TwoLostSampleGapsInARowLoseNothing) {
  auto t = regular(100);
  t.erase(t.begin() + 41);  // one sample lost ...
  t.erase(t.begin() + 42);  // ... and the one after the next
  const Outcome o = run(t);
  EXPECT_TRUE(o.dropped.empty());
  EXPECT_EQ(o.kept, t);
}

TEST(TimeOrder, ARowWrittenEarlyAfterLostSamplesLosesOnlyItself) {
  // 5 is lost; 9 was written before 6 and 8 (8 is lost too).
  const Outcome o = run({0, 1, 2, 3, 4, 6, 9, 7, 10, 11, 12, 13});
  EXPECT_EQ(o.kept, (std::vector<double>{0, 1, 2, 3, 4, 6, 7, 10, 11, 12, 13}));
  EXPECT_EQ(o.dropped, (std::vector<std::uint64_t>{7}));
}

TEST(TimeOrder, ACorruptFirstTimeDoesNotBecomeTheOrigin) {
  for (double wild : {1e9, -1e9, 7.0}) {
    auto t = regular(200, 0.008, 1.0);
    t[0] = wild;
    const Outcome o = run(t);
    EXPECT_EQ(o.dropped, (std::vector<std::uint64_t>{1})) << wild;
    EXPECT_EQ(o.kept.front(), t[1]);
  }
  auto t = regular(200, 0.008, 1.0);
  t[1] = 1e9;  // the second row
  const Outcome o = run(t);
  EXPECT_LE(o.dropped.size(), 2u);
  EXPECT_EQ(o.kept.back(), t.back());
  EXPECT_GE(o.kept.size(), 198u);
}

TEST(TimeOrder, ARowWrittenEarlyLosesOnlyItself) {
  const Outcome o = run({1, 2, 3, 7, 4, 5, 6, 8, 9, 10, 11, 12});
  EXPECT_EQ(o.kept, (std::vector<double>{1, 2, 3, 4, 5, 6, 8, 9, 10, 11, 12}));
  EXPECT_EQ(o.dropped, (std::vector<std::uint64_t>{4}));
}

TEST(TimeOrder, ARepeatedTimeAndAnExactDuplicateAreDropped) {
  ms::TimeOrder order(2, 0, nullptr);
  std::vector<double> kept;
  const double rows[][2] = {{0, 0}, {1, 1}, {2, 2}, {2, 2}, {2, 5}, {3, 3}, {4, 4}};
  for (const auto& row : rows) {
    order.push(row, 0);
    while (const auto* r = order.pop()) kept.push_back(r->values[1]);
  }
  order.finish();
  while (const auto* r = order.pop()) kept.push_back(r->values[1]);
  EXPECT_EQ(kept, (std::vector<double>{0, 1, 2, 3, 4}));
  EXPECT_EQ(order.summary().duplicates, 1u);
  EXPECT_EQ(order.summary().out_of_order, 1u);
}

// A row whose time equals its neighbour's is a repeated time, said as such: it was once
// reported as "time out of order: t=5 before t=5". Both at the start (against the next row)
// and later (against the last kept row).
TEST(TimeOrder, ARepeatedTimeIsNamedAsSuch) {
  for (const auto& times : std::vector<std::vector<double>>{{5, 5, 6, 7, 8}, {3, 4, 5, 5, 6, 7}}) {
    std::vector<std::pair<ms::TimeFault, std::string>> drops;
    ms::TimeOrder order(2, 0, [&](std::uint64_t, ms::TimeFault fault, const std::string& detail) {
      drops.emplace_back(fault, detail);
    });
    for (std::size_t i = 0; i < times.size(); ++i) {
      const double row[2] = {times[i], static_cast<double>(i)};
      order.push(row, i + 1);
    }
    order.finish();
    ASSERT_EQ(drops.size(), 1u);
    EXPECT_EQ(drops[0].first, ms::TimeFault::repeated_time);
    EXPECT_EQ(drops[0].second, "t=5");
    EXPECT_EQ(ms::time_fault_name(drops[0].first), "repeated time");
    EXPECT_EQ(order.summary().out_of_order, 1u);  // counted with the rows out of order
  }
  // A time that only goes back is still out of order, with its neighbours.
  std::vector<std::string> details;
  ms::TimeOrder order(2, 0, [&](std::uint64_t, ms::TimeFault fault, const std::string& detail) {
    EXPECT_EQ(fault, ms::TimeFault::out_of_order);
    details.push_back(detail);
  });
  for (double t : {1.0, 2.0, 3.0, 4.0, 2.5, 5.0, 6.0}) {
    const double row[2] = {t, t};
    order.push(row, 0);
  }
  order.finish();
  EXPECT_EQ(details, (std::vector<std::string>{"t=2.5 after t=4, next t=5"}));
}

TEST(TimeOrder, AChangeOfRateLosesNoRow) {
  auto t = regular(300, 0.001);
  for (int i = 1; i <= 100; ++i) t.push_back(t.back() + 0.1);
  const Outcome o = run(t);
  EXPECT_TRUE(o.dropped.empty());
  EXPECT_EQ(o.kept, t);
  EXPECT_NEAR(0.1, [&] {
    ms::TimeOrder order(1, 0, nullptr);
    for (double x : t) order.push(&x, 0);
    return order.median_dt();
  }(), 1e-12);
}

TEST(TimeOrder, GarbageTimesHoldAtMostThreeRows) {
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> any(-1e6, 1e6);
  std::vector<double> t(20000);
  for (auto& x : t) x = any(random);
  const Outcome o = run(t);
  EXPECT_LE(o.most_held, 3u);
  // Times kept are each after the one before or a clock step.
  for (std::size_t i = 1; i < o.kept.size(); ++i)
    if (o.marks[i] != ms::TimeMark::clock_step) {
      EXPECT_GT(o.kept[i], o.kept[i - 1]);
    }
}

// pass() is push() for a row in time order, without the copy through the queue: over a stream
// with every kind of fault (exact duplicates, repeated times, corrupt and non-finite times, rows
// written early or late, lost samples, clock steps back and forward, jitter), taking the fast
// path wherever it is offered keeps and drops the same rows, at the same positions, with the
// same marks, faults and summary as pushing every row; and it is offered for most rows.
TEST(TimeOrder, TheFastPathKeepsAndDropsWhatPushDoes) {
  std::mt19937_64 random(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<std::pair<double, double>> rows;  // (t, value)
  double t = 100;
  for (int i = 0; i < 60000; ++i) {
    const double u = unit(random);
    double row_t = t;
    double value = static_cast<double>(i);
    if (u < 0.01 && !rows.empty()) {
      rows.push_back(rows.back());  // an exact duplicate
      continue;
    }
    if (u < 0.02 && !rows.empty()) {
      row_t = rows.back().first;  // a repeated time, other values
    } else if (u < 0.025) {
      row_t = 1e9 * unit(random);  // a corrupt time
    } else if (u < 0.03) {
      row_t = u < 0.0275 ? std::nan("") : std::numeric_limits<double>::infinity();
    } else if (u < 0.035) {
      row_t = t - 0.001 * (1 + 5 * unit(random));  // written late
    } else {
      if (u < 0.04) t += 0.001 * (2 + static_cast<int>(10 * unit(random)));  // lost samples
      else if (u < 0.042) t -= 0.5;                                           // clock back
      else if (u < 0.043) t += 2.0;                                           // clock forward
      t += 0.001 * (0.8 + 0.4 * unit(random));                                // jitter
      row_t = t;
    }
    rows.emplace_back(row_t, value);
  }
  struct Seen {
    std::vector<double> kept_values;
    std::vector<std::uint64_t> kept_at;
    std::vector<ms::TimeMark> marks;
    std::vector<std::uint64_t> dropped;
    std::vector<ms::TimeFault> faults;
    ms::TimeOrder::Summary summary;
    double median_dt = 0;
    std::size_t passed = 0;
  };
  auto run_rows = [&](bool fast) {
    Seen seen;
    ms::TimeOrder order(2, 0, [&](std::uint64_t position, ms::TimeFault fault, const std::string&) {
      seen.dropped.push_back(position);
      seen.faults.push_back(fault);
    });
    auto drain = [&] {
      while (const auto* row = order.pop()) {
        seen.kept_values.push_back(row->values[1]);
        seen.kept_at.push_back(row->position);
        seen.marks.push_back(row->mark);
      }
    };
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const double row[2] = {rows[i].first, rows[i].second};
      if (fast && order.pass(row)) {
        ++seen.passed;
        seen.kept_values.push_back(row[1]);
        seen.kept_at.push_back(i + 1);
        seen.marks.push_back(ms::TimeMark::none);
        continue;
      }
      order.push(row, i + 1);
      drain();
    }
    order.finish();
    drain();
    seen.summary = order.summary();
    seen.median_dt = order.median_dt();
    return seen;
  };
  const Seen slow = run_rows(false), fast = run_rows(true);
  EXPECT_EQ(fast.kept_values, slow.kept_values);
  EXPECT_EQ(fast.kept_at, slow.kept_at);
  EXPECT_EQ(fast.marks, slow.marks);
  EXPECT_EQ(fast.dropped, slow.dropped);
  EXPECT_EQ(fast.faults, slow.faults);
  EXPECT_EQ(fast.summary.kept, slow.summary.kept);
  EXPECT_EQ(fast.summary.duplicates, slow.summary.duplicates);
  EXPECT_EQ(fast.summary.not_finite, slow.summary.not_finite);
  EXPECT_EQ(fast.summary.out_of_order, slow.summary.out_of_order);
  EXPECT_EQ(fast.summary.gaps, slow.summary.gaps);
  EXPECT_EQ(fast.summary.clock_steps, slow.summary.clock_steps);
  EXPECT_EQ(fast.median_dt, slow.median_dt);
  // Every kind of fault occurred, and most rows took the fast path.
  EXPECT_GT(slow.summary.duplicates, 100u);
  EXPECT_GT(slow.summary.not_finite, 50u);
  EXPECT_GT(slow.summary.out_of_order, 100u);
  EXPECT_GT(slow.summary.gaps, 100u);
  EXPECT_GT(slow.summary.clock_steps, 50u);
  EXPECT_GT(fast.passed, rows.size() * 8 / 10);
}

TEST(TimeOrder, TheReaderAppliesItAndNamesTheLine) {
  const std::string path = ::testing::TempDir() + "/time_order_" + std::to_string(::getpid()) + ".csv";
  {
    std::ofstream out(path);
    out << "t,x\n";
    for (int i = 0; i < 20; ++i) out << (i == 7 ? 1e9 : 0.01 * i) << "," << i << "\n";
  }
  std::vector<std::string> warnings;
  auto previous = momentum::set_warning_sink([&](std::string_view m) { warnings.emplace_back(m); });
  auto in = ms::Reader::open(path);
  std::vector<std::string> where;
  while (in->next()) where.push_back(in->where());
  momentum::set_warning_sink(previous);
  EXPECT_EQ(where.size(), 19u);
  EXPECT_EQ(where[7], path + ":10");  // the row after the dropped one (line 9)
  EXPECT_EQ(in->rows_skipped(), 1u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], path + ":9: time out of order: t=1e+09 after t=0.06, next t=0.08: skipped");

  ms::ReaderOptions strict;
  strict.strict = true;
  auto again = ms::Reader::open(path, strict);
  EXPECT_THROW(while (again->next()) {}, momentum::Error);
  ms::ReaderOptions raw;
  raw.time_order = false;
  auto as_written = ms::Reader::open(path, raw);
  int rows = 0;
  while (as_written->next()) ++rows;
  EXPECT_EQ(rows, 20);
  std::remove(path.c_str());
}
