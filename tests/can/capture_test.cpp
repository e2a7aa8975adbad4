// The capture writer (what mo-sim --candump uses) against the reader: rows -> candump -L text
// -> CandumpReader -> CycleAssembler gives the same rows within each signal's resolution, and
// the same times exactly (to the microsecond the text carries).

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "momentum/can/candump.hpp"
#include "momentum/can/capture.hpp"
#include "momentum/can/codec.hpp"
#include "momentum/can/cycle.hpp"
#include "momentum/core/error.hpp"

namespace fs = std::filesystem;
using namespace momentum::can;

namespace {

TEST(Capture, RoundTripThroughCandumpText) {
  const Database db = Database::load((fs::path(MOMENTUM_TEST_DATA) / "can" / "formats" / "arm2.dbc").string());
  const auto sources = columns_from_signal_names(db);
  ASSERT_EQ(sources.size(), 8U);
  CaptureWriter writer(db, sources);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> angle(-3, 3), speed(-2, 2), current(-20, 20), torque(-250, 250);
  const int rows = 500;
  std::vector<std::vector<double>> sent;
  std::string text;
  for (int k = 0; k < rows; ++k) {
    std::vector<double> v(sources.size());
    for (std::size_t c = 0; c < sources.size(); ++c) {
      const std::string& name = sources[c].column;
      v[c] = name[0] == 'q' ? angle(rng) : name[0] == 'd' ? speed(rng) : name[0] == 'i' ? current(rng) : torque(rng);
    }
    const double t = 1700000000.0 + 0.008 * k;  // the paper's 125 Hz
    EXPECT_EQ(writer.write_cycle(t, v.data(), text), 6U);  // SYNC + 5 messages
    v.insert(v.begin(), t);
    sent.push_back(v);
  }
  EXPECT_EQ(writer.stats().saturated, 0U);
  EXPECT_EQ(writer.stats().frames, static_cast<std::uint64_t>(rows) * 6U);

  auto reader = CandumpReader::from_text(text);
  CycleAssembler cycles(db, sources, CycleOptions{});
  std::vector<std::vector<double>> got;
  Frame f;
  while (reader->next(f))
    for (std::size_t k = 0, n = cycles.add(f); k < n; ++k)
      got.emplace_back(cycles.row(k), cycles.row(k) + cycles.columns().size());
  if (cycles.finish()) got.emplace_back(cycles.row(), cycles.row() + cycles.columns().size());
  EXPECT_EQ(reader->stats().bad_lines, 0U);
  ASSERT_EQ(got.size(), sent.size());
  for (std::size_t r = 0; r < got.size(); ++r) {
    EXPECT_NEAR(got[r][0], sent[r][0], 1e-6) << "row " << r;  // the text carries microseconds
    for (std::size_t c = 0; c < sources.size(); ++c) {
      const Signal& s = sources[c].message->signals[static_cast<std::size_t>(sources[c].signal)];
      EXPECT_LE(std::abs(got[r][c + 1] - sent[r][c + 1]), resolution(s, sent[r][c + 1]) * (1 + 1e-9))
          << "row " << r << " " << sources[c].column;
    }
  }
  EXPECT_EQ(cycles.stats().complete_cycles, static_cast<std::uint64_t>(rows));
}

TEST(Capture, MultiplexedSignalsGetOneFramePerSelectorValue) {
  const Database db = Database::parse(
      "BO_ 400 Joints: 8 X\n SG_ Joint M : 0|8@1+ (1,0) [0|0] \"\" X\n"
      " SG_ Pos1 m1 : 8|32@1- (1E-006,0) [0|0] \"\" X\n SG_ Pos2 m2 : 8|32@1- (1E-006,0) [0|0] \"\" X\n",
      "mux.dbc");
  const auto sources = parse_column_map("q1 = Joints.Pos1\nq2 = Joints.Pos2\n", "m.map", db);
  CaptureOptions options;
  options.interface = "vcan0";
  options.frame_spacing = 0.0001;
  CaptureWriter writer(db, sources, options);
  std::string text;
  const double v[2] = {0.5, -1.25};
  ASSERT_EQ(writer.write_cycle(2.0, v, text), 3U);
  EXPECT_EQ(text,
            "(0000000002.000000) vcan0 080#\n"
            "(0000000002.000100) vcan0 190#0120A10700000000\n"
            "(0000000002.000200) vcan0 190#0230EDECFF000000\n");
  auto reader = CandumpReader::from_text(text);
  CycleAssembler cycles(db, sources, CycleOptions{});
  Frame f;
  std::size_t closed = 0;
  while (reader->next(f)) closed += cycles.add(f);
  ASSERT_EQ(closed, 1U);  // at its second selector value, when both signals were in
  EXPECT_FALSE(cycles.finish());
  EXPECT_DOUBLE_EQ(cycles.row()[1], 0.5);
  EXPECT_DOUBLE_EQ(cycles.row()[2], -1.25);
}

TEST(Capture, RejectsBadOptions) {
  const Database db = Database::parse("BO_ 1 M: 1 X\n SG_ q1 : 0|8@1+ (1,0) [0|0] \"\" X\n", "a.dbc");
  CaptureOptions options;
  options.interface = "can 0";
  EXPECT_THROW(CaptureWriter(db, columns_from_signal_names(db), options), momentum::Error);
  options.interface = "can0";
  options.frame_spacing = -1;
  std::string why;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_EQ(why, "the frame spacing must be 0 or more seconds");
}

}  // namespace
