// The inertial-parameter regressor against two independent references:
//  - Pinocchio's M dq, g - C^T dq and inverse dynamics for the UR5 and the Panda
//    (tests/data/*.points.csv, from ../shared/reference/dynamics), to 1e-9 relative;
//  - the library's own recursive dynamics (momentum_and_beta, inverse_dynamics: a different
//    algorithm in different frames) at random states, including prismatic joints and rotor
//    inertia, to 1e-10 relative.
// d/dt Y_p is taken exactly with a ceres::Jet in time, so tau = d/dt(Y_p theta + B dq) + Y_b theta
// is checked without finite differences.
#include <gtest/gtest.h>

#include <ceres/jet.h>

#include <random>
#include <string>
#include <vector>

#include "momentum/inertia/regressor.hpp"
#include "momentum/model/dynamics.hpp"
#include "momentum/model/inertial_corrections.hpp"
#include "momentum/model/profile.hpp"
#include "../support/reference_table.hpp"

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using momentum::model::Model;
using Jet = ceres::Jet<double, 1>;

Model load(const std::string& name) {
  return momentum::model::build_model(
      momentum::model::load_profile(std::string(MOMENTUM_TEST_DATA) + "/" + name + ".json"));
}

double relative(const MatrixXd& got, const MatrixXd& want) {
  return (got - want).norm() / std::max(want.norm(), 1e-300);
}

// tau = d/dt (Y_p theta) + B ddq + Y_b theta along q(t) = q + dq t, dq(t) = dq + ddq t at t = 0.
VectorXd regressor_torque(const Model& model, const VectorXd& q, const VectorXd& dq,
                          const VectorXd& ddq) {
  const int n = model.nq;
  momentum::model::DataTpl<Jet> data(model);
  momentum::model::VectorX<Jet> qj(n), dqj(n);
  for (int i = 0; i < n; ++i) {
    qj[i] = Jet(q[i], 0);
    qj[i].v[0] = dq[i];
    dqj[i] = Jet(dq[i], 0);
    dqj[i].v[0] = ddq[i];
  }
  momentum::model::MatrixX<Jet> Yp, Yb;
  momentum::inertia::momentum_regressor(model, data, qj, dqj, Yp, Yb);
  const VectorXd theta = momentum::inertia::model_parameters(model);
  MatrixXd dYp(n, Yp.cols()), Ybv(n, Yp.cols());
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < Yp.cols(); ++j) {
      dYp(i, j) = Yp(i, j).v[0];
      Ybv(i, j) = Yb(i, j).a;
    }
  }
  return dYp * theta + model.rotor_inertia.cwiseProduct(ddq) + Ybv * theta;
}

class Pinocchio : public ::testing::TestWithParam<std::string> {};

TEST_P(Pinocchio, RegressorTimesParametersMatches) {
  Model model = load(GetParam());
  model.rotor_inertia.setZero();  // Pinocchio's values have no rotor inertia
  const int n = model.nq;
  const auto table = momentum::testing::read_reference_table(std::string(MOMENTUM_TEST_DATA) + "/" + GetParam() + ".points.csv");
  ASSERT_EQ(table.rows.size(), 40u);
  const VectorXd theta = momentum::inertia::model_parameters(model);
  momentum::model::Data data(model);
  MatrixXd Yp, Yb;
  for (std::size_t r = 0; r < table.rows.size(); ++r) {
    const VectorXd q = table.vector(r, "q", n), dq = table.vector(r, "dq", n),
                   ddq = table.vector(r, "ddq", n);
    MatrixXd M(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        M(i, j) = table.rows[r][static_cast<std::size_t>(table.column("m" + std::to_string(i + 1) + "_" + std::to_string(j + 1)))];
    momentum::inertia::momentum_regressor(model, data, q, dq, Yp, Yb);
    const VectorXd beta_ref = table.vector(r, "g", n) - table.vector(r, "ctqd", n);
    EXPECT_LT(relative(Yp * theta, M * dq), 1e-9) << "row " << r;
    EXPECT_LT(relative(Yb * theta, beta_ref), 1e-9) << "row " << r;
    EXPECT_LT(relative(regressor_torque(model, q, dq, ddq), table.vector(r, "tau_id", n)), 1e-9)
        << "row " << r;
  }
}

INSTANTIATE_TEST_SUITE_P(Robots, Pinocchio, ::testing::Values("ur5", "panda"));

class LibraryDynamics : public ::testing::TestWithParam<std::string> {};

TEST_P(LibraryDynamics, RegressorMatchesMomentumBetaAndInverseDynamics) {
  const Model model = load(GetParam());
  const int n = model.nq;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  const VectorXd theta = momentum::inertia::model_parameters(model);
  momentum::model::Data data(model), data2(model);
  MatrixXd Yp, Yb;
  VectorXd p, beta, tau;
  for (int trial = 0; trial < 50; ++trial) {
    VectorXd q(n), dq(n), ddq(n);
    for (int i = 0; i < n; ++i) {
      q[i] = u(rng);
      dq[i] = u(rng);
      ddq[i] = 3 * u(rng);
    }
    momentum::inertia::momentum_regressor(model, data, q, dq, Yp, Yb);
    momentum::model::momentum_and_beta(model, data2, q, dq, p, beta);
    momentum::model::inverse_dynamics(model, data2, q, dq, ddq, tau);
    EXPECT_LT(relative(Yp * theta + model.rotor_inertia.cwiseProduct(dq), p), 1e-10);
    EXPECT_LT(relative(Yb * theta, beta), 1e-10);
    EXPECT_LT(relative(regressor_torque(model, q, dq, ddq), tau), 1e-10);
  }
}

INSTANTIATE_TEST_SUITE_P(Robots, LibraryDynamics,
                         ::testing::Values("ur5", "panda", "mixed_chain", "three_link"));

TEST(StandardParameters, RoundTripAndLinearity) {
  const Model model = load("panda");
  for (const auto& body : model.bodies) {
    const auto theta = momentum::model::standard_parameters(body);
    momentum::model::Body copy;
    ASSERT_TRUE(momentum::model::set_standard_parameters(copy, theta, nullptr));
    EXPECT_NEAR(copy.mass, body.mass, 1e-12);
    EXPECT_LT((copy.com - body.com).norm(), 1e-12);
    EXPECT_LT((copy.inertia - body.inertia).norm(), 1e-12);
  }
  // Two point masses merged: the standard parameters add (parallel-axis theorem).
  momentum::model::Body a, b;
  a.mass = 2;
  a.com = {0.1, 0, 0};
  a.inertia = Eigen::Matrix3d::Identity() * 1e-3;
  b.mass = 1;
  b.com = {0, 0.3, 0};
  b.inertia = Eigen::Matrix3d::Identity() * 2e-3;
  momentum::model::Body sum;
  ASSERT_TRUE(momentum::model::set_standard_parameters(
      sum, momentum::model::standard_parameters(a) + momentum::model::standard_parameters(b), nullptr));
  EXPECT_NEAR(sum.mass, 3, 1e-15);
  EXPECT_LT((sum.com - Eigen::Vector3d(0.2 / 3, 0.1, 0)).norm(), 1e-15);
  // Izz about the merged com: 3e-3 + 2 (0.1^2 + 0.1^2) + 1 ((0.2/3)^2 + 0.2^2) by hand.
  const double dx = 0.2 / 3;
  EXPECT_NEAR(sum.inertia(2, 2), 3e-3 + 2 * ((0.1 - dx) * (0.1 - dx) + 0.1 * 0.1) + 1 * (dx * dx + 0.2 * 0.2), 1e-14);
  momentum::model::StandardParameters negative = momentum::model::standard_parameters(a);
  negative[0] = -1;
  std::string why;
  EXPECT_FALSE(momentum::model::set_standard_parameters(sum, negative, &why));
  EXPECT_NE(why.find("mass"), std::string::npos);
}

}  // namespace

namespace {

// The profile's inertial_corrections section as build_model applies it: the corrected body's
// standard parameters are the URDF's plus the correction, by hand.
TEST(InertialCorrections, BuildModelAppliesTheSection) {
  const std::string path = std::string(MOMENTUM_TEST_DATA) + "/dynfit/nominal.json";
  const momentum::model::Profile plain = momentum::model::load_profile(path);
  const Model nominal = momentum::model::build_model(plain);
  nlohmann::json document = plain.document;
  // +0.5 kg at 0.3 m along z of the forearm frame, as a point mass: dm = 0.5, dmz = 0.15,
  // dixx = diyy = 0.5 * 0.3^2 = 0.045.
  document["inertial_corrections"] = {
      {"bodies", {{"forearm", {0.5, 0.0, 0.0, 0.15, 0.045, 0.0, 0.0, 0.045, 0.0, 0.0}}}}};
  const Model corrected =
      momentum::model::build_model(momentum::model::profile_from_document(document, path));
  const auto& a = nominal.bodies[2];
  const auto& b = corrected.bodies[2];
  EXPECT_NEAR(b.mass, a.mass + 0.5, 1e-12);
  EXPECT_LT((b.com - (a.mass * a.com + 0.5 * Eigen::Vector3d(0, 0, 0.3)) / (a.mass + 0.5)).norm(), 1e-12);
  EXPECT_NEAR(corrected.bodies[0].mass, nominal.bodies[0].mass, 0.0);
  // The nominal model ignores the section.
  const Model again = momentum::model::build_nominal_model(momentum::model::profile_from_document(document, path));
  EXPECT_EQ(again.bodies[2].mass, a.mass);
  // Errors name the profile.
  document["inertial_corrections"]["bodies"] = {{"no_such_link", {0, 0, 0, 0, 0, 0, 0, 0, 0, 0}}};
  try {
    momentum::model::build_model(momentum::model::profile_from_document(document, path));
    ADD_FAILURE() << "unknown body accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("nominal.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no_such_link"), std::string::npos) << e.what();
  }
  document["inertial_corrections"]["bodies"] = {{"forearm", {-5, 0, 0, 0, 0, 0, 0, 0, 0, 0}}};
  EXPECT_THROW(momentum::model::build_model(momentum::model::profile_from_document(document, path)),
               std::exception);
  document["inertial_corrections"]["bodies"] = {{"forearm", {1, 2, 3}}};
  EXPECT_THROW(momentum::model::build_model(momentum::model::profile_from_document(document, path)),
               std::exception);
}

}  // namespace
