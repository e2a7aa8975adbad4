// mo-dynfit's cost per sample: the UR5 reference motion (tests/data/ur5.traj.csv, 8 s at 1 kHz,
// repeated with time going on) streamed into a inertia::Identifier with mo-dynfit's defaults
// (K = 10 1/s, min speed 0.2 rad/s, torque held, 20 rows per time constant, the friction probe),
// items = samples. The velocity-noise copies run over a log's first 600 s only, so a day's
// cost per sample is that of the fit and its probe: they are left out here (draws 0). Arg:
// threads (1: the probe on the same thread; 2: on a second one, wall time). solve() is not
// timed (its cost does not grow with the log).
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include <Eigen/Core>

#include "momentum/inertia/identify.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/stream/reader.hpp"

namespace {

constexpr int kJoints = 6;

struct Motion {
  std::vector<double> t;
  std::vector<Eigen::VectorXd> q, dq, tau;
};

Motion load_motion() {
  auto in = momentum::stream::Reader::open(std::string(MOMENTUM_TEST_DATA) + "/ur5.traj.csv");
  Motion m;
  while (const double* row = in->next()) {
    m.t.push_back(row[in->require("t")]);
    Eigen::VectorXd q(kJoints), dq(kJoints), tau(kJoints);
    for (int j = 0; j < kJoints; ++j) {
      const std::string k = std::to_string(j + 1);
      q[j] = row[in->require("q" + k)];
      dq[j] = row[in->require("dq" + k)];
      tau[j] = row[in->require("tau_m" + k)];
    }
    m.q.push_back(q);
    m.dq.push_back(dq);
    m.tau.push_back(tau);
  }
  return m;
}

void BM_IdentifierPerSample(benchmark::State& state) {
  namespace mm = momentum::model;
  const mm::Model model = mm::build_model(mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/ur5.json"));
  const Motion m = load_motion();
  momentum::inertia::IdentifyOptions options;
  options.filter_gain = 10.0;
  options.min_speed = 0.2;
  options.torque_held = true;
  options.velocity_noise_draws = 0;
  options.threads = static_cast<int>(state.range(0));
  momentum::inertia::Identifier identifier(model, options);
  std::size_t k = 0;
  double offset = 0;
  for (auto _ : state) {
    identifier.add(m.t[k] + offset, m.q[k], m.dq[k], m.tau[k]);
    if (++k == m.t.size()) k = 0, offset += m.t.back() + 0.001;
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("6 joints, 1 kHz, fit + friction probe, " + std::to_string(options.threads) + " thread" +
                 (options.threads > 1 ? "s" : ""));
}
BENCHMARK(BM_IdentifierPerSample)->Arg(1)->Arg(2)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
