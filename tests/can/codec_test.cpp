// The encoder against the decoder: decode(encode(x)) = x within each signal's resolution, for
// every signal of every reference DBC (Intel and Motorola, signed, 64-bit, floats,
// multiplexed), and every reference frame re-encoded from its decoded values decodes to the
// same raw bits.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <vector>

#include "momentum/can/candump.hpp"
#include "momentum/can/codec.hpp"
#include "momentum/can/dbc.hpp"

namespace fs = std::filesystem;
using namespace momentum::can;

namespace {

std::vector<std::string> dbc_names() {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(fs::path(MOMENTUM_TEST_DATA) / "can"))
    if (entry.path().extension() == ".dbc") names.push_back(entry.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

class Codec : public ::testing::TestWithParam<std::string> {};

TEST_P(Codec, ReferenceFramesSurviveReencoding) {
  const fs::path dir = fs::path(MOMENTUM_TEST_DATA) / "can";
  const Database db = Database::load((dir / (GetParam() + ".dbc")).string());
  auto reader = CandumpReader::open((dir / (GetParam() + ".log")).string());
  Frame frame, again;
  std::vector<SignalValue> first(256), second(256);
  std::size_t frames = 0;
  while (reader->next(frame)) {
    const Message* m = db.find(frame.key());
    ASSERT_NE(m, nullptr);
    const std::size_t n = decode(*m, frame, first.data());
    std::vector<double> values(m->signals.size(), 0.0);
    for (std::size_t k = 0; k < n; ++k) values[first[k].index] = first[k].value;
    const EncodeSummary summary = encode(*m, values.data(), again);
    EXPECT_EQ(summary.signals_written, n);
    EXPECT_EQ(again.key(), frame.key());
    const std::size_t n2 = decode(*m, again, second.data());
    ASSERT_EQ(n2, n) << reader->where();
    for (std::size_t k = 0; k < n; ++k) {
      EXPECT_EQ(second[k].index, first[k].index);
      // Exact while a double carries the integer; 64-bit raws beyond 2^53 come back to the
      // double's precision (the physical value is a double).
      if (std::abs(first[k].value) < 0x1p53) {
        EXPECT_EQ(second[k].bits, first[k].bits) << reader->where() << " " << m->signals[first[k].index].name;
      } else {
        EXPECT_EQ(second[k].value, first[k].value) << reader->where() << " " << m->signals[first[k].index].name;
      }
    }
    ++frames;
  }
  EXPECT_GT(frames, 0U);
}

TEST_P(Codec, DecodeOfEncodeWithinResolution) {
  const Database db = Database::load((fs::path(MOMENTUM_TEST_DATA) / "can" / (GetParam() + ".dbc")).string());
  std::mt19937_64 rng(20240611);
  Frame frame;
  std::vector<SignalValue> out(256);
  std::size_t checked = 0;
  for (const Message& m : db.messages()) {
    for (int trial = 0; trial < 200; ++trial) {
      // A random raw value per signal, turned into a physical value off the grid by up to
      // 0.49 steps; multiplexers take raw values their children are selected by.
      std::vector<double> x(m.signals.size());
      for (std::size_t i = 0; i < m.signals.size(); ++i) {
        const Signal& s = m.signals[i];
        if (s.value_type == ValueType::float32) {
          x[i] = static_cast<double>(std::uniform_real_distribution<float>(-1e6f, 1e6f)(rng)) * s.factor + s.offset;
          continue;
        }
        if (s.value_type == ValueType::float64) {
          x[i] = std::uniform_real_distribution<double>(-1e12, 1e12)(rng) * s.factor + s.offset;
          continue;
        }
        std::uint64_t bits = rng() & s.extraction.mask;
        if (s.is_multiplexer) {
          // Pick a value some child selects, so multiplexed signals are exercised.
          std::vector<std::uint64_t> choices;
          for (const Signal& c : m.signals)
            if (c.mux_parent == static_cast<int>(i))
              for (auto [lo, hi] : c.mux_ranges) choices.push_back(lo + rng() % (hi - lo + 1));
          if (!choices.empty()) bits = choices[rng() % choices.size()];
        }
        // Keep away from the extreme raw values for 64-bit fields: a double of the form
        // raw*factor+offset near 2^63 or 2^64 may round outside the field.
        if (s.length >= 53 && !s.integer_scaling) bits &= (std::uint64_t{1} << 50) - 1;
        const double raw = s.is_signed ? static_cast<double>(raw_signed(s, bits)) : static_cast<double>(bits);
        const bool small = std::abs(raw) < 1e15;
        const double jitter = small && !s.is_multiplexer ? std::uniform_real_distribution<double>(-0.49, 0.49)(rng) : 0.0;
        x[i] = (raw + jitter) * s.factor + s.offset;
      }
      encode(m, x.data(), frame);
      const std::size_t n = decode(m, frame, out.data());
      for (std::size_t k = 0; k < n; ++k) {
        const Signal& s = m.signals[out[k].index];
        const double want = x[out[k].index];
        const double got = out[k].value;
        // Half a step, plus the rounding of the double arithmetic on large values.
        const double tolerance = resolution(s, want) * (1 + 1e-9) + std::abs(want) * 1e-15;
        EXPECT_LE(std::abs(got - want), tolerance) << m.name << "." << s.name << " x=" << want;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 100U);
}

INSTANTIATE_TEST_SUITE_P(Reference, Codec, ::testing::ValuesIn(dbc_names()), [](const auto& info) { return info.param; });

TEST(Encode, SaturatesOutOfRange) {
  const Database db = Database::parse("BO_ 5 M: 8 X\n SG_ U : 0|8@1+ (0.5,10) [0|0] \"\" X\n SG_ S : 15|8@0- (1,0) [0|0] \"\" X\n", "s.dbc");
  const Message& m = *db.find(5);
  Frame f;
  const int u = m.find("U"), s = m.find("S");
  double values[2];
  values[u] = 1000;  // (1000-10)/0.5 = 1980 > 255
  values[s] = -1000;
  EncodeSummary summary = encode(m, values, f);
  EXPECT_EQ(summary.saturated, 2U);
  SignalValue out[2];
  ASSERT_EQ(decode(m, f, out), 2U);
  for (const SignalValue& v : out) {
    if (static_cast<int>(v.index) == u) {
      EXPECT_EQ(v.value, 255 * 0.5 + 10);
    } else {
      EXPECT_EQ(v.value, -128);
    }
  }
  values[u] = std::nan("");
  values[s] = 3;
  summary = encode(m, values, f);
  EXPECT_EQ(summary.saturated, 1U);
  EXPECT_EQ(f.data[0], 0);  // NaN -> raw 0
  EXPECT_EQ(f.data[1], 3);  // Motorola 15|8: byte 1
}

TEST(Encode, MultiplexedSignalsFollowTheirSelector) {
  const Database db = Database::parse(
      "BO_ 9 M: 8 X\n SG_ Sel M : 0|8@1+ (1,0) [0|0] \"\" X\n SG_ A m1 : 8|16@1- (0.1,0) [0|0] \"\" X\n"
      " SG_ B m2 : 8|16@0+ (1,0) [0|0] \"\" X\n",
      "m.dbc");
  const Message& m = *db.find(9);
  std::vector<double> values(3);
  values[static_cast<std::size_t>(m.find("Sel"))] = 2;
  values[static_cast<std::size_t>(m.find("A"))] = -12.3;
  values[static_cast<std::size_t>(m.find("B"))] = 0xABCD;
  Frame f;
  const EncodeSummary summary = encode(m, values.data(), f);
  EXPECT_EQ(summary.signals_written, 2U);
  EXPECT_EQ(f.data[0], 2);
  // Motorola 8|16: MSB is bit 0 of byte 1, so the 16 bits run from byte 1 bit 0 into byte 3.
  SignalValue out[3];
  ASSERT_EQ(decode(m, f, out), 2U);
  EXPECT_EQ(m.signals[out[1].index].name, "B");
  EXPECT_EQ(out[1].value, 0xABCD);
  values[static_cast<std::size_t>(m.find("Sel"))] = 1;
  encode(m, values.data(), f);
  ASSERT_EQ(decode(m, f, out), 2U);
  EXPECT_EQ(m.signals[out[1].index].name, "A");
  EXPECT_NEAR(out[1].value, -12.3, 0.05);
}

TEST(Encode, WideFieldsInFdFrames) {
  // 64-bit fields that straddle nine bytes need the second load in both byte orders.
  const Database db = Database::parse(
      "BO_ 7 W: 24 X\n SG_ I : 4|64@1+ (1,0) [0|0] \"\" X\n SG_ Mo : 83|64@0- (1,0) [0|0] \"\" X\n", "w.dbc");
  const Message& m = *db.find(7);
  const Signal& intel = m.signals[static_cast<std::size_t>(m.find("I"))];
  const Signal& moto = m.signals[static_cast<std::size_t>(m.find("Mo"))];
  EXPECT_TRUE(intel.extraction.wide);
  EXPECT_TRUE(moto.extraction.wide);
  std::uint8_t data[kPayloadStorage] = {};
  insert_bits(intel, 0xFEDCBA9876543210ULL, data);
  insert_bits(moto, 0x0123456789ABCDEFULL, data);
  EXPECT_EQ(extract_bits(intel, data), 0xFEDCBA9876543210ULL);
  EXPECT_EQ(extract_bits(moto, data), 0x0123456789ABCDEFULL);
  // Intel 4|64: the low nibble of byte 0 is untouched, bits 4.. hold the value.
  EXPECT_EQ(data[0], 0x00);
  EXPECT_EQ(data[1], 0x21);
  EXPECT_EQ(data[8], 0x0F);  // top nibble 0xF of the value in the low half of byte 8
  // Motorola 83|64: MSB at bit 3 of byte 10 -> stream position 84; bytes 10..18.
  EXPECT_EQ(data[10], 0x00);
  EXPECT_EQ(data[11], 0x12);
  EXPECT_EQ(data[18], 0xF0);
}

}  // namespace
