// CAN capture throughput: candump lines parsed per second, parsed and decoded, and through the
// whole cycle assembly, on a synthetic 6-joint CANopen bus (SYNC + 2 TPDOs per joint, 1 kHz).
// items_per_second is frames per second. Aim: >= 2,000,000 frames/s parsed and decoded.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "momentum/can/candump.hpp"
#include "momentum/can/codec.hpp"
#include "momentum/can/cycle.hpp"
#include "momentum/can/dbc.hpp"

using namespace momentum::can;

namespace {

constexpr int kJoints = 6;

std::string arm_dbc() {
  std::string text;
  char line[256];
  for (int j = 1; j <= kJoints; ++j) {
    std::snprintf(line, sizeof line,
                  "BO_ %d Joint%d_TPDO1: 8 Drive%d\n SG_ q%d : 0|32@1- (1E-006,0) [-10|10] \"rad\" Host\n"
                  " SG_ dq%d : 32|32@1- (1E-005,0) [-10|10] \"rad/s\" Host\n",
                  0x180 + j, j, j, j, j);
    text += line;
    std::snprintf(line, sizeof line,
                  "BO_ %d Joint%d_TPDO2: 4 Drive%d\n SG_ i%d : 0|16@1- (0.001,0) [-30|30] \"A\" Host\n"
                  " SG_ tau_m%d : 23|16@0- (0.01,0) [-300|300] \"Nm\" Host\n",
                  0x280 + j, j, j, j, j);
    text += line;
  }
  return text;
}

// `cycles` cycles of candump -L text.
std::string capture(const Database& db, int cycles, bool default_format) {
  std::string text;
  text.reserve(static_cast<std::size_t>(cycles) * (1 + 2 * kJoints) * 50);
  Frame f;
  char buf[kMaxLogLine];
  std::vector<double> values(4);
  std::int64_t t = 1700000000LL * 1000000000LL;
  for (int k = 0; k < cycles; ++k, t += 1000000) {
    clear(f);
    f.id = 0x080;
    f.time_ns = t;
    auto emit = [&](const Frame& fr) {
      if (!default_format) {
        text.append(buf, format_log_line(fr, "can0", buf));
        return;
      }
      char line[128];
      int n = std::snprintf(line, sizeof line, " (%010lld.%06lld)  can0  %03X   [%d] ", static_cast<long long>(fr.time_ns / 1000000000),
                            static_cast<long long>(fr.time_ns % 1000000000 / 1000), fr.id, fr.len);
      for (int b = 0; b < fr.len; ++b) n += std::snprintf(line + n, sizeof line - static_cast<std::size_t>(n), " %02X", fr.data[b]);
      text.append(line, static_cast<std::size_t>(n));
      text += '\n';
    };
    emit(f);
    for (int j = 1; j <= kJoints; ++j) {
      for (int m = 0; m < 2; ++m) {
        const Message& msg = *db.find(static_cast<std::uint32_t>((m == 0 ? 0x180 : 0x280) + j));
        for (std::size_t s = 0; s < msg.signals.size(); ++s) values[s] = std::sin(0.001 * k + j + static_cast<double>(s));
        encode(msg, values.data(), f);
        f.time_ns = t + 50000 * (2 * j + m);
        emit(f);
      }
    }
  }
  return text;
}

struct Fixture {
  Database db = Database::parse(arm_dbc(), "arm.dbc");
  std::string log = capture(db, 20000, false);
  std::string plain = capture(db, 20000, true);
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

void BM_ParseLogLines(benchmark::State& state) {
  const std::string& text = fixture().log;
  Frame f;
  ParsedLine info;
  std::int64_t frames = 0;
  for (auto _ : state) {
    std::size_t at = 0;
    while (at < text.size()) {
      const std::size_t nl = text.find('\n', at);
      if (parse_candump_line(std::string_view(text).substr(at, nl - at), f, info) == LineKind::frame) ++frames;
      at = nl + 1;
    }
    benchmark::DoNotOptimize(f);
  }
  state.SetItemsProcessed(frames);
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(text.size()));
}
BENCHMARK(BM_ParseLogLines)->Unit(benchmark::kMillisecond);

void parse_and_decode(benchmark::State& state, const std::string& text) {
  const Database& db = fixture().db;
  Frame f;
  SignalValue values[8];
  std::int64_t frames = 0;
  double sink = 0;
  for (auto _ : state) {
    auto reader = CandumpReader::from_text(text);
    while (reader->next(f)) {
      ++frames;
      if (const Message* m = db.find(f.key())) {
        const std::size_t n = decode(*m, f, values);
        for (std::size_t k = 0; k < n; ++k) sink += values[k].value;
      }
    }
  }
  benchmark::DoNotOptimize(sink);
  state.SetItemsProcessed(frames);
}

void BM_ParseDecodeLog(benchmark::State& state) { parse_and_decode(state, fixture().log); }
BENCHMARK(BM_ParseDecodeLog)->Unit(benchmark::kMillisecond);

void BM_ParseDecodeDefaultFormat(benchmark::State& state) { parse_and_decode(state, fixture().plain); }
BENCHMARK(BM_ParseDecodeDefaultFormat)->Unit(benchmark::kMillisecond);

void BM_ParseDecodeCycles(benchmark::State& state) {
  const Database& db = fixture().db;
  Frame f;
  std::int64_t frames = 0, rows = 0;
  for (auto _ : state) {
    CycleAssembler cycles(db, columns_from_signal_names(db), CycleOptions{});
    auto reader = CandumpReader::from_text(fixture().log);
    while (reader->next(f)) {
      ++frames;
      rows += cycles.add(f);
    }
    rows += cycles.finish();
  }
  benchmark::DoNotOptimize(rows);
  state.SetItemsProcessed(frames);
}
BENCHMARK(BM_ParseDecodeCycles)->Unit(benchmark::kMillisecond);

void BM_DecodeOnly(benchmark::State& state) {
  const Database& db = fixture().db;
  std::vector<Frame> frames;
  auto reader = CandumpReader::from_text(fixture().log);
  Frame f;
  while (reader->next(f) && frames.size() < 13000) frames.push_back(f);
  SignalValue values[8];
  double sink = 0;
  for (auto _ : state) {
    for (const Frame& fr : frames) {
      if (const Message* m = db.find(fr.key())) {
        const std::size_t n = decode(*m, fr, values);
        for (std::size_t k = 0; k < n; ++k) sink += values[k].value;
      }
    }
  }
  benchmark::DoNotOptimize(sink);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * frames.size()));
}
BENCHMARK(BM_DecodeOnly)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
