// The observer's hot path piece by piece: filter coefficients, the disturbance filter (double and
// the Jet the fitter uses), LuGre steps, the model-free residual observer, the whole
// MomentumObserver and the signal check on the UR5 and Panda reference motions (items = rows).
// End-to-end throughput of mo-observe on a 1,000,000-row stream: scripts/bench-observe.sh.
#include <benchmark/benchmark.h>
#include <ceres/jet.h>

#include <cmath>
#include <string>
#include <vector>

#include "momentum/friction/friction.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/observer/filter.hpp"
#include "momentum/observer/observer.hpp"
#include "momentum/observer/signal_check.hpp"
#include "momentum/stream/reader.hpp"

namespace mo = momentum::observer;
namespace mf = momentum::friction;

namespace {

const mf::Parameters<double> kLugre = {98467.9088, 314.0483, 6.4865, 7.8322, 4.0033, 0.0978};

void BM_Discretize(benchmark::State& state) {
  const mo::Gains gains{50.0, state.range(0) == 0 ? 0.0 : (state.range(0) == 1 ? 5.0 : 50.0), 0.0};
  double dt = 0.001;
  for (auto _ : state) {
    benchmark::DoNotOptimize(mo::discretize(gains, dt));
    dt = dt == 0.001 ? 0.0010000001 : 0.001;  // defeat any caching
  }
  state.SetLabel(state.range(0) == 0 ? "first order" : state.range(0) == 1 ? "second order" : "repeated pole");
}
BENCHMARK(BM_Discretize)->Arg(0)->Arg(1)->Arg(2);

template <class T>
void BM_DisturbanceFilter(benchmark::State& state) {
  mo::DisturbanceFilter<T> filter(mo::Gains{50.0, 5.0, 0.0});
  T x = T(1.0);
  for (auto _ : state) {
    x = x * 0.999 + T(0.01);
    benchmark::DoNotOptimize(filter.step(x, 0.001));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_DisturbanceFilter<double>);
BENCHMARK(BM_DisturbanceFilter<ceres::Jet<double, 6>>);

template <class T>
void BM_LugreStep(benchmark::State& state) {
  const mf::LugreUpdate update = state.range(0) ? mf::LugreUpdate::semi_implicit : mf::LugreUpdate::exact;
  const mf::Parameters<T> p = kLugre.cast<T>();
  T z = T(0);
  int k = 0;
  for (auto _ : state) {
    const double w = 0.6 * std::sin(0.008 * ++k);
    benchmark::DoNotOptimize(mf::lugre_step(p, T(w), 0.008, update, z));
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(mf::update_name(update));
}
BENCHMARK(BM_LugreStep<double>)->Arg(0)->Arg(1);
BENCHMARK(BM_LugreStep<ceres::Jet<double, 6>>)->Arg(0)->Arg(1);

// The model-free observer for 6 joints, per row; range(0): 1 = with LuGre compensation.
void BM_ResidualObserver(benchmark::State& state) {
  const int n = 6;
  mf::FrictionModel friction;
  friction.joints.assign(n, kLugre);
  mo::ResidualObserver observer(std::vector<mo::Gains>(n, mo::Gains{50, 5, 0}),
                                state.range(0) ? &friction : nullptr);
  std::vector<double> p(n, 1.0), u(n, 2.0), dq(n, 0.3), r(n), tau_f(n), mu(n);
  int k = 0;
  for (auto _ : state) {
    ++k;
    for (int j = 0; j < n; ++j) {
      p[j] = std::sin(0.001 * k + j);
      dq[j] = std::cos(0.001 * k + j);
    }
    observer.step(0.001, p.data(), u.data(), dq.data(), r.data(), tau_f.data(), mu.data());
    benchmark::DoNotOptimize(r.data());
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(state.range(0) ? "6 joints, order 2 + LuGre" : "6 joints, order 2");
}
BENCHMARK(BM_ResidualObserver)->Arg(0)->Arg(1);

struct Motion {
  std::vector<std::vector<double>> q, dq, tau;
  std::vector<double> t;
};

Motion load_motion(const std::string& robot, int n) {
  auto in = momentum::stream::Reader::open(std::string(MOMENTUM_TEST_DATA) + "/" + robot + ".traj.csv");
  Motion m;
  while (const double* row = in->next()) {
    m.t.push_back(row[in->require("t")]);
    std::vector<double> q, dq, tau;
    for (int j = 1; j <= n; ++j) {
      q.push_back(row[in->require("q" + std::to_string(j))]);
      dq.push_back(row[in->require("dq" + std::to_string(j))]);
      tau.push_back(row[in->require("tau_m" + std::to_string(j))]);
    }
    m.q.push_back(q);
    m.dq.push_back(dq);
    m.tau.push_back(tau);
  }
  return m;
}

// The whole per-row work of mo-observe minus stream I/O: dynamics (p, beta) and the filter.
void BM_MomentumObserver(benchmark::State& state, const std::string& robot, const std::string& profile, int n) {
  namespace mm = momentum::model;
  const mm::Model model = mm::build_model(mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/" + profile));
  const Motion m = load_motion(robot, n);
  mo::ObserverOptions options;
  options.order = 2;
  options.k2 = {5.0};
  mf::FrictionModel friction;
  friction.joints.assign(n, kLugre);
  mo::MomentumObserver observer(model, options, state.range(0) ? &friction : nullptr);
  std::vector<double> r(n), tau_f(n), mu(n);
  std::size_t k = 0;
  double offset = 0;
  for (auto _ : state) {
    observer.step(m.t[k] + offset, m.q[k].data(), m.dq[k].data(), m.tau[k].data(), r.data(), tau_f.data(), mu.data());
    benchmark::DoNotOptimize(r.data());
    if (++k == m.t.size()) k = 0, offset += m.t.back() + 0.001;
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(std::to_string(n) + " joints, order 2" + (state.range(0) ? " + LuGre" : ""));
}
BENCHMARK_CAPTURE(BM_MomentumObserver, ur5, "ur5", "ur5.json", 6)->Arg(0)->Arg(1);
BENCHMARK_CAPTURE(BM_MomentumObserver, panda, "panda", "panda.json", 7)->Arg(0)->Arg(1);

// The signal check's work on a clean row, as mo-observe does it: the one-pass test against the
// last good row, then learning from the interval (the full tests only where the one pass does
// not decide, which on the reference motion is about one row in 500).
void BM_SignalCheck(benchmark::State& state, const std::string& robot, const std::string& profile, int n) {
  namespace mm = momentum::model;
  const mm::Model model = mm::build_model(mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/" + profile));
  const Motion m = load_motion(robot, n);
  mo::SignalCheck check(model, mo::SignalCheckOptions{});
  std::size_t a = 0, b = 1;
  double offset = 0, t_a = m.t[0];
  std::int64_t full = 0;
  for (auto _ : state) {
    const double t_b = m.t[b] + offset;
    if (!check.plainly_passes(t_a, m.q[a].data(), m.dq[a].data(), t_b, m.q[b].data(), m.dq[b].data(),
                              m.tau[b].data(), 0.001)) {
      ++full;
      benchmark::DoNotOptimize(check.disagree(t_a, m.q[a].data(), m.dq[a].data(), t_b, m.q[b].data(),
                                              m.dq[b].data(), 0.001, nullptr));
    }
    check.learn(t_a, m.q[a].data(), m.dq[a].data(), m.tau[a].data(), t_b, m.q[b].data(), m.dq[b].data(),
                m.tau[b].data());
    a = b;
    t_a = t_b;
    if (++b == m.t.size()) b = 0, offset += m.t.back() + 0.001;
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["full tests"] = benchmark::Counter(static_cast<double>(full), benchmark::Counter::kAvgIterations);
  state.SetLabel(std::to_string(n) + " joints");
}
BENCHMARK_CAPTURE(BM_SignalCheck, ur5, "ur5", "ur5.json", 6);
BENCHMARK_CAPTURE(BM_SignalCheck, panda, "panda", "panda.json", 7);

}  // namespace

BENCHMARK_MAIN();
