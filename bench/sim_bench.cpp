// Simulation speed: simulated seconds per wall-clock second (the "sim_s" rate counter) for the
// paper's arm (3 joints, LuGre friction of Table 1) and the Panda (7 joints, the same LuGre
// parameters on every joint), at the default internal rate of 10 kHz; and the cost of one
// internal step. Everything but the output encoding is included: trajectory, controller,
// friction, contacts, sensors.
#include <benchmark/benchmark.h>

#include <string>

#include "momentum/core/error.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/sim/run.hpp"

namespace {

using namespace momentum;

struct Arm {
  model::Model model;
  sim::SimulationSection section;
};

Arm load(const std::string& path) {
  auto previous = set_warning_sink([](std::string_view) {});
  Arm arm;
  const model::Profile profile = model::load_profile(path);
  arm.model = model::build_model(profile);
  arm.section = sim::read_simulation_section(profile, arm.model);
  set_warning_sink(previous);
  return arm;
}

const Arm& paper_arm() {
  static const Arm arm = load(std::string(MOMENTUM_TEST_DATA) + "/../../share/momentum/robots/paper-arm/paper-arm.json");
  return arm;
}

const Arm& panda() {
  static const Arm arm = [] {
    Arm a = load(std::string(MOMENTUM_TEST_DATA) + "/panda.json");
    // Table 1's joint 1 on every joint, so that the 7-joint run pays for LuGre too.
    a.section.friction = paper_arm().section.friction;
    a.section.friction.joints.assign(7, paper_arm().section.friction.joints[0]);
    a.section.has_friction = true;
    return a;
  }();
  return arm;
}

void run(benchmark::State& state, const Arm& arm, double rate, sim::Integrator integrator, int collisions) {
  sim::RunOptions options;
  options.rate_hz = rate;
  options.integrator = integrator;
  options.trajectory.duration = 20.0;
  options.contacts.count = collisions;
  options.contacts.min_spacing = 1.0;
  std::uint64_t samples = 0;
  sim::RunCallbacks callbacks;
  callbacks.sample = [&](const sim::Sample& s) { samples += s.q.size() > 0; };
  for (auto _ : state) {
    const auto summary = sim::simulate(arm.model, &arm.section.friction, arm.section.home, options, 1, callbacks);
    benchmark::DoNotOptimize(summary.samples);
  }
  state.counters["sim_s"] = benchmark::Counter(options.trajectory.duration * static_cast<double>(state.iterations()),
                                               benchmark::Counter::kIsRate);
  state.counters["rows"] = benchmark::Counter(static_cast<double>(samples), benchmark::Counter::kIsRate);
}

void BM_PaperArm_1kHz_RK4(benchmark::State& state) { run(state, paper_arm(), 1000, sim::Integrator::rk4, 4); }
void BM_PaperArm_125Hz_RK4(benchmark::State& state) { run(state, paper_arm(), 125, sim::Integrator::rk4, 4); }
void BM_PaperArm_1kHz_SemiImplicit(benchmark::State& state) {
  run(state, paper_arm(), 1000, sim::Integrator::semi_implicit, 4);
}
void BM_Panda_1kHz_RK4(benchmark::State& state) { run(state, panda(), 1000, sim::Integrator::rk4, 4); }
void BM_Panda_1kHz_SemiImplicit(benchmark::State& state) {
  run(state, panda(), 1000, sim::Integrator::semi_implicit, 4);
}

void step(benchmark::State& state, const Arm& arm, sim::Integrator integrator) {
  sim::Plant plant(arm.model, &arm.section.friction, integrator);
  const Eigen::VectorXd dq = Eigen::VectorXd::Constant(arm.model.nq, 0.3);
  plant.reset(arm.section.home, dq);
  const Eigen::VectorXd tau = Eigen::VectorXd::Constant(arm.model.nq, 1.0);
  double t = 0;
  for (auto _ : state) {
    plant.step(t, 1e-4, tau, nullptr);
    t += 1e-4;
    if (t > 0.5) plant.reset(arm.section.home, dq), t = 0;
  }
  state.counters["steps"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_Step_PaperArm_RK4(benchmark::State& state) { step(state, paper_arm(), sim::Integrator::rk4); }
void BM_Step_Panda_RK4(benchmark::State& state) { step(state, panda(), sim::Integrator::rk4); }

BENCHMARK(BM_PaperArm_1kHz_RK4)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PaperArm_125Hz_RK4)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PaperArm_1kHz_SemiImplicit)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Panda_1kHz_RK4)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Panda_1kHz_SemiImplicit)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Step_PaperArm_RK4);
BENCHMARK(BM_Step_Panda_RK4);

}  // namespace

BENCHMARK_MAIN();
