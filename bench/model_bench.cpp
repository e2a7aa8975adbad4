// Dynamics on 3-joint (tests/data/three_link), 6-joint (UR5) and 7-joint (Panda) chains:
// mass matrix, gravity, momentum and beta (the observer's per-sample work), C^T dq, RNEA.
// Each benchmark cycles through 64 random states so branch predictors and caches see
// realistic variety.
#include <benchmark/benchmark.h>

#include <random>
#include <string>
#include <vector>

#include "momentum/model/dynamics.hpp"
#include "momentum/model/momentum_batch.hpp"
#include "momentum/model/profile.hpp"

namespace {

namespace mm = momentum::model;

const char* const kRobots[] = {"three_link", "ur5", "panda"};

struct Fixture {
  explicit Fixture(int robot)
      : model(mm::build_model(
            mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/" + kRobots[robot] + ".json"))),
        data(model) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    for (int k = 0; k < 64; ++k) {
      Eigen::VectorXd q(model.nq), dq(model.nq), ddq(model.nq);
      for (int j = 0; j < model.nq; ++j) {
        q[j] = 3.0 * unit(rng);
        dq[j] = 2.0 * unit(rng);
        ddq[j] = 5.0 * unit(rng);
      }
      qs.push_back(q);
      dqs.push_back(dq);
      ddqs.push_back(ddq);
    }
  }
  mm::Model model;
  mm::Data data;
  std::vector<Eigen::VectorXd> qs, dqs, ddqs;
};

void label(benchmark::State& state, const Fixture& f) {
  state.SetLabel(std::string(kRobots[state.range(0)]) + ", " + std::to_string(f.model.nq) +
                 " joints");
  state.SetItemsProcessed(state.iterations());
}

void BM_MassMatrix(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)));
  Eigen::MatrixXd M(f.model.nq, f.model.nq);
  std::size_t k = 0;
  for (auto _ : state) {
    mm::mass_matrix(f.model, f.data, f.qs[k++ & 63], M);
    benchmark::DoNotOptimize(M.data());
  }
  label(state, f);
}

void BM_GravityTorque(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)));
  Eigen::VectorXd g(f.model.nq);
  std::size_t k = 0;
  for (auto _ : state) {
    mm::gravity_torque(f.model, f.data, f.qs[k++ & 63], g);
    benchmark::DoNotOptimize(g.data());
  }
  label(state, f);
}

void BM_MomentumAndBeta(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)));
  Eigen::VectorXd p(f.model.nq), beta(f.model.nq);
  std::size_t k = 0;
  for (auto _ : state) {
    const std::size_t i = k++ & 63;
    mm::momentum_and_beta(f.model, f.data, f.qs[i], f.dqs[i], p, beta);
    benchmark::DoNotOptimize(p.data());
    benchmark::DoNotOptimize(beta.data());
  }
  label(state, f);
}

// The same per sample, MomentumBatch::kLanes samples a call; items are samples.
void BM_MomentumAndBetaBatch(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)));
  mm::MomentumBatch batch(f.model, f.data);
  constexpr int kLanes = mm::MomentumBatch::kLanes;
  std::vector<Eigen::VectorXd> p(kLanes, Eigen::VectorXd(f.model.nq)), beta = p;
  const double* q[kLanes];
  const double* dq[kLanes];
  double* p_out[kLanes];
  double* beta_out[kLanes];
  for (int k = 0; k < kLanes; ++k) {
    p_out[k] = p[k].data();
    beta_out[k] = beta[k].data();
  }
  std::size_t k = 0;
  for (auto _ : state) {
    for (int lane = 0; lane < kLanes; ++lane) {
      const std::size_t i = k++ & 63;
      q[lane] = f.qs[i].data();
      dq[lane] = f.dqs[i].data();
    }
    batch.run(kLanes, q, dq, p_out, beta_out);
    benchmark::DoNotOptimize(p_out[0]);
    benchmark::DoNotOptimize(beta_out[0]);
  }
  label(state, f);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * kLanes);
}

void BM_CoriolisTransposeTimesVelocity(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)));
  Eigen::VectorXd ct(f.model.nq);
  std::size_t k = 0;
  for (auto _ : state) {
    const std::size_t i = k++ & 63;
    mm::coriolis_transpose_times_velocity(f.model, f.data, f.qs[i], f.dqs[i], ct);
    benchmark::DoNotOptimize(ct.data());
  }
  label(state, f);
}

void BM_InverseDynamics(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)));
  Eigen::VectorXd tau(f.model.nq);
  std::size_t k = 0;
  for (auto _ : state) {
    const std::size_t i = k++ & 63;
    mm::inverse_dynamics(f.model, f.data, f.qs[i], f.dqs[i], f.ddqs[i], tau);
    benchmark::DoNotOptimize(tau.data());
  }
  label(state, f);
}

void BM_ForwardKinematics(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)));
  std::size_t k = 0;
  for (auto _ : state) {
    mm::forward_kinematics(f.model, f.data, f.qs[k++ & 63]);
    benchmark::DoNotOptimize(f.data.tip_position_world.data());
  }
  label(state, f);
}

BENCHMARK(BM_MassMatrix)->DenseRange(0, 2);
BENCHMARK(BM_GravityTorque)->DenseRange(0, 2);
BENCHMARK(BM_MomentumAndBeta)->DenseRange(0, 2);
BENCHMARK(BM_MomentumAndBetaBatch)->DenseRange(0, 2);
BENCHMARK(BM_CoriolisTransposeTimesVelocity)->DenseRange(0, 2);
BENCHMARK(BM_InverseDynamics)->DenseRange(0, 2);
BENCHMARK(BM_ForwardKinematics)->DenseRange(0, 2);

}  // namespace

BENCHMARK_MAIN();
