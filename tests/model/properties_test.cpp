// Physical and mathematical properties of the dynamics at random states, on the UR5, the
// Panda, the three-link arm (rotor inertia) and the mixed chain (continuous, prismatic,
// fixed-in-the-middle and locked joints, oblique gravity). Derivatives come from ceres::Jet
// forward-mode differentiation through the same templated code, which also shows that the
// dynamics compile and agree with S = ceres::Jet.
#include <gtest/gtest.h>

#include <ceres/jet.h>

#include <random>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "momentum/model/dynamics.hpp"
#include "momentum/model/profile.hpp"

namespace {

namespace mm = momentum::model;
using Eigen::MatrixXd;
using Eigen::VectorXd;
constexpr int kMaxJoints = 8;
using Jet = ceres::Jet<double, kMaxJoints>;  // one derivative slot per joint
using Jet1 = ceres::Jet<double, 1>;          // a time derivative

mm::Model load(const std::string& name) {
  return mm::build_model(mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/" + name + ".json"));
}

double relative(const MatrixXd& got, const MatrixXd& want) {
  return (got - want).norm() / std::max(want.norm(), 1e-12);
}

struct State {
  VectorXd q, dq, ddq;
};

State random_state(const mm::Model& model, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  State s{VectorXd(model.nq), VectorXd(model.nq), VectorXd(model.nq)};
  for (int j = 0; j < model.nq; ++j) {
    const bool revolute = model.joints[j].type == mm::JointType::revolute;
    s.q[j] = revolute ? 3.0 * unit(rng) : 0.2 * unit(rng);
    s.dq[j] = revolute ? 2.0 * unit(rng) : 0.4 * unit(rng);
    s.ddq[j] = 5.0 * unit(rng);
  }
  return s;
}

// q as jets with d/dq_k in slot k.
mm::VectorX<Jet> seeded(const VectorXd& q) {
  mm::VectorX<Jet> out(q.size());
  for (int k = 0; k < q.size(); ++k) out[k] = Jet(q[k], k);
  return out;
}

template <class J>
mm::VectorX<J> constant(const VectorXd& x) {
  return x.unaryExpr([](double v) { return J(v); });
}

class Properties : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    model = load(GetParam());
    ASSERT_LE(model.nq, kMaxJoints);
  }
  mm::Model model;
  std::mt19937 rng{20240601};
};

TEST_P(Properties, MassMatrixSymmetricPositiveDefinite) {
  mm::Data data(model);
  MatrixXd M;
  for (int trial = 0; trial < 50; ++trial) {
    const State s = random_state(model, rng);
    mm::mass_matrix(model, data, s.q, M);
    EXPECT_EQ((M - M.transpose()).norm(), 0.0);
    const Eigen::SelfAdjointEigenSolver<MatrixXd> eig(M);
    EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0) << M;
  }
}

// M from its definition: sum over bodies of m Jc^T Jc + Jw^T I_world Jw, plus rotor inertia.
// Jc is the com Jacobian (checked against autodiff below), Jw stacks the world axes of the
// revolute joints up to the body.
TEST_P(Properties, MassMatrixEqualsJacobianSum) {
  mm::Data data(model);
  MatrixXd M;
  mm::Matrix3X<double> Jc;
  for (int trial = 0; trial < 20; ++trial) {
    const State s = random_state(model, rng);
    mm::mass_matrix(model, data, s.q, M);
    MatrixXd expected = model.rotor_inertia.asDiagonal();
    for (int b = 0; b < model.nq; ++b) {
      mm::point_jacobian(model, data, s.q, b, model.bodies[b].com, Jc);
      Eigen::MatrixXd Jw = Eigen::MatrixXd::Zero(3, model.nq);
      for (int j = 0; j <= b; ++j) {
        if (model.joints[j].type == mm::JointType::revolute) Jw.col(j) = data.axis[j];
      }
      const Eigen::Matrix3d R = data.rotation[b];
      const Eigen::Matrix3d I = R * model.bodies[b].inertia * R.transpose();
      expected += model.bodies[b].mass * Jc.transpose() * Jc + Jw.transpose() * I * Jw;
    }
    EXPECT_LT(relative(M, expected), 1e-12);
  }
}

TEST_P(Properties, PointJacobianIsDerivativeOfPointPosition) {
  mm::Data data(model);
  mm::DataTpl<Jet> jet_data(model);
  mm::Matrix3X<double> J;
  for (int trial = 0; trial < 10; ++trial) {
    const State s = random_state(model, rng);
    for (int b = 0; b < model.nq; ++b) {
      const Eigen::Vector3d point(0.1 * b, -0.05, 0.2);
      mm::point_jacobian(model, data, s.q, b, point, J);
      const Eigen::Matrix<Jet, 3, 1> x =
          mm::point_position(model, jet_data, seeded(s.q), b, point.cast<Jet>().eval());
      for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < model.nq; ++k) EXPECT_NEAR(J(r, k), x[r].v[k], 1e-12);
      }
    }
  }
}

TEST_P(Properties, MomentumAndBetaAgreeWithMatrixForms) {
  mm::Data data(model);
  MatrixXd M;
  VectorXd g, ct, p, beta;
  for (int trial = 0; trial < 50; ++trial) {
    const State s = random_state(model, rng);
    mm::mass_matrix(model, data, s.q, M);
    mm::gravity_torque(model, data, s.q, g);
    mm::coriolis_transpose_times_velocity(model, data, s.q, s.dq, ct);
    mm::momentum_and_beta(model, data, s.q, s.dq, p, beta);
    EXPECT_LT(relative(p, M * s.dq), 1e-12);
    EXPECT_LT(relative(beta, g - ct), 1e-12);
  }
}

TEST_P(Properties, InverseDynamicsIsEquationOfMotion) {
  mm::Data data(model);
  MatrixXd M;
  VectorXd g, c, tau;
  for (int trial = 0; trial < 50; ++trial) {
    const State s = random_state(model, rng);
    mm::mass_matrix(model, data, s.q, M);
    mm::gravity_torque(model, data, s.q, g);
    mm::coriolis_times_velocity(model, data, s.q, s.dq, c);
    mm::inverse_dynamics(model, data, s.q, s.dq, s.ddq, tau);
    EXPECT_LT(relative(tau, M * s.ddq + c + g), 1e-12);
    EXPECT_NEAR(mm::kinetic_energy(model, data, s.q, s.dq), 0.5 * s.dq.dot(M * s.dq),
                1e-12 * (1.0 + s.dq.dot(M * s.dq)));
  }
}

TEST_P(Properties, RotorInertiaOnlyOnDiagonal) {
  mm::Model bare = model;
  bare.rotor_inertia.setZero();
  mm::Model geared = model;
  for (int j = 0; j < model.nq; ++j) geared.rotor_inertia[j] = 0.1 * (j + 1);
  mm::Data bare_data(bare), geared_data(geared);
  MatrixXd Mb, Mg;
  VectorXd pb, betab, pg, betag, taub, taug;
  const State s = random_state(model, rng);
  mm::mass_matrix(bare, bare_data, s.q, Mb);
  mm::mass_matrix(geared, geared_data, s.q, Mg);
  EXPECT_LT(relative(Mg - Mb, MatrixXd(geared.rotor_inertia.asDiagonal())), 1e-12);
  mm::momentum_and_beta(bare, bare_data, s.q, s.dq, pb, betab);
  mm::momentum_and_beta(geared, geared_data, s.q, s.dq, pg, betag);
  EXPECT_LT(relative(pg - pb, geared.rotor_inertia.cwiseProduct(s.dq)), 1e-12);
  EXPECT_LT(relative(betag, betab), 1e-15);  // B is constant: nothing in C^T dq
  mm::inverse_dynamics(bare, bare_data, s.q, s.dq, s.ddq, taub);
  mm::inverse_dynamics(geared, geared_data, s.q, s.dq, s.ddq, taug);
  EXPECT_LT(relative(taug - taub, geared.rotor_inertia.cwiseProduct(s.ddq)), 1e-12);
}

// With dM/dq_k from jets of the mass matrix: the Christoffel C, and the velocity terms the
// recursive algorithms compute without it.
TEST_P(Properties, ChristoffelConsistentCoriolis) {
  const int n = model.nq;
  mm::Data data(model);
  mm::DataTpl<Jet> jet_data(model);
  mm::MatrixX<Jet> Mj;
  VectorXd cqd, ctqd;
  for (int trial = 0; trial < 20; ++trial) {
    const State s = random_state(model, rng);
    mm::mass_matrix(model, jet_data, seeded(s.q), Mj);
    std::vector<MatrixXd> dM(n, MatrixXd(n, n));  // dM[k] = dM/dq_k
    for (int k = 0; k < n; ++k) {
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) dM[k](i, j) = Mj(i, j).v[k];
      }
    }
    MatrixXd Mdot = MatrixXd::Zero(n, n);
    for (int k = 0; k < n; ++k) Mdot += dM[k] * s.dq[k];
    MatrixXd C = MatrixXd::Zero(n, n);  // C_ij = sum_k Gamma_ijk dq_k
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        for (int k = 0; k < n; ++k) {
          C(i, j) += 0.5 * (dM[k](i, j) + dM[j](i, k) - dM[i](j, k)) * s.dq[k];
        }
      }
    }
    const MatrixXd N = Mdot - 2.0 * C;
    EXPECT_LT((N + N.transpose()).norm(), 1e-12 * (1.0 + Mdot.norm()));
    EXPECT_LT(relative(Mdot, C + C.transpose()), 1e-12);

    mm::coriolis_times_velocity(model, data, s.q, s.dq, cqd);
    mm::coriolis_transpose_times_velocity(model, data, s.q, s.dq, ctqd);
    EXPECT_LT(relative(cqd, C * s.dq), 1e-11);
    EXPECT_LT(relative(ctqd, C.transpose() * s.dq), 1e-11);
    EXPECT_LT(relative(cqd + ctqd, Mdot * s.dq), 1e-11);  // dM/dt = C + C^T along dq
    // dq^T (dM/dt - 2C) dq = 0 with the recursive C dq.
    EXPECT_NEAR(s.dq.dot(Mdot * s.dq) - 2.0 * s.dq.dot(cqd), 0.0,
                1e-11 * (1.0 + std::abs(s.dq.dot(Mdot * s.dq))));
  }
}

TEST_P(Properties, GravityIsGradientOfPotential) {
  mm::Data data(model);
  mm::DataTpl<Jet> jet_data(model);
  VectorXd g;
  for (int trial = 0; trial < 20; ++trial) {
    const State s = random_state(model, rng);
    mm::gravity_torque(model, data, s.q, g);
    const Jet V = mm::potential_energy(model, jet_data, seeded(s.q));
    EXPECT_NEAR(V.a, mm::potential_energy(model, data, s.q), 1e-12);
    for (int k = 0; k < model.nq; ++k) EXPECT_NEAR(g[k], V.v[k], 1e-11 * (1.0 + g.norm()));
  }
}

// Power balance: d(T + V)/dt = dq^T tau with tau from inverse dynamics. d/dt by a jet along
// (q, dq) -> (dq, ddq).
TEST_P(Properties, PowerBalance) {
  mm::Data data(model);
  mm::DataTpl<Jet1> jet_data(model);
  VectorXd tau;
  for (int trial = 0; trial < 50; ++trial) {
    const State s = random_state(model, rng);
    mm::VectorX<Jet1> q(model.nq), dq(model.nq);
    for (int j = 0; j < model.nq; ++j) {
      q[j] = Jet1(s.q[j]);
      q[j].v[0] = s.dq[j];
      dq[j] = Jet1(s.dq[j]);
      dq[j].v[0] = s.ddq[j];
    }
    const double dT = mm::kinetic_energy(model, jet_data, q, dq).v[0];
    const double dV = mm::potential_energy(model, jet_data, q).v[0];
    mm::inverse_dynamics(model, data, s.q, s.dq, s.ddq, tau);
    const double power = s.dq.dot(tau);
    EXPECT_NEAR(dT + dV, power, 1e-11 * (1.0 + std::abs(power) + std::abs(dT)));
  }
}

// Free motion (tau = 0) integrated with RK4 from forward dynamics ddq = M^-1 (-C dq - g):
// total energy is conserved to the integrator's accuracy.
TEST_P(Properties, EnergyConservedInFreeMotion) {
  const int n = model.nq;
  mm::Data data(model);
  MatrixXd M;
  VectorXd c, g;
  auto accel = [&](const VectorXd& q, const VectorXd& dq) {
    mm::mass_matrix(model, data, q, M);
    mm::coriolis_times_velocity(model, data, q, dq, c);
    mm::gravity_torque(model, data, q, g);
    return VectorXd(M.ldlt().solve(-c - g));
  };
  auto energy = [&](const VectorXd& q, const VectorXd& dq) {
    return mm::kinetic_energy(model, data, q, dq) + mm::potential_energy(model, data, q);
  };
  State s = random_state(model, rng);
  VectorXd q = s.q, dq = s.dq;
  const double e0 = energy(q, dq);
  const double scale = mm::kinetic_energy(model, data, q, dq) + model.total_mass() * 9.81 * 1.0;
  const double h = 2e-4;
  for (int step = 0; step < 2500; ++step) {  // 0.5 s
    const VectorXd k1q = dq, k1v = accel(q, dq);
    const VectorXd k2q = dq + 0.5 * h * k1v, k2v = accel(q + 0.5 * h * k1q, k2q);
    const VectorXd k3q = dq + 0.5 * h * k2v, k3v = accel(q + 0.5 * h * k2q, k3q);
    const VectorXd k4q = dq + h * k3v, k4v = accel(q + h * k3q, k4q);
    q += h / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q);
    dq += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
  }
  EXPECT_GT((q - s.q).norm(), 0.1);  // it did move
  EXPECT_LT(std::abs(energy(q, dq) - e0), 1e-7 * scale) << "n=" << n;
}

// The jet versions return the same values as the double versions.
TEST_P(Properties, JetValuesEqualDoubleValues) {
  mm::Data data(model);
  mm::DataTpl<Jet> jet_data(model);
  const State s = random_state(model, rng);
  const auto q = seeded(s.q);
  const auto dq = constant<Jet>(s.dq);
  const auto ddq = constant<Jet>(s.ddq);
  MatrixXd M;
  VectorXd g, c, ct, p, beta, tau;
  mm::MatrixX<Jet> Mj;
  mm::VectorX<Jet> gj, cj, ctj, pj, betaj, tauj;
  mm::mass_matrix(model, data, s.q, M);
  mm::mass_matrix(model, jet_data, q, Mj);
  mm::gravity_torque(model, data, s.q, g);
  mm::gravity_torque(model, jet_data, q, gj);
  mm::coriolis_times_velocity(model, data, s.q, s.dq, c);
  mm::coriolis_times_velocity(model, jet_data, q, dq, cj);
  mm::coriolis_transpose_times_velocity(model, data, s.q, s.dq, ct);
  mm::coriolis_transpose_times_velocity(model, jet_data, q, dq, ctj);
  mm::momentum_and_beta(model, data, s.q, s.dq, p, beta);
  mm::momentum_and_beta(model, jet_data, q, dq, pj, betaj);
  mm::inverse_dynamics(model, data, s.q, s.dq, s.ddq, tau);
  mm::inverse_dynamics(model, jet_data, q, dq, ddq, tauj);
  auto value = [](const auto& x) { return x.unaryExpr([](const Jet& v) { return v.a; }).eval(); };
  EXPECT_LT(relative(value(Mj), M), 1e-14);
  EXPECT_LT(relative(value(gj), g), 1e-14);
  EXPECT_LT(relative(value(cj), c), 1e-14);
  EXPECT_LT(relative(value(ctj), ct), 1e-14);
  EXPECT_LT(relative(value(pj), p), 1e-14);
  EXPECT_LT(relative(value(betaj), beta), 1e-14);
  EXPECT_LT(relative(value(tauj), tau), 1e-14);
  // d beta / dq from the jets against a central difference of the double version.
  VectorXd bp, bm, unused;
  for (int k = 0; k < model.nq; ++k) {
    const double h = 1e-6;
    VectorXd qp = s.q, qm = s.q;
    qp[k] += h;
    qm[k] -= h;
    mm::momentum_and_beta(model, data, qp, s.dq, unused, bp);
    mm::momentum_and_beta(model, data, qm, s.dq, unused, bm);
    const VectorXd fd = (bp - bm) / (2.0 * h);
    for (int i = 0; i < model.nq; ++i) {
      EXPECT_NEAR(betaj[i].v[k], fd[i], 1e-6 * (1.0 + fd.norm()));
    }
  }
}

TEST_P(Properties, WrongSizesThrow) {
  mm::Data data(model);
  VectorXd g;
  EXPECT_THROW(mm::gravity_torque(model, data, VectorXd::Zero(model.nq + 1), g),
               std::invalid_argument);
  VectorXd p, beta;
  EXPECT_THROW(mm::momentum_and_beta(model, data, VectorXd::Zero(model.nq),
                                     VectorXd::Zero(model.nq - 1), p, beta),
               std::invalid_argument);
  mm::Matrix3X<double> J;
  EXPECT_THROW(mm::point_jacobian(model, data, VectorXd::Zero(model.nq), model.nq,
                                  Eigen::Vector3d::Zero(), J),
               std::invalid_argument);
}

INSTANTIATE_TEST_SUITE_P(Chains, Properties,
                         ::testing::Values("ur5", "panda", "three_link", "mixed_chain"));

}  // namespace
