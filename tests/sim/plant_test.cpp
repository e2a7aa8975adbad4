// The simulated arm's physics against properties it must have whatever the implementation:
// energy conservation of the free arm, dissipation by friction, agreement of the simulated
// motion with the library's inverse dynamics, contact torques equal to the virtual work of the
// force, and LuGre's steady state equal to the Stribeck curve at the paper's time step.
#include <gtest/gtest.h>

#include <cmath>

#include "momentum/friction/lugre.hpp"
#include "momentum/model/dynamics.hpp"
#include "momentum/sim/plant.hpp"
#include "momentum/core/random.hpp"
#include "paper_arm.hpp"

namespace momentum::sim {
namespace {

using Eigen::VectorXd;
using testing::Arm;

// Runs the free arm (no motor torque) for `seconds` and returns the relative energy drift.
double free_energy_drift(Arm arm, bool gravity, const VectorXd& q0, const VectorXd& dq0, double seconds,
                         double h, Integrator integrator) {
  if (!gravity) arm.model.gravity.setZero();
  Plant plant(arm.model, nullptr, integrator);
  plant.reset(q0, dq0);
  const double e0 = plant.energy();
  const VectorXd zero = VectorXd::Zero(arm.model.nq);
  const long steps = std::lround(seconds / h);
  double worst = 0;
  for (long k = 0; k < steps; ++k) {
    plant.step(k * h, h, zero, nullptr);
    if (k % 1000 == 999) worst = std::max(worst, std::abs(plant.energy() - e0));
  }
  // Kinetic energy at the start: the scale of the motion (the potential has an arbitrary zero).
  model::Data data(arm.model);
  const double t0 = model::kinetic_energy(arm.model, data, q0, dq0);
  return worst / t0;
}

TEST(Plant, EnergyIsConservedWithoutFrictionControlAndGravity) {
  Arm arm = testing::paper_arm();
  VectorXd q0(3), dq0(3);
  q0 << 0.3, 0.7, 1.0;
  dq0 << 1.2, -0.8, 1.5;
  // RK4 at 10 kHz over 10 s: the drift is at the level of rounding.
  const double drift = free_energy_drift(arm, false, q0, dq0, 10.0, 1e-4, Integrator::rk4);
  EXPECT_LT(drift, 1e-9);
  // The semi-implicit (symplectic) Euler keeps it bounded, to first order in h.
  EXPECT_LT(free_energy_drift(arm, false, q0, dq0, 10.0, 1e-4, Integrator::semi_implicit), 1e-2);
}

TEST(Plant, EnergyIsConservedWithGravityOnPaperArmAndPanda) {
  Arm arm = testing::paper_arm();
  VectorXd q0(3), dq0(3);
  q0 << 0.3, 0.7, 1.0;
  dq0 << 0.5, -0.4, 0.9;
  EXPECT_LT(free_energy_drift(arm, true, q0, dq0, 5.0, 1e-4, Integrator::rk4), 1e-8);

  Arm panda = testing::panda();
  VectorXd qp(7), dqp(7);
  qp << 0.1, -0.4, 0.2, -1.8, 0.1, 1.5, 0.6;
  dqp << 0.5, -0.3, 0.6, 0.4, -0.7, 0.5, 0.9;
  EXPECT_LT(free_energy_drift(panda, true, qp, dqp, 2.0, 1e-4, Integrator::rk4), 1e-8);
}

TEST(Plant, FrictionDissipatesTheEnergy) {
  Arm arm = testing::paper_arm();
  arm.model.gravity.setZero();
  ASSERT_TRUE(arm.section.has_friction);
  Plant plant(arm.model, &arm.section.friction);
  VectorXd q0(3), dq0(3);
  q0 << 0.3, 0.7, 1.0;
  dq0 << 1.2, -0.8, 1.5;
  plant.reset(q0, dq0);
  const double e0 = plant.energy();
  const VectorXd zero = VectorXd::Zero(3);
  // Energy the bristles can hold and give back: sum of g_max^2 / (2 sigma0), far below e0.
  double bristle = 0;
  for (const auto& p : arm.section.friction.joints)
    bristle += std::pow(std::max(p.tau_c, p.tau_s), 2) / (2 * p.sigma0);
  double previous = e0;
  const double h = 1e-4;
  for (int k = 0; k < 20000; ++k) {
    plant.step(k * h, h, zero, nullptr);
    const double e = plant.energy();
    ASSERT_LE(e, previous + bristle) << "energy rose at t = " << (k + 1) * h;
    previous = std::min(previous, e);
  }
  EXPECT_LT(plant.energy(), 1e-3 * e0);
  EXPECT_LT(plant.dq().cwiseAbs().maxCoeff(), 1e-2);
  // The bristle state stays within its bound g_max / sigma0 all along.
  const VectorXd z = plant.bristle_state();
  for (int j = 0; j < 3; ++j) {
    const auto& p = arm.section.friction.joints[j];
    EXPECT_LE(std::abs(z[j]), std::max(p.tau_c, p.tau_s) / p.sigma0 * (1 + 1e-12));
  }
}

// The acceleration the simulator integrated, put back into the library's inverse dynamics,
// gives the torques that acted: motor minus friction minus contact.
TEST(Plant, SimulatedAccelerationAgreesWithInverseDynamics) {
  Arm arm = testing::paper_arm();
  Plant plant(arm.model, &arm.section.friction);
  ContactOptions contact_options;
  Contact contact;
  contact.link = 3;
  contact.t_onset = 0.0;
  contact.t_rise_end = 0.05;
  contact.t_hold_end = 0.2;
  contact.t_end = 0.3;
  contact.peak = 80;
  contact.point = Eigen::Vector3d(0.02, 0.03, 0.25);
  contact.direction = Eigen::Vector3d(0.3, -0.8, 0.5).normalized();
  contact.direction_in_body = false;
  VectorXd q0(3), dq0(3);
  q0 << 0.1, 0.6, 1.1;
  dq0 << 0.4, -0.3, 0.5;
  plant.reset(q0, dq0);
  ActiveContact active(contact, arm.model, plant.data(), q0, dq0, contact_options);
  model::Data data(arm.model);
  VectorXd tau_m(3), tau_id(3);
  const double h = 1e-4;
  for (int k = 0; k < 2500; ++k) {
    const double t = k * h;
    tau_m << 20 * std::sin(7 * t), 15 + 10 * std::cos(5 * t), -8 + 4 * std::sin(11 * t);
    const VectorXd q = plant.q(), dq = plant.dq();
    plant.step(t, h, tau_m, &active);
    model::inverse_dynamics(arm.model, data, q, dq, plant.acceleration(), tau_id);
    const VectorXd applied = tau_m - plant.friction_torque() - plant.contact_torque();
    ASSERT_LT((tau_id - applied).norm(), 1e-9 * (1 + applied.norm())) << "t = " << t;
  }
  EXPECT_GT(active.peak_force(), 79.0);
}

// Independent of the solver: finite differences of the simulated velocity give the
// acceleration, and the inverse dynamics of that acceleration is the torque that was applied.
TEST(Plant, FiniteDifferencesOfTheMotionGiveTheAppliedTorque) {
  Arm arm = testing::paper_arm();
  Plant plant(arm.model, nullptr);
  VectorXd q0(3), dq0(3);
  q0 << 0.1, 0.6, 1.1;
  dq0 << 0.4, -0.3, 0.5;
  plant.reset(q0, dq0);
  model::Data data(arm.model);
  VectorXd tau_m(3), tau_id(3);
  tau_m << 3.0, 25.0, 6.0;  // held constant: the motion is smooth
  const double h = 1e-4;
  VectorXd q_prev = plant.q(), dq_prev = plant.dq();
  plant.step(0, h, tau_m, nullptr);
  for (int k = 1; k < 5000; ++k) {
    const VectorXd q_mid = plant.q(), dq_mid = plant.dq();
    plant.step(k * h, h, tau_m, nullptr);
    if (k % 500 != 0) {
      q_prev = q_mid, dq_prev = dq_mid;
      continue;
    }
    const VectorXd ddq = (plant.dq() - dq_prev) / (2 * h);
    model::inverse_dynamics(arm.model, data, q_mid, dq_mid, ddq, tau_id);
    EXPECT_LT((tau_id - tau_m).norm(), 1e-5 * tau_m.norm()) << "t = " << k * h;
    q_prev = q_mid, dq_prev = dq_mid;
  }
}

// J^T F against the virtual work of the force: tau_j = F . dx/dq_j with dx/dq_j by central
// differences of the point's position (no Jacobian involved).
TEST(Contacts, JointTorquesAreTheVirtualWorkOfTheForce) {
  Arm arm = testing::paper_arm();
  model::Data data(arm.model);
  momentum::core::Random random(7);
  ContactOptions options;
  for (int trial = 0; trial < 20; ++trial) {
    Contact c;
    c.link = random.integer(1, 3);
    c.t_onset = 0, c.t_rise_end = 0.1, c.t_hold_end = 0.3, c.t_end = 0.4;
    c.peak = random.uniform(30, 150);
    c.point = Eigen::Vector3d(random.uniform(-0.05, 0.05), random.uniform(-0.05, 0.05), random.uniform(0, 0.4));
    c.direction = Eigen::Vector3d(random.normal(), random.normal(), random.normal()).normalized();
    c.direction_in_body = random.chance(0.5);
    VectorXd q(3), dq = VectorXd::Zero(3);
    q << random.uniform(-2, 2), random.uniform(-1.5, 1.5), random.uniform(-2, 2);
    ActiveContact active(c, arm.model, data, q, dq, options);
    VectorXd tau = VectorXd::Zero(3);
    const Eigen::Vector3d f = active.add_joint_torque(0.2, q, dq, tau, true);
    EXPECT_NEAR(f.norm(), c.peak, 1e-9 * c.peak);
    for (int j = 0; j < 3; ++j) {
      const double eps = 1e-6;
      VectorXd qp = q, qm = q;
      qp[j] += eps, qm[j] -= eps;
      const Eigen::Vector3d xp = model::point_position(arm.model, data, qp, c.link - 1, c.point);
      const Eigen::Vector3d xm = model::point_position(arm.model, data, qm, c.link - 1, c.point);
      const double work = f.dot(xp - xm) / (2 * eps);
      EXPECT_NEAR(tau[j], work, 1e-7 * c.peak) << "trial " << trial << " joint " << j + 1;
      // Joints beyond the link feel nothing; the recorded peak is the disturbance -J^T F.
      if (j + 1 > c.link) {
        EXPECT_EQ(tau[j], 0.0);
      }
      EXPECT_DOUBLE_EQ(active.peak_torque()[j], -tau[j]);
    }
  }
}

// The paper arm's true friction (Table 1) through the library's LuGre at the paper's 8 ms:
// steady state equals the Stribeck curve, and the bristle state stays bounded under any
// velocity sequence.
TEST(Friction, LugreSteadyStateIsStribeckAndStaysBoundedAtThePapersStep) {
  Arm arm = testing::paper_arm();
  ASSERT_TRUE(arm.section.has_friction);
  const auto& model = arm.section.friction;
  ASSERT_EQ(model.kind, friction::Kind::lugre);
  EXPECT_DOUBLE_EQ(model.joints[0].sigma0, 98467.9088);
  EXPECT_DOUBLE_EQ(model.joints[2].w_s, 0.0917);
  const double dt = 0.008;
  for (const auto& p : model.joints) {
    for (double w : {-2.0, -0.5, -0.1, -0.03, -0.005, 0.002, 0.01, 0.05, 0.0978, 0.3, 1.0, 2.5}) {
      friction::JointFriction<double> f(model.kind, p, model.options);
      f.step(0.0, dt);
      double tau = 0;
      for (int k = 0; k < 3000; ++k) tau = f.step(w, dt);
      EXPECT_NEAR(tau, friction::stribeck_torque(p, w), 1e-9 * std::abs(friction::stribeck_torque(p, w)))
          << "w = " << w;
    }
    friction::JointFriction<double> f(model.kind, p, model.options);
    momentum::core::Random random(3);
    const double bound = std::max(p.tau_c, p.tau_s) / p.sigma0;
    const double torque_bound = std::max(p.tau_c, p.tau_s) + p.sigma1 * 2 * 3.0 + p.sigma2 * 3.0;
    for (int k = 0; k < 20000; ++k) {
      const double w = random.chance(0.1) ? 0.0 : random.uniform(-3, 3) * std::pow(10.0, -random.integer(0, 4));
      const double tau = f.step(w, dt);
      ASSERT_LE(std::abs(f.z()), bound * (1 + 1e-12)) << "step " << k;
      ASSERT_TRUE(std::isfinite(tau));
      ASSERT_LE(std::abs(tau), torque_bound);
    }
  }
}

}  // namespace
}  // namespace momentum::sim
