// MomentumBatch against momentum_and_beta: every lane bit for bit the one-sample result, for
// every sample count, on the UR5, the Panda, the three-link arm (rotor inertia) and the mixed
// chain (prismatic joints, oblique gravity). momentum_and_beta itself is checked against
// Pinocchio (reference_test.cpp) and the physics (properties_test.cpp).
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "momentum/model/dynamics.hpp"
#include "momentum/model/momentum_batch.hpp"
#include "momentum/model/profile.hpp"

namespace {

namespace mm = momentum::model;
constexpr int kLanes = mm::MomentumBatch::kLanes;

mm::Model load(const std::string& name) {
  return mm::build_model(mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/" + name + ".json"));
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// The robot, and whether the batch may use the CPU's extensions (AVX2 where it has them; the
// baseline instruction set otherwise, and always with false).
class MomentumBatchTest : public ::testing::TestWithParam<std::tuple<const char*, bool>> {};

TEST_P(MomentumBatchTest, EveryLaneIsTheOneSampleResultBitForBit) {
  const char* robot = std::get<0>(GetParam());
  const mm::Model model = load(robot);
  const int n = model.nq;
  mm::Data data(model);
  mm::MomentumBatch batch(model, data, std::get<1>(GetParam()));
  ASSERT_EQ(batch.joints(), n);
  if (!std::get<1>(GetParam())) {
    ASSERT_FALSE(batch.accelerated());
  }
  std::mt19937 rng(11);
  // Angles over several turns and near zero.
  std::uniform_real_distribution<double> angle(-20.0, 20.0), small(-1e-3, 1e-3), rate(-3.0, 3.0);
  Eigen::VectorXd p(n), beta(n);
  int compared = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const int count = 1 + trial % kLanes;
    std::vector<std::vector<double>> q(kLanes, std::vector<double>(n)), dq = q, p_batch = q, beta_batch = q;
    for (int k = 0; k < count; ++k) {
      for (int j = 0; j < n; ++j) {
        const bool revolute = model.joints[j].type == mm::JointType::revolute;
        q[k][j] = revolute ? (trial % 3 == 0 ? small(rng) : angle(rng)) : 0.05 * rate(rng);
        // Now and then an angle beyond the range of the pass's own sin and cos (libm's then).
        if (revolute && trial % 7 == 5 && k == count - 1) q[k][j] = 1e6 * angle(rng);
        dq[k][j] = rate(rng);
      }
    }
    const double* qs[kLanes];
    const double* dqs[kLanes];
    double* ps[kLanes];
    double* betas[kLanes];
    for (int k = 0; k < kLanes; ++k) {
      qs[k] = q[k].data();
      dqs[k] = dq[k].data();
      ps[k] = p_batch[k].data();
      betas[k] = beta_batch[k].data();
    }
    batch.run(count, qs, dqs, ps, betas);
    for (int k = 0; k < count; ++k) {
      mm::momentum_and_beta(model, data, Eigen::Map<const Eigen::VectorXd>(qs[k], n),
                            Eigen::Map<const Eigen::VectorXd>(dqs[k], n), p, beta);
      for (int j = 0; j < n; ++j) {
        ASSERT_TRUE(same_bits(p_batch[k][j], p[j]))
            << robot << " trial " << trial << " lane " << k << " joint " << j << ": p " << p_batch[k][j]
            << " vs " << p[j];
        ASSERT_TRUE(same_bits(beta_batch[k][j], beta[j]))
            << robot << " trial " << trial << " lane " << k << " joint " << j << ": beta "
            << beta_batch[k][j] << " vs " << beta[j];
        ++compared;
      }
    }
    // Lanes beyond the count are not written.
    for (int k = count; k < kLanes; ++k)
      for (int j = 0; j < n; ++j) ASSERT_EQ(p_batch[k][j], 0.0);
  }
  EXPECT_EQ(compared, 500 * n);
}

INSTANTIATE_TEST_SUITE_P(Robots, MomentumBatchTest,
                         ::testing::Combine(::testing::Values("ur5", "panda", "three_link", "mixed_chain"),
                                            ::testing::Bool()));

TEST(MomentumBatch, RefusesACountOutsideItsLanes) {
  const mm::Model model = load("ur5");
  mm::Data data(model);
  mm::MomentumBatch batch(model, data);
  std::vector<double> q(6, 0.0), out(6);
  const double* qs[kLanes + 1] = {q.data(), q.data(), q.data(), q.data(), q.data()};
  double* outs[kLanes + 1] = {out.data(), out.data(), out.data(), out.data(), out.data()};
  EXPECT_THROW(batch.run(0, qs, qs, outs, outs), std::invalid_argument);
  EXPECT_THROW(batch.run(kLanes + 1, qs, qs, outs, outs), std::invalid_argument);
}

TEST(MomentumBatch, RefusesDataOfAnotherModel) {
  const mm::Model ur5 = load("ur5");
  const mm::Model panda = load("panda");
  mm::Data data(panda);
  EXPECT_THROW(mm::MomentumBatch(ur5, data), std::invalid_argument);
}

}  // namespace
