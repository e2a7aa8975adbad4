// Payloads of the profile: parsing, selection, and the dynamics of a model carrying one, against
// two independent references: the same URDF with an extra fixed link carrying that body (the
// URDF path of the builder, which the Pinocchio reference tests cover), and the closed form of
// a single pendulum.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <string>

#include "momentum/core/error.hpp"
#include "momentum/model/dynamics.hpp"
#include "momentum/model/profile.hpp"

namespace {

namespace mm = momentum::model;
using Eigen::MatrixXd;
using Eigen::VectorXd;

std::string data(const std::string& name) { return std::string(MOMENTUM_TEST_DATA) + "/" + name; }

mm::Model load(const std::string& profile, const std::string& payload = "") {
  mm::Profile p = mm::load_profile(data(profile));
  mm::select_payload(p, payload);
  return mm::build_model(p);
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const momentum::Error& e) {
    return e.what();
  }
  return "(no error)";
}

// M, g, C dq, C^T dq, p, beta and inverse dynamics of two models at random states; largest
// difference relative to the largest magnitude of each quantity.
void expect_same_dynamics(const mm::Model& a, const mm::Model& b, double tolerance) {
  ASSERT_EQ(a.nq, b.nq);
  mm::Data da(a), db(b);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const int n = a.nq;
  for (int trial = 0; trial < 50; ++trial) {
    VectorXd q(n), dq(n), ddq(n);
    for (int j = 0; j < n; ++j) {
      q[j] = 3.0 * unit(rng);
      dq[j] = 2.0 * unit(rng);
      ddq[j] = 5.0 * unit(rng);
    }
    MatrixXd ma, mb;
    mm::mass_matrix(a, da, q, ma);
    mm::mass_matrix(b, db, q, mb);
    EXPECT_LE((ma - mb).cwiseAbs().maxCoeff(), tolerance * mb.cwiseAbs().maxCoeff()) << trial;
    VectorXd xa, xb, ya, yb;
    mm::gravity_torque(a, da, q, xa);
    mm::gravity_torque(b, db, q, xb);
    EXPECT_LE((xa - xb).cwiseAbs().maxCoeff(), tolerance * xb.cwiseAbs().maxCoeff()) << trial;
    mm::coriolis_times_velocity(a, da, q, dq, xa);
    mm::coriolis_times_velocity(b, db, q, dq, xb);
    EXPECT_LE((xa - xb).cwiseAbs().maxCoeff(), tolerance * xb.cwiseAbs().maxCoeff()) << trial;
    mm::coriolis_transpose_times_velocity(a, da, q, dq, xa);
    mm::coriolis_transpose_times_velocity(b, db, q, dq, xb);
    EXPECT_LE((xa - xb).cwiseAbs().maxCoeff(), tolerance * xb.cwiseAbs().maxCoeff()) << trial;
    mm::momentum_and_beta(a, da, q, dq, xa, ya);
    mm::momentum_and_beta(b, db, q, dq, xb, yb);
    EXPECT_LE((xa - xb).cwiseAbs().maxCoeff(), tolerance * xb.cwiseAbs().maxCoeff()) << trial;
    EXPECT_LE((ya - yb).cwiseAbs().maxCoeff(), tolerance * yb.cwiseAbs().maxCoeff()) << trial;
    mm::inverse_dynamics(a, da, q, dq, ddq, xa);
    mm::inverse_dynamics(b, db, q, dq, ddq, xb);
    EXPECT_LE((xa - xb).cwiseAbs().maxCoeff(), tolerance * xb.cwiseAbs().maxCoeff()) << trial;
  }
}

TEST(Payload, ProfileParsesPayloadsAndDefault) {
  const mm::Profile p = mm::load_profile(data("ur5_payloads.json"));
  ASSERT_EQ(p.payloads.size(), 2u);
  ASSERT_NE(p.payload(), nullptr);
  EXPECT_EQ(p.payload()->name, "gripper");
  EXPECT_EQ(p.payload()->mass, 1.7);
  EXPECT_TRUE(p.payload()->link.empty());
  const mm::Payload& camera = p.payloads[0].name == "camera" ? p.payloads[0] : p.payloads[1];
  EXPECT_EQ(camera.link, "forearm_link");
  EXPECT_EQ(camera.inertia(1, 1), 0.0009);
  EXPECT_EQ(camera.com.z(), 0.2);
}

// The active payload by default (the tip link, with a rotated and offset frame) equals the URDF
// with the same body on a fixed joint below tool0.
TEST(Payload, TipPayloadEqualsFixedLinkInUrdf) {
  const mm::Model with_payload = load("ur5_payloads.json");
  const mm::Model with_link = load("ur5_gripper.json");
  EXPECT_EQ(with_payload.payload, "gripper");
  EXPECT_EQ(with_payload.payload_body, 5);
  EXPECT_NEAR(with_payload.total_mass(), load("ur5.json").total_mass() + 1.7, 1e-12);
  expect_same_dynamics(with_payload, with_link, 1e-12);
}

// A payload on a named link in the middle of the chain.
TEST(Payload, LinkPayloadEqualsFixedLinkInUrdf) {
  const mm::Model with_payload = load("ur5_payloads.json", "camera");
  EXPECT_EQ(with_payload.payload_body, 2);
  expect_same_dynamics(with_payload, load("ur5_camera.json"), 1e-12);
}

TEST(Payload, NoneGivesTheBareArm) {
  const mm::Model none = load("ur5_payloads.json", "none");
  EXPECT_EQ(none.payload_body, -1);
  expect_same_dynamics(none, load("ur5.json"), 0.0);
}

// Single pendulum, rod mass m = 2 kg with com at l_c = 0.25 m (izz 0.04), flange at 0.5 m,
// gravity 9.81 along -y: g(q) = G cos q - H sin q, M = const, C = 0.
TEST(Payload, PendulumClosedForm) {
  const double gravity = 9.81, rod = 2.0 * 0.25, rod_inertia = 0.04 + 2.0 * 0.25 * 0.25;
  struct Case {
    const char* payload;
    double first_x, first_y;  // payload mass times its com in the rod frame, kg m
    double inertia;           // payload's inertia about the joint axis, kg m^2
  };
  const Case cases[] = {
      {"none", 0.0, 0.0, 0.0},
      // point mass 1.5 kg at 0.1 m beyond the flange: 0.6 m from the axis.
      {"point", 1.5 * 0.6, 0.0, 1.5 * 0.36},
      // 0.8 kg at (0.6, 0.05, 0.02) with izz 0.004: the z offset does not matter.
      {"tool", 0.8 * 0.6, 0.8 * 0.05, 0.004 + 0.8 * (0.36 + 0.0025)},
      // on the rod's own link at 0.2 m.
      {"on-rod", 0.5 * 0.2, 0.0, 0.5 * 0.04},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.payload);
    const mm::Model model = load("pendulum.json", c.payload);
    mm::Data d(model);
    for (double q : {-2.5, -1.0, 0.0, 0.4, 1.3, 3.0}) {
      const VectorXd qv = VectorXd::Constant(1, q), dq = VectorXd::Constant(1, 1.7);
      VectorXd g, c_dq;
      MatrixXd M;
      mm::gravity_torque(model, d, qv, g);
      mm::mass_matrix(model, d, qv, M);
      mm::coriolis_times_velocity(model, d, qv, dq, c_dq);
      // Height of the com y = x_c sin q + y_c cos q: dV/dq = m g (x_c cos q - y_c sin q).
      const double expected_g = gravity * ((rod + c.first_x) * std::cos(q) - c.first_y * std::sin(q));
      EXPECT_NEAR(g[0], expected_g, 1e-12 * 20) << q;
      EXPECT_NEAR(M(0, 0), rod_inertia + c.inertia, 1e-14) << q;
      EXPECT_NEAR(c_dq[0], 0.0, 1e-13) << q;
    }
  }
}

TEST(Payload, UnknownNameIsAnErrorNamingTheProfile) {
  mm::Profile p = mm::load_profile(data("ur5_payloads.json"));
  const std::string e = error_of([&] { mm::select_payload(p, "drill"); });
  EXPECT_NE(e.find("ur5_payloads.json"), std::string::npos) << e;
  EXPECT_NE(e.find("\"drill\""), std::string::npos) << e;
  EXPECT_NE(e.find("camera, gripper"), std::string::npos) << e;
  mm::Profile bare = mm::load_profile(data("ur5.json"));
  EXPECT_NE(error_of([&] { mm::select_payload(bare, "drill"); }).find("none defined"), std::string::npos);
  EXPECT_NO_THROW(mm::select_payload(bare, "none"));
}

TEST(Payload, BadPayloadsAreErrors) {
  auto with = [](const std::string& payloads, const std::string& extra = "") {
    return error_of([&] {
      nlohmann::json doc = nlohmann::json::parse(R"({"urdf": "ur5_robot.urdf", "root": "base_link",
                                                     "tip": "tool0", "payloads": )" + payloads + extra + "}");
      mm::build_model(mm::profile_from_document(doc, data("test.json")));
    });
  };
  EXPECT_NE(with(R"({"a": {"com": [0, 0, 0]}})").find("missing \"mass\""), std::string::npos);
  EXPECT_NE(with(R"({"a": {"mass": -1}})").find("mass must be >= 0"), std::string::npos);
  EXPECT_NE(with(R"({"a": {"mass": 1, "com": [0, 0]}})").find("com must be"), std::string::npos);
  EXPECT_NE(with(R"({"a": {"mass": 1, "inertia": [1, 0, 0, 1, 0]}})").find("6 numbers"), std::string::npos);
  EXPECT_NE(with(R"({"a": {"mass": 1, "inertia": [1, 0, 0, 1, 0, 3]}})").find("not physical"), std::string::npos);
  EXPECT_NE(with(R"({"a": {"mass": 0, "inertia": [1, 0, 0, 1, 0, 1]}})").find("zero mass"), std::string::npos);
  EXPECT_NE(with(R"({"none": {"mass": 1}})").find("reserved"), std::string::npos);
  EXPECT_NE(with(R"({"a": {"mass": 1}})", R"(, "active_payload": "b")").find("no payload \"b\""), std::string::npos);
  EXPECT_NE(with(R"({"a": {"mass": 1, "link": "nowhere"}})", R"(, "active_payload": "a")")
                .find("unknown link 'nowhere'"),
            std::string::npos);
  EXPECT_NE(with(R"({"a": {"mass": 1, "link": "base_link"}})", R"(, "active_payload": "a")")
                .find("does not move"),
            std::string::npos);
  EXPECT_EQ(with(R"({"a": {"mass": 1, "link": "base_link"}})"), "(no error)");  // not active
  const std::string e = with(R"({"a": {"mass": 1}})", R"(, "active_payload": "a")");
  EXPECT_EQ(e, "(no error)");
}

}  // namespace
