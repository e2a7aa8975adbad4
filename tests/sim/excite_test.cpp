// The identification excitation (--trajectory excite) on the paper arm: within the joint limits
// (position and velocity) over its whole duration, reproducible, and a better conditioned
// inertial-parameter regressor (dynfit's) than the paper's sine or a random multisine.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include <Eigen/Dense>

#include "momentum/inertia/regressor.hpp"
#include "momentum/sim/trajectory.hpp"
#include "paper_arm.hpp"

namespace momentum::sim {
namespace {

using testing::paper_arm;

// Y_tau(q, dq, ddq) (nq x 10 nq): tau = Y_tau theta (+ B ddq), with dY_p/dt by a central
// difference along the motion (error O(h^2), far below what the condition numbers resolve).
Eigen::MatrixXd torque_regressor(const model::Model& m, model::Data& data, const Eigen::VectorXd& q,
                                 const Eigen::VectorXd& dq, const Eigen::VectorXd& ddq) {
  const double h = 1e-5;
  Eigen::MatrixXd Yp1, Yp0, Yp, Yb;
  const Eigen::VectorXd q1 = q + h * dq, dq1 = dq + h * ddq, q0 = q - h * dq, dq0 = dq - h * ddq;
  inertia::momentum_regressor<double>(m, data, q1, dq1, Yp1, Yb);
  inertia::momentum_regressor<double>(m, data, q0, dq0, Yp0, Yb);
  inertia::momentum_regressor<double>(m, data, q, dq, Yp, Yb);
  return (Yp1 - Yp0) / (2 * h) + Yb;
}

// The identifiable (base) directions of theta, from states drawn at random over the whole joint
// space: a fixed basis, independent of the trajectories compared.
Eigen::MatrixXd base_directions(const model::Model& m) {
  model::Data data(m);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::MatrixXd A(0, 10 * m.nq);
  for (int s = 0; s < 400; ++s) {
    Eigen::VectorXd q(m.nq), dq(m.nq), ddq(m.nq);
    for (int j = 0; j < m.nq; ++j) {
      const auto& lim = m.joints[j].limits;
      q[j] = 0.5 * (lim.lower + lim.upper) + 0.5 * (lim.upper - lim.lower) * u(rng);
      dq[j] = 2 * u(rng);
      ddq[j] = 5 * u(rng);
    }
    const Eigen::MatrixXd Y = torque_regressor(m, data, q, dq, ddq);
    A.conservativeResize(A.rows() + Y.rows(), Eigen::NoChange);
    A.bottomRows(Y.rows()) = Y;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinV);
  const auto& sv = svd.singularValues();
  int rank = 0;
  while (rank < sv.size() && sv[rank] > 1e-8 * sv[0]) ++rank;
  return svd.matrixV().leftCols(rank);
}

struct Excitation {
  double condition = 0;        // of the normal equations of the column-scaled base regressor
  double worst_margin = 1e9;   // smallest distance to a position limit, rad (< 0: outside)
  double worst_speed = 0;      // largest |dq| / velocity limit
};

Excitation excitation(TrajectoryKind kind, const Eigen::MatrixXd& base, std::uint64_t seed,
                      double duration = 60) {
  const auto arm = paper_arm();
  const auto& m = arm.model;
  TrajectoryOptions options;
  options.kind = kind;
  options.duration = duration;
  Trajectory trajectory(options, m, arm.section.home, seed);
  model::Data data(m);
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(base.cols(), base.cols());
  Eigen::VectorXd q, dq, ddq;
  Excitation e;
  const double step = 0.001;  // dense: the limits are checked at every millisecond
  int n = 0;
  for (double t = 0; t <= duration; t = ++n * step) {
    trajectory.evaluate(t, q, dq, ddq);
    for (int j = 0; j < m.nq; ++j) {
      const auto& lim = m.joints[j].limits;
      e.worst_margin = std::min({e.worst_margin, q[j] - lim.lower, lim.upper - q[j]});
      e.worst_speed = std::max(e.worst_speed, std::abs(dq[j]) / lim.velocity);
    }
    if (n % 20 == 0) {  // the regressor at 50 Hz
      const Eigen::MatrixXd Y = torque_regressor(m, data, q, dq, ddq) * base;
      A += Y.transpose() * Y;
    }
  }
  const Eigen::VectorXd scale = A.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd S = scale.asDiagonal() * A * scale.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(S);
  e.condition = eig.eigenvalues().maxCoeff() / eig.eigenvalues().minCoeff();
  return e;
}

TEST(Excite, WithinLimitsAndBetterConditionedThanPaperAndMultisine) {
  const auto arm = paper_arm();
  const Eigen::MatrixXd base = base_directions(arm.model);
  ASSERT_GE(base.cols(), 2 * arm.model.nq);
  const Excitation excite = excitation(TrajectoryKind::excite, base, 1);
  const Excitation paper = excitation(TrajectoryKind::paper, base, 1);
  const Excitation multisine = excitation(TrajectoryKind::multisine, base, 1);
  std::printf("base parameters %d; condition number of the normal equations (column-scaled): "
              "excite %.4g, paper %.4g, multisine %.4g\n",
              static_cast<int>(base.cols()), excite.condition, paper.condition, multisine.condition);
  std::printf("excite: closest approach to a position limit %.3f rad, peak |dq|/limit %.3f\n",
              excite.worst_margin, excite.worst_speed);
  EXPECT_GT(excite.worst_margin, 0.0);
  EXPECT_LE(excite.worst_speed, 0.5 * (1 + 1e-4));  // half the velocity limit (peak found on a grid)
  EXPECT_LT(excite.condition, paper.condition);
  EXPECT_LT(excite.condition, multisine.condition);
}

TEST(Excite, ReproducibleAndIndependentOfTheSeed) {
  const auto arm = paper_arm();
  TrajectoryOptions options;
  options.kind = TrajectoryKind::excite;
  options.duration = 30;
  Trajectory a(options, arm.model, arm.section.home, 1), b(options, arm.model, arm.section.home, 99);
  Eigen::VectorXd qa, dqa, ddqa, qb, dqb, ddqb;
  for (double t = 0; t <= 30; t += 0.37) {
    a.evaluate(t, qa, dqa, ddqa);
    b.evaluate(t, qb, dqb, ddqb);
    EXPECT_EQ(qa, qb);
    EXPECT_EQ(dqa, dqb);
    EXPECT_EQ(ddqa, ddqb);
  }
}

TEST(Excite, JointsMoveAtDistinctFrequencies) {
  // Over one 30 s period (3 joints), the velocities of two joints driven at disjoint harmonic sets are
  // orthogonal (closed form); the paper's sines are perfectly correlated.
  const auto arm = paper_arm();
  TrajectoryOptions options;
  options.kind = TrajectoryKind::excite;
  options.duration = 40;
  Trajectory trajectory(options, arm.model, arm.section.home, 1);
  const int nq = arm.model.nq;
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(nq, nq);
  Eigen::VectorXd q, dq, ddq;
  const int samples = 10000;
  for (int s = 0; s < samples; ++s) {
    trajectory.evaluate(5 + 30.0 * s / samples, q, dq, ddq);
    G += dq * dq.transpose();
  }
  for (int i = 0; i < nq; ++i)
    for (int j = i + 1; j < nq; ++j)
      EXPECT_LT(std::abs(G(i, j)) / std::sqrt(G(i, i) * G(j, j)), 1e-6) << i << "," << j;
}

TEST(Excite, ParsesAndNames) {
  TrajectoryKind kind = TrajectoryKind::paper;
  ASSERT_TRUE(parse_trajectory("excite", &kind));
  EXPECT_EQ(kind, TrajectoryKind::excite);
  EXPECT_STREQ(trajectory_name(kind), "excite");
}

}  // namespace
}  // namespace momentum::sim
