// Cost of identifying one contact (Locator::locate) on the UR5, 6 joints, without collision
// shapes (segments and their cylinders: 189 candidate points per link): a push on link 5 seen
// on 41 rows (24 of them fitted), as at the end of an event (proximal_accepted) and at its
// detection (best_fit). The detector calls it twice per event, not per row.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "momentum/contact/locate.hpp"
#include "momentum/model/dynamics.hpp"
#include "momentum/model/profile.hpp"

namespace mc = momentum::contact;
namespace mm = momentum::model;

namespace {

const mm::Model& ur5() {
  static const mm::Model model = mm::build_model(mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/ur5.json"));
  return model;
}

std::vector<mc::ResidualSample> push_on_link5() {
  const mm::Model& model = ur5();
  mm::Data data(model);
  const auto segments = mc::link_segments(model);
  const Eigen::Vector3d along = segments[4].to - segments[4].from;
  const Eigen::Vector3d point = segments[4].from + 0.5 * along + 0.05 * along.normalized().unitOrthogonal();
  const Eigen::Vector3d force(30, -50, 20);
  std::mt19937_64 random(1);
  std::normal_distribution<double> noise(0.0, 0.05);
  std::vector<mc::ResidualSample> samples;
  const Eigen::VectorXd q0 = Eigen::VectorXd::LinSpaced(model.nq, 0.3, -0.4);
  for (int k = 0; k <= 40; ++k) {
    mc::ResidualSample s;
    s.t = 0.005 * k;
    s.q = q0 + Eigen::VectorXd::Constant(model.nq, 0.2 * s.t);
    mm::Matrix3X<double> J;
    mm::point_jacobian(model, data, s.q, 4, point, J);
    s.r = -J.transpose() * (std::sin(M_PI * k / 40.0) * force);
    for (Eigen::Index j = 0; j < s.r.size(); ++j) s.r[j] += noise(random);
    samples.push_back(std::move(s));
  }
  return samples;
}

void BM_LocateWholeContact(benchmark::State& state) {
  const auto samples = push_on_link5();
  mc::Locator locator(ur5(), Eigen::VectorXd::Constant(6, 0.05));
  for (auto _ : state) benchmark::DoNotOptimize(locator.locate(samples, 2, 5, mc::LinkChoice::proximal_accepted));
}
BENCHMARK(BM_LocateWholeContact)->Unit(benchmark::kMillisecond);

void BM_LocateAtDetection(benchmark::State& state) {
  const auto samples = push_on_link5();
  const std::vector<mc::ResidualSample> first(samples.begin(), samples.begin() + 8);
  mc::Locator locator(ur5(), Eigen::VectorXd::Constant(6, 0.05));
  for (auto _ : state) benchmark::DoNotOptimize(locator.locate(first, 2, 2, mc::LinkChoice::best_fit));
}
BENCHMARK(BM_LocateAtDetection)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
