// Friction identification at the paper's settings: 1251 samples (10 s at 125 Hz) of the
// paper's motion on the paper's arm (mo-sim's plant with the Table 1 friction, default sensor
// noise, observed by the profile's second-order observer), fitted with
//   paper    the paper's full GA (population 200, 300 generations, one run), no polish;
//   default  mo-lugre-fit's default: a short GA (friction_fit::quick_search) and the Ceres polish.
// One joint, and the three joints together on two threads. Counters: evaluations (cost
// function runs over the 1251 samples, Ceres Jacobian runs included) and the final cost
// 1/2 sum e^2 summed over the joints; "paper cost" is the full GA's (same seed), so the
// default must show cost <= paper cost. Each benchmark runs once (a fit takes seconds).
// BM_FitPerSample: the default fit's CPU cost per sample on long data (the same motion repeated
// up to an hour at 125 Hz), which falls with the length since the search runs on a fixed subset.
// scripts/bench-fit.sh runs it and mo-lugre-fit end to end.
#include <benchmark/benchmark.h>

#include <chrono>
#include <ctime>
#include <string>
#include <vector>

#include "momentum/friction_fit/friction_fit.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/observer/observer.hpp"
#include "momentum/sim/run.hpp"

namespace friction_fit = momentum::friction_fit;

namespace {

struct Data {
  std::vector<friction_fit::JointSeries> series;
  std::vector<momentum::observer::Gains> gains;
};

// Simulates 12 s of the paper's motion at 125 Hz and observes the 10 s in the middle
// (1251 samples), the observer starting with the window as the paper's "middle stable cycles".
const Data& paper_data() {
  static const Data data = [] {
    const auto profile = momentum::model::load_profile(std::string(MOMENTUM_TEST_DATA) +
                                                       "/../../share/momentum/robots/paper-arm/paper-arm.json");
    const auto model = momentum::model::build_model(profile);
    const auto section = momentum::sim::read_simulation_section(profile, model);
    momentum::sim::RunOptions run;
    run.rate_hz = 125;
    run.trajectory.duration = 12;
    const auto observer_options = momentum::observer::observer_options_from_json(profile.document["observer"]);
    momentum::observer::MomentumObserver observer(model, observer_options, nullptr);
    Data d;
    d.gains = observer_options.joint_gains(model.nq);
    d.series.resize(static_cast<std::size_t>(model.nq));
    Eigen::VectorXd tau(model.nq), r(model.nq);
    momentum::sim::RunCallbacks callbacks;
    callbacks.sample = [&](const momentum::sim::Sample& s) {
      if (s.t < 1.0 - 1e-9 || s.t > 11.0 + 1e-9) return;
      tau = model.k_i.cwiseProduct(s.i);
      observer.step(s.t, s.q.data(), s.dq.data(), tau.data(), r.data(), nullptr, nullptr);
      for (int j = 0; j < model.nq; ++j) {
        auto& js = d.series[static_cast<std::size_t>(j)];
        js.joint = j + 1;
        js.restart.push_back(js.t.empty() ? 2 : 0);
        js.t.push_back(s.t);
        js.dq.push_back(s.dq(j));
        js.r.push_back(r(j));
        js.scored.push_back(1);
      }
    };
    momentum::sim::simulate(model, &section.friction, section.home, run, 1, callbacks);
    return d;
  }();
  return data;
}

friction_fit::FitOptions options(bool paper, bool with_static) {
  friction_fit::FitOptions o;
  o.compare_static = with_static;
  if (paper) {
    o.global.genetic = friction_fit::GeneticOptions{};  // 200 x 300, one run
    o.polish.enabled = false;
  } else {
    o.global.genetic = friction_fit::quick_search();
  }
  return o;
}

double total_cost(const std::vector<friction_fit::JointFit>& fits) {
  double c = 0;
  for (const auto& f : fits) c += f.model.metrics.cost;
  return c;
}

std::vector<friction_fit::JointFit> run(bool paper, int joints, int threads, bool with_static = false) {
  const Data& d = paper_data();
  std::vector<friction_fit::JointSeries> series(d.series.begin(), d.series.begin() + joints);
  std::vector<momentum::observer::Gains> gains(d.gains.begin(), d.gains.begin() + joints);
  return friction_fit::fit_joints(series, gains, options(paper, with_static), threads);
}

// Arguments: method (0 paper GA, 1 default, 2 default with the static Stribeck comparison, as
// mo-lugre-fit runs by default), joints.
void BM_Fit(benchmark::State& state) {
  const bool paper = state.range(0) == 0;
  const bool with_static = state.range(0) == 2;
  const int joints = static_cast<int>(state.range(1));
  const int threads = joints == 1 ? 1 : 2;
  (void)paper_data();
  std::vector<friction_fit::JointFit> fits;
  const std::clock_t cpu_start = std::clock();
  for (auto _ : state) fits = run(paper, joints, threads, with_static);
  const double cpu = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  std::uint64_t evaluations = 0;
  for (const auto& f : fits)
    evaluations += f.model.evaluations + (f.static_model ? f.static_model->evaluations : 0);
  state.counters["process_cpu_s"] = cpu;
  state.counters["evaluations"] = static_cast<double>(evaluations);
  state.counters["cost"] = total_cost(fits);
  state.counters["samples"] = static_cast<double>(fits.front().model.metrics.samples);
  if (!paper) state.counters["paper cost"] = total_cost(run(true, joints, threads));
  state.SetLabel(std::string(paper ? "paper GA 200x300" : with_static ? "default GA+polish+stribeck" : "default GA+polish") + ", " +
                 std::to_string(joints) + (joints == 1 ? " joint" : " joints on 2 threads"));
}
BENCHMARK(BM_Fit)->Args({0, 1})->Args({1, 1})->Args({0, 3})->Args({1, 3})->Args({2, 3})
    ->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();

// The fit's cost per sample on long data: the paper's 10 s repeated (with its observer
// restarting at each copy) to range(0) samples per joint, one joint, the default fit (search
// on a 2,000-sample subset, polish and uncertainties on all). Counter "us_per_sample": CPU
// microseconds per counted sample; it falls as the data grow, since the search's share is fixed.
void BM_FitPerSample(benchmark::State& state) {
  const Data& d = paper_data();
  const auto wanted = static_cast<std::size_t>(state.range(0));
  friction_fit::JointSeries series;
  while (series.size() < wanted) friction_fit::append_series(series, d.series.front());
  std::vector<friction_fit::JointSeries> data{series};
  std::vector<momentum::observer::Gains> gains{d.gains.front()};
  std::vector<friction_fit::JointFit> fits;
  const std::clock_t cpu_start = std::clock();
  for (auto _ : state) fits = friction_fit::fit_joints(data, gains, options(false, false), 1);
  const double cpu = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  const auto samples = static_cast<double>(fits.front().model.metrics.samples);
  state.counters["samples"] = samples;
  state.counters["us_per_sample"] = 1e6 * cpu / static_cast<double>(state.iterations()) / samples;
  state.counters["cost"] = total_cost(fits);
}
BENCHMARK(BM_FitPerSample)->Arg(12510)->Arg(125100)->Arg(450360)
    ->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
