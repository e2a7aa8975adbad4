// Cost per row of the detector and the calibrator, 6 joints, on noise with rare pulses and a
// joint that alternates motion and holds (so every motion state is exercised).
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "momentum/calibrate/calibration.hpp"
#include "momentum/detect/detector.hpp"

using namespace momentum::detect;
using namespace momentum::calibrate;

namespace {

constexpr std::size_t kJoints = 6;
constexpr int kRows = 1 << 16;

struct Data {
  std::vector<double> t, x, dq;  // row-major, kJoints per row
};

const Data& data() {
  static const Data d = [] {
    Data d;
    std::mt19937_64 rng(1);
    std::normal_distribution<double> noise(0.0, 0.3);
    for (int k = 0; k < kRows; ++k) {
      d.t.push_back(k * 0.001);
      const bool hold = (k / 2000) % 2 == 1;
      for (std::size_t j = 0; j < kJoints; ++j) {
        double x = noise(rng);
        if (k % 5000 >= 1000 && k % 5000 < 1150) x += 4.0;  // a pulse every 5 s
        d.x.push_back(x);
        d.dq.push_back(hold && j == 0 ? 0.001 : 0.5);
      }
    }
    return d;
  }();
  return d;
}

Thresholds thresholds(bool states, bool envelope) {
  Thresholds t;
  t.rest_rule = RestRule{0.01, 0.2};
  for (std::size_t j = 0; j < kJoints; ++j) {
    JointThreshold J;
    J.moving = 2.0;
    J.band = 0.8;
    if (states) {
      J.slow = 2.5;
      J.rest = 1.0;
      J.rest_band = 0.5;
    }
    if (envelope) J.envelope = JointThreshold::Envelope{1.5, 0.5};
    t.joints.push_back(J);
  }
  return t;
}

void BM_DetectorStep(benchmark::State& state) {
  const Data& d = data();
  Detector detector(thresholds(state.range(0) != 0, state.range(1) != 0), {}, true);
  int k = 0;
  std::uint64_t events = 0;
  for (auto _ : state) {
    const auto rows = detector.step(d.t[k] + 100.0 * static_cast<double>(detector.rows() / kRows), &d.x[k * kJoints],
                                    &d.dq[k * kJoints]);
    events += rows.size();
    benchmark::DoNotOptimize(rows.data());
    if (++k == kRows) k = 0;
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["event_rows"] = static_cast<double>(events);
}
BENCHMARK(BM_DetectorStep)->ArgsProduct({{0, 1}, {0, 1}})->ArgNames({"states", "envelope"});

void BM_CalibratorAdd(benchmark::State& state) {
  const Data& d = data();
  CalibrationOptions o;
  o.envelope = state.range(0) != 0;
  Calibrator calibrator(Signal::mu, kJoints, o);
  calibrator.begin_stream("bench", true);
  int k = 0;
  double t0 = 0;
  auto where = [] { return std::string("bench:1"); };
  for (auto _ : state) {
    calibrator.add(t0 + d.t[k], &d.x[k * kJoints], &d.dq[k * kJoints], where);
    if (++k == kRows) k = 0, t0 += 100;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_CalibratorAdd)->Arg(0)->Arg(1)->ArgName("envelope");

void BM_FormatEvent(benchmark::State& state) {
  Event e;
  e.id = 12;
  e.t_onset_estimate = 7.104;
  e.t_detect = 7.184;
  e.link = 3;
  e.joints = {1, 2, 3};
  e.peaks = {8.31, 9.12, 0.52, 1.5, 2.25, 0.125};
  for (auto _ : state) benchmark::DoNotOptimize(format_event(e));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_FormatEvent);

}  // namespace

BENCHMARK_MAIN();
