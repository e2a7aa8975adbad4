// The dynamics against Pinocchio's values for the UR5 and the Panda (tests/data/*.points.csv,
// copied from ../shared/reference/dynamics): M, g, C dq, C^T dq and inverse dynamics at 40
// random states each, to 1e-9 relative to the norm of the reference matrix or vector.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "momentum/model/dynamics.hpp"
#include "momentum/model/profile.hpp"
#include "../support/reference_table.hpp"

namespace {

using momentum::model::Data;
using momentum::model::Model;
using Eigen::MatrixXd;
using Eigen::VectorXd;

double relative(const MatrixXd& got, const MatrixXd& want) {
  return (got - want).norm() / std::max(want.norm(), 1e-300);
}

class Reference : public ::testing::TestWithParam<std::string> {};

TEST_P(Reference, MatchesPinocchio) {
  const std::string data = MOMENTUM_TEST_DATA;
  const std::string robot = GetParam();
  const auto table = momentum::testing::read_reference_table(data + "/" + robot + ".points.csv");
  ASSERT_EQ(table.rows.size(), 40u);
  // The header comment states the gravity Pinocchio used.
  ASSERT_NE(table.comment.find("gravity -9.81 z"), std::string::npos) << table.comment;

  const auto profile = momentum::model::load_profile(data + "/" + robot + ".json");
  ASSERT_DOUBLE_EQ(profile.gravity.z(), -9.81);
  const Model model = momentum::model::build_model(profile);
  const int n = model.nq;
  ASSERT_EQ(n, robot == "ur5" ? 6 : 7);
  for (int j = 0; j < n; ++j) {
    // The comment lists the joint names in chain order.
    EXPECT_NE(table.comment.find(model.joints[j].name), std::string::npos);
  }
  Data data_(model);
  MatrixXd M;
  VectorXd g, cqd, ctqd, tau, p, beta;
  for (std::size_t r = 0; r < table.rows.size(); ++r) {
    const auto& row = table.rows[r];
    const VectorXd q = table.vector(r, "q", n);
    const VectorXd dq = table.vector(r, "dq", n);
    const VectorXd ddq = table.vector(r, "ddq", n);
    MatrixXd M_ref(n, n);
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < n; ++k) {
        M_ref(i, k) = row[table.column("m" + std::to_string(i + 1) + "_" + std::to_string(k + 1))];
      }
    }
    const VectorXd g_ref = table.vector(r, "g", n);
    const VectorXd cqd_ref = table.vector(r, "cqd", n);
    const VectorXd ctqd_ref = table.vector(r, "ctqd", n);
    const VectorXd tau_ref = table.vector(r, "tau_id", n);

    momentum::model::mass_matrix(model, data_, q, M);
    momentum::model::gravity_torque(model, data_, q, g);
    momentum::model::coriolis_times_velocity(model, data_, q, dq, cqd);
    momentum::model::coriolis_transpose_times_velocity(model, data_, q, dq, ctqd);
    momentum::model::inverse_dynamics(model, data_, q, dq, ddq, tau);
    momentum::model::momentum_and_beta(model, data_, q, dq, p, beta);

    EXPECT_LT(relative(M, M_ref), 1e-9) << "M\n" << M << "\nref\n" << M_ref;
    EXPECT_LT(relative(g, g_ref), 1e-9) << g.transpose() << "\nref " << g_ref.transpose();
    EXPECT_LT(relative(cqd, cqd_ref), 1e-9) << cqd.transpose() << "\nref " << cqd_ref.transpose();
    EXPECT_LT(relative(ctqd, ctqd_ref), 1e-9)
        << ctqd.transpose() << "\nref " << ctqd_ref.transpose();
    EXPECT_LT(relative(tau, tau_ref), 1e-9) << tau.transpose() << "\nref " << tau_ref.transpose();
    EXPECT_LT(relative(p, M_ref * dq), 1e-9);
    EXPECT_LT(relative(beta, g_ref - ctqd_ref), 1e-9);
  }
}

INSTANTIATE_TEST_SUITE_P(Robots, Reference, ::testing::Values("ur5", "panda"));

}  // namespace
