// The simulated arm: forward dynamics of a Model with joint friction and contact forces, and the
// computed-torque tracking controller that drives it.
//
//   M(q) ddq = tau_m - C(q,dq) dq - g(q) - tau_f + J(q)^T F,   M = M_links + diag(rotor_inertia)
//
// M from the library's mass_matrix (CRBA), C dq + g from its inverse_dynamics with ddq = 0
// (RNEA), solved with a Cholesky (LDLT) factorisation. The friction torque tau_f comes from the
// friction library's JointFriction (LuGre with its stable update, stepped once per internal
// step with the velocity at the start of the step, then held over the step); the motor torque
// is held over a step too (zero-order hold of the controller), the contact force is evaluated
// at every stage. Integrators: classic RK4 on (q, dq), or semi-implicit (symplectic) Euler.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "momentum/friction/friction.hpp"
#include "momentum/model/dynamics.hpp"
#include "momentum/model/model.hpp"
#include "momentum/sim/contacts.hpp"

namespace momentum::sim {

enum class Integrator { rk4, semi_implicit };

// "rk4", "semi-implicit".
const char* integrator_name(Integrator integrator);
bool parse_integrator(const std::string& name, Integrator* integrator);

class Plant {
 public:
  // `friction`: the true joint friction (one entry per joint), or nullptr for none. The model
  // must outlive the plant. Throws momentum::Error when the friction model has the wrong number
  // of joints or is invalid.
  Plant(const model::Model& model, const friction::FrictionModel* friction,
        Integrator integrator = Integrator::rk4);

  // Sets the state (rad, rad/s) and forgets the friction state (LuGre restarts in its steady
  // state for the first velocity it sees).
  void reset(const Eigen::VectorXd& q, const Eigen::VectorXd& dq);

  // Advances the state from time t by h seconds (> 0) with motor torque tau_m (Nm, nq) held,
  // and `contact` (may be null) acting.
  void step(double t, double h, const Eigen::VectorXd& tau_m, ActiveContact* contact);

  // ddq = M(q)^-1 (tau - C(q,dq) dq - g(q)) for a generalized force tau on the joints (Nm).
  void forward_dynamics(const Eigen::VectorXd& q, const Eigen::VectorXd& dq,
                        const Eigen::VectorXd& tau, Eigen::VectorXd& ddq);

  const Eigen::VectorXd& q() const { return q_; }
  const Eigen::VectorXd& dq() const { return dq_; }
  // Friction torque of the last step (Nm, nq): tau_f, part of the disturbance tau_d.
  const Eigen::VectorXd& friction_torque() const { return tau_f_; }
  // Contact disturbance torque -J^T F at the start of the last step (Nm, nq).
  const Eigen::VectorXd& contact_torque() const { return tau_c_; }
  // Acceleration at the start of the last step (first RK4 stage), rad/s^2.
  const Eigen::VectorXd& acceleration() const { return ddq0_; }
  // Kinetic plus potential energy of the current state, J (rotor inertia included).
  double energy();

  const model::Model& model() const { return *model_; }
  model::Data& data() { return data_; }
  bool has_friction() const { return !friction_.empty(); }
  // LuGre bristle states (rad, nq; zeros without friction).
  Eigen::VectorXd bristle_state() const;

 private:
  void derivative(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq,
                  ActiveContact* contact, bool record, Eigen::VectorXd& ddq);

  const model::Model* model_;
  model::Data data_;
  Integrator integrator_;
  std::vector<friction::JointFriction<double>> friction_;
  Eigen::VectorXd q_, dq_, tau_f_, tau_c_, ddq0_;
  // Scratch.
  Eigen::VectorXd tau_m_, tau_, bias_, zero_, k_q_[4], k_dq_[4], q_stage_, dq_stage_;
  Eigen::MatrixXd M_;
  Eigen::LDLT<Eigen::MatrixXd> ldlt_;
};

struct ControllerOptions {
  // Closed-loop bandwidth of every joint, Hz (> 0): Kp = w^2, Kd = 2 zeta w with w = 2 pi f.
  double bandwidth_hz = 5.0;
  double damping_ratio = 1.0;  // zeta, > 0
  // Rate at which the torque is recomputed (held in between), Hz (> 0).
  double rate_hz = 1000.0;
  // Saturate the motor torque at the URDF effort limits (where finite).
  bool limit_effort = true;
  // Integral time of the position loop, s (>= 0; 0: PD only): Ki = Kp / Ti. A real position
  // controller integrates the error, so a joint that stops on stiction ends up holding torque
  // against it, and after a push is released unloads it over about Ti: the residual of a
  // resting joint drifts with no contact. Stable for Ti > 1 / (2 zeta w).
  double integral_time = 2.0;

  bool IsValid(std::string* why) const;
};

// Computed torque with PID: tau_m = M(q) (ddq_d + Kp e + Kd de + Ki int e) + C(q,dq) dq + g(q),
// i.e. the library's inverse dynamics at the commanded acceleration. It knows the rigid-body
// model exactly but neither friction nor contacts: the feedback terms absorb those.
class Controller {
 public:
  Controller(const model::Model& model, const ControllerOptions& options);
  // Motor torque (Nm, nq) for state (q, dq) and desired (q_d, dq_d, ddq_d).
  void compute(const Eigen::VectorXd& q, const Eigen::VectorXd& dq, const Eigen::VectorXd& q_d,
               const Eigen::VectorXd& dq_d, const Eigen::VectorXd& ddq_d, Eigen::VectorXd& tau_m);
  const ControllerOptions& options() const { return options_; }

 private:
  const model::Model* model_;
  model::Data data_;
  ControllerOptions options_;
  double kp_, kd_, ki_;
  Eigen::VectorXd command_, effort_, integral_;
};

}  // namespace momentum::sim
