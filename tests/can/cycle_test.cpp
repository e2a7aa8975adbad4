// Cycle assembly: SYNC-delimited CANopen cycles become rows timed at their SYNC; a value that
// did not arrive is NaN and counted (or held for at most --hold cycles); boundaries by
// message and by fixed period; column maps and their errors.

#include <gtest/gtest.h>

#include <cmath>

#include "momentum/can/codec.hpp"
#include "momentum/can/cycle.hpp"
#include "momentum/core/error.hpp"

using namespace momentum::can;

namespace {

const char* kArm = R"(
BO_ 385 Joint1_TPDO: 8 Drive1
 SG_ Position : 0|32@1- (0.0001,0) [0|0] "rad" Host
 SG_ Velocity : 32|32@1- (0.0001,0) [0|0] "rad/s" Host
BO_ 386 Joint2_TPDO: 8 Drive2
 SG_ q2 : 0|32@1- (0.0001,0) [0|0] "rad" Host
 SG_ dq2 : 32|32@1- (0.0001,0) [0|0] "rad/s" Host
BO_ 641 Joint1_Current: 2 Drive1
 SG_ i1 : 0|16@1- (0.001,0) [0|0] "A" Host
)";

Frame message_frame(const Database& db, const char* name, std::vector<double> values, double t) {
  const Message& m = *db.find_name(name);
  Frame f;
  clear(f);
  encode(m, values.data(), f);
  f.time_ns = static_cast<std::int64_t>(std::llround(t * 1e9));
  f.has_time = true;
  return f;
}

Frame sync_frame(double t) {
  Frame f;
  clear(f);
  f.id = 0x080;
  f.time_ns = static_cast<std::int64_t>(std::llround(t * 1e9));
  f.has_time = true;
  return f;
}

std::vector<ColumnSource> arm_map(const Database& db) {
  return parse_column_map(
      "# joint 1 from its TPDO\n"
      "q1 = Joint1_TPDO.Position\n"
      "dq1 = Joint1_TPDO.Velocity\n"
      "\n"
      "q2=Joint2_TPDO.q2\n",
      "arm.map", db);
}

TEST(ColumnMap, ParsesAndNamesErrors) {
  const Database db = Database::parse(kArm, "arm.dbc");
  const auto map = arm_map(db);
  ASSERT_EQ(map.size(), 3U);
  EXPECT_EQ(map[0].column, "q1");
  EXPECT_EQ(map[0].message->name, "Joint1_TPDO");
  EXPECT_EQ(map[0].message->signals[static_cast<std::size_t>(map[0].signal)].name, "Position");
  auto error = [&](const char* text) {
    try {
      parse_column_map(text, "m.map", db);
    } catch (const momentum::Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(error("\nq1 Joint1_TPDO.Position\n"), "m.map:2: expected 'column = Message.Signal'");
  EXPECT_EQ(error("q1 = Nope.Position\n"), "m.map:1: no message 'Nope' in the dbc");
  EXPECT_EQ(error("q1 = Joint1_TPDO.Nope\n"), "m.map:1: message Joint1_TPDO has no signal 'Nope'");
  EXPECT_EQ(error("q1 = Joint1_TPDO.Position\nq1 = Joint1_TPDO.Velocity\n"), "m.map:2: column 'q1' mapped twice");
  EXPECT_EQ(error("t = Joint1_TPDO.Position\n"), "m.map:1: column 't' is the cycle time and cannot be mapped");
  EXPECT_EQ(error("q 1 = Joint1_TPDO.Position\n"), "m.map:1: bad column name 'q 1'");
  EXPECT_EQ(error("# nothing\n"), "m.map: no column mapped");
}

TEST(ColumnMap, SignalsNamedLikeColumns) {
  const Database db = Database::parse(kArm, "arm.dbc");
  const auto cols = columns_from_signal_names(db);
  std::vector<std::string> names;
  for (const auto& c : cols) names.push_back(c.column);
  EXPECT_EQ(names, (std::vector<std::string>{"q2", "dq2", "i1"}));
}

TEST(Cycles, SyncCyclesWithMissingValues) {
  const Database db = Database::parse(kArm, "arm.dbc");
  CycleAssembler cycles(db, arm_map(db), CycleOptions{});
  EXPECT_EQ(cycles.columns(), (std::vector<std::string>{"t", "q1", "dq1", "q2"}));
  std::vector<std::vector<double>> rows;
  auto feed = [&](const Frame& f) {
    if (cycles.add(f)) rows.emplace_back(cycles.row(), cycles.row() + 4);
  };
  feed(message_frame(db, "Joint1_TPDO", {9, 9}, 0.0005));  // before the first SYNC: dropped
  feed(sync_frame(0.001));
  feed(message_frame(db, "Joint1_TPDO", {0.5, -0.25}, 0.00115));
  feed(message_frame(db, "Joint2_TPDO", {1.25, 0}, 0.0012));
  feed(sync_frame(0.002));
  feed(message_frame(db, "Joint1_TPDO", {0.5001, -0.2}, 0.00215));  // Joint2 lost
  feed(sync_frame(0.003));
  feed(message_frame(db, "Joint2_TPDO", {1.3, 0}, 0.0032));
  Frame unknown = sync_frame(0.0033);
  unknown.id = 0x700;
  feed(unknown);
  if (cycles.finish()) rows.emplace_back(cycles.row(), cycles.row() + 4);
  ASSERT_EQ(rows.size(), 3U);
  EXPECT_DOUBLE_EQ(rows[0][0], 0.001);
  EXPECT_DOUBLE_EQ(rows[0][1], 0.5);
  EXPECT_DOUBLE_EQ(rows[0][2], -0.25);
  EXPECT_DOUBLE_EQ(rows[0][3], 1.25);
  EXPECT_DOUBLE_EQ(rows[1][1], 0.5001);
  EXPECT_TRUE(std::isnan(rows[1][3]));
  EXPECT_TRUE(std::isnan(rows[2][1]));
  EXPECT_DOUBLE_EQ(rows[2][3], 1.3);
  const CycleStats& s = cycles.stats();
  EXPECT_EQ(s.complete_cycles, 1U);
  EXPECT_EQ(s.incomplete_cycles, 2U);
  EXPECT_EQ(s.missing_values, 3U);
  EXPECT_EQ(s.sync_frames, 3U);
  EXPECT_EQ(s.unknown_ids, 1U);
  EXPECT_EQ(s.before_first_cycle, 1U);
  EXPECT_EQ(s.decoded, 5U);
}

// Live, a cycle's row goes out with its last mapped signal, not one period later at the next
// SYNC (issue 27: 8 ms late at 125 Hz); a cycle that misses a signal still ends at its SYNC.
TEST(Cycles, RowGoesOutWithTheCyclesLastSignal) {
  const Database db = Database::parse(kArm, "arm.dbc");
  CycleAssembler cycles(db, arm_map(db), CycleOptions{});
  EXPECT_EQ(cycles.add(sync_frame(0.008)), 0U);
  EXPECT_EQ(cycles.add(message_frame(db, "Joint1_TPDO", {0.5, -0.25}, 0.0081)), 0U);  // q2 still missing
  ASSERT_EQ(cycles.add(message_frame(db, "Joint2_TPDO", {1.25, 0}, 0.0082)), 1U);     // every signal in
  EXPECT_DOUBLE_EQ(cycles.row()[0], 0.008);  // timed at its SYNC as before
  EXPECT_DOUBLE_EQ(cycles.row()[1], 0.5);
  EXPECT_DOUBLE_EQ(cycles.row()[3], 1.25);
  // A second value in the same cycle comes too late for its row: counted, not used, and not
  // carried into the next cycle.
  EXPECT_EQ(cycles.add(message_frame(db, "Joint2_TPDO", {7, 0}, 0.0083)), 0U);
  EXPECT_EQ(cycles.stats().repeated_values, 1U);  // q2 (dq2 is not mapped)
  EXPECT_EQ(cycles.add(sync_frame(0.016)), 0U);  // the cycle's row is out: nothing to close
  EXPECT_EQ(cycles.add(message_frame(db, "Joint1_TPDO", {0.6, -0.2}, 0.0161)), 0U);
  // Joint2 lost in this cycle: the fallback, the next SYNC closes it with q2 NaN.
  ASSERT_EQ(cycles.add(sync_frame(0.024)), 1U);
  EXPECT_DOUBLE_EQ(cycles.row()[0], 0.016);
  EXPECT_DOUBLE_EQ(cycles.row()[1], 0.6);
  EXPECT_TRUE(std::isnan(cycles.row()[3]));
  EXPECT_FALSE(cycles.finish());  // the cycle opened at 0.024 holds no value
  EXPECT_EQ(cycles.stats().complete_cycles, 1U);
  EXPECT_EQ(cycles.stats().incomplete_cycles, 1U);
  EXPECT_EQ(cycles.stats().missing_values, 1U);
}

TEST(Cycles, HoldReusesAtMostNCycles) {
  const Database db = Database::parse(kArm, "arm.dbc");
  CycleOptions options;
  options.hold = 2;
  CycleAssembler cycles(db, arm_map(db), options);
  std::vector<double> q2;
  double t = 0;
  auto sync = [&] {
    if (cycles.add(sync_frame(t += 0.001))) q2.push_back(cycles.row()[3]);
  };
  sync();
  cycles.add(message_frame(db, "Joint2_TPDO", {2.0, 0}, t + 1e-4));
  for (int k = 0; k < 4; ++k) sync();  // q2 never arrives again
  cycles.add(message_frame(db, "Joint2_TPDO", {3.0, 0}, t + 1e-4));
  sync();
  ASSERT_EQ(q2.size(), 5U);
  EXPECT_EQ(q2[0], 2.0);
  EXPECT_EQ(q2[1], 2.0);  // held 1
  EXPECT_EQ(q2[2], 2.0);  // held 2
  EXPECT_TRUE(std::isnan(q2[3]));  // a third cycle is too many
  EXPECT_EQ(q2[4], 3.0);
  EXPECT_EQ(cycles.stats().held_values, 2U);
  EXPECT_EQ(cycles.stats().missing_values, 5U * 2U + 1U);  // q1, dq1 never came; q2 once
}

TEST(Cycles, MessageBoundary) {
  const Database db = Database::parse(kArm, "arm.dbc");
  CycleOptions options;
  options.boundary = CycleBoundary::message;
  options.message_key = 385;
  CycleAssembler cycles(db, arm_map(db), options);
  int rows = 0;
  rows += cycles.add(message_frame(db, "Joint1_TPDO", {1, 1}, 0.010));
  rows += cycles.add(message_frame(db, "Joint2_TPDO", {2, 0}, 0.011));
  rows += cycles.add(message_frame(db, "Joint1_TPDO", {3, 1}, 0.020));
  ASSERT_EQ(rows, 1);
  EXPECT_DOUBLE_EQ(cycles.row()[0], 0.010);
  EXPECT_DOUBLE_EQ(cycles.row()[1], 1);
  EXPECT_DOUBLE_EQ(cycles.row()[3], 2);
  ASSERT_TRUE(cycles.finish());
  EXPECT_DOUBLE_EQ(cycles.row()[0], 0.020);
  EXPECT_DOUBLE_EQ(cycles.row()[1], 3);
}

// A boundary message that closes a cycle still waiting for a signal, and completes its own
// cycle at once, gives two rows from one frame, in order.
TEST(Cycles, OneFrameCanCloseTwoCycles) {
  const Database db = Database::parse(kArm, "arm.dbc");
  CycleOptions options;
  options.boundary = CycleBoundary::message;
  options.message_key = 386;  // Joint2_TPDO
  CycleAssembler cycles(db, parse_column_map("q2 = Joint2_TPDO.q2\ndq2 = Joint2_TPDO.dq2\n", "m", db), options);
  Frame cut = message_frame(db, "Joint2_TPDO", {1, 0.5}, 0.010);
  cut.len = 4;  // q2 only: dq2 is missing from this cycle
  EXPECT_EQ(cycles.add(cut), 0U);
  ASSERT_EQ(cycles.add(message_frame(db, "Joint2_TPDO", {2, 0.25}, 0.020)), 2U);
  EXPECT_DOUBLE_EQ(cycles.row(0)[0], 0.010);
  EXPECT_DOUBLE_EQ(cycles.row(0)[1], 1);
  EXPECT_TRUE(std::isnan(cycles.row(0)[2]));
  EXPECT_DOUBLE_EQ(cycles.row(1)[0], 0.020);
  EXPECT_DOUBLE_EQ(cycles.row(1)[2], 0.25);
  EXPECT_EQ(cycles.add(message_frame(db, "Joint2_TPDO", {3, 0.125}, 0.030)), 1U);  // complete at once
  EXPECT_FALSE(cycles.finish());  // nothing left open
  EXPECT_EQ(cycles.stats().complete_cycles, 2U);
  EXPECT_EQ(cycles.stats().incomplete_cycles, 1U);
  EXPECT_EQ(cycles.stats().short_frames, 1U);

  // The same with fixed periods: the frame of a new period closes the one before, and its own.
  options.boundary = CycleBoundary::period;
  options.period = 0.008;
  CycleAssembler periods(db, parse_column_map("q2 = Joint2_TPDO.q2\ndq2 = Joint2_TPDO.dq2\n", "m", db), options);
  EXPECT_EQ(periods.add(cut), 0U);
  ASSERT_EQ(periods.add(message_frame(db, "Joint2_TPDO", {2, 0.25}, 0.019)), 2U);
  EXPECT_DOUBLE_EQ(periods.row(0)[0], 0.010);
  EXPECT_DOUBLE_EQ(periods.row(1)[0], 0.018);
  // A second frame in the same period comes after its row: counted, no row, no empty period.
  EXPECT_EQ(periods.add(message_frame(db, "Joint2_TPDO", {9, 9}, 0.020)), 0U);
  EXPECT_EQ(periods.add(message_frame(db, "Joint2_TPDO", {4, 0.5}, 0.027)), 1U);
  EXPECT_DOUBLE_EQ(periods.row(0)[0], 0.026);
  EXPECT_DOUBLE_EQ(periods.row(0)[1], 4);
  EXPECT_EQ(periods.stats().repeated_values, 2U);
  EXPECT_EQ(periods.stats().empty_periods, 0U);
}

TEST(Cycles, FixedPeriod) {
  const Database db = Database::parse(kArm, "arm.dbc");
  CycleOptions options;
  options.boundary = CycleBoundary::period;
  options.period = 0.008;
  CycleAssembler cycles(db, arm_map(db), options);
  std::vector<double> t;
  auto feed = [&](const Frame& f) {
    if (cycles.add(f)) t.push_back(cycles.row()[0]);
  };
  feed(message_frame(db, "Joint1_TPDO", {1, 1}, 100.000));
  feed(message_frame(db, "Joint2_TPDO", {1, 1}, 100.007));
  feed(message_frame(db, "Joint1_TPDO", {1, 1}, 100.009));
  feed(message_frame(db, "Joint1_TPDO", {1, 1}, 100.041));  // periods 2, 3, 4 empty
  if (cycles.finish()) t.push_back(cycles.row()[0]);
  ASSERT_EQ(t.size(), 3U);
  EXPECT_DOUBLE_EQ(t[0], 100.000);
  EXPECT_DOUBLE_EQ(t[1], 100.008);
  EXPECT_DOUBLE_EQ(t[2], 100.040);
  EXPECT_EQ(cycles.stats().empty_periods, 3U);
  Frame untimed = sync_frame(0);
  untimed.has_time = false;
  EXPECT_THROW(cycles.add(untimed), momentum::Error);
}

TEST(Cycles, InvalidOptions) {
  CycleOptions options;
  std::string why;
  options.boundary = CycleBoundary::period;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_EQ(why, "the cycle period must be 1e-06 to 1e+06 s, not 0");
  // 1e10 s is 1e19 ns, beyond 64 bits: it once rounded to a 1 ns period, one row per frame.
  options.period = 1e10;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_EQ(why, "the cycle period must be 1e-06 to 1e+06 s, not 1e+10");
  options.period = NAN;
  EXPECT_FALSE(options.IsValid(&why));
  options.period = 1e-7;  // finer than candump's microseconds
  EXPECT_FALSE(options.IsValid(&why));
  options.period = kMaxPeriod;
  EXPECT_TRUE(options.IsValid(&why));
  options.period = 0.001;
  options.hold = -1;
  EXPECT_FALSE(options.IsValid(&why));
  options.hold = 0;
  EXPECT_TRUE(options.IsValid(&why));
}

}  // namespace
