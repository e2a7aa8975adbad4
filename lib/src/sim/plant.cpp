#include "momentum/sim/plant.hpp"

#include <cmath>
#include <numbers>

#include "momentum/core/error.hpp"

namespace momentum::sim {

const char* integrator_name(Integrator integrator) {
  return integrator == Integrator::rk4 ? "rk4" : "semi-implicit";
}

bool parse_integrator(const std::string& name, Integrator* integrator) {
  if (name == "rk4") *integrator = Integrator::rk4;
  else if (name == "semi-implicit" || name == "semi_implicit") *integrator = Integrator::semi_implicit;
  else return false;
  return true;
}

Plant::Plant(const model::Model& model, const friction::FrictionModel* friction, Integrator integrator)
    : model_(&model), data_(model), integrator_(integrator), ldlt_(model.nq) {
  const int n = model.nq;
  if (friction) {
    if (friction->joints.size() != static_cast<std::size_t>(n))
      throw Error("simulation friction has " + std::to_string(friction->joints.size()) +
                  " joints, the chain has " + std::to_string(n));
    std::string why;
    if (!friction->IsValid(&why)) throw Error("simulation friction: " + why);
    friction_ = friction::make_joint_frictions(*friction);
  }
  q_.setZero(n);
  dq_.setZero(n);
  tau_f_.setZero(n);
  tau_c_.setZero(n);
  ddq0_.setZero(n);
  tau_m_.setZero(n);
  tau_.setZero(n);
  bias_.setZero(n);
  zero_.setZero(n);
  for (auto& k : k_q_) k.setZero(n);
  for (auto& k : k_dq_) k.setZero(n);
  q_stage_.setZero(n);
  dq_stage_.setZero(n);
  M_.setZero(n, n);
}

void Plant::reset(const Eigen::VectorXd& q, const Eigen::VectorXd& dq) {
  q_ = q;
  dq_ = dq;
  tau_f_.setZero();
  tau_c_.setZero();
  ddq0_.setZero();
  for (auto& f : friction_) f.reset();
}

void Plant::forward_dynamics(const Eigen::VectorXd& q, const Eigen::VectorXd& dq,
                             const Eigen::VectorXd& tau, Eigen::VectorXd& ddq) {
  model::mass_matrix(*model_, data_, q, M_);
  model::inverse_dynamics(*model_, data_, q, dq, zero_, bias_);
  ldlt_.compute(M_);
  ddq = tau - bias_;
  ldlt_.solveInPlace(ddq);
}

void Plant::derivative(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq,
                       ActiveContact* contact, bool record, Eigen::VectorXd& ddq) {
  tau_ = tau_m_ - tau_f_;
  if (contact) {
    if (record) tau_c_ = tau_;
    contact->add_joint_torque(t, q, dq, tau_, record);
    if (record) tau_c_ -= tau_;  // -J^T F
  } else if (record) {
    tau_c_.setZero();
  }
  forward_dynamics(q, dq, tau_, ddq);
}

void Plant::step(double t, double h, const Eigen::VectorXd& tau_m, ActiveContact* contact) {
  tau_m_ = tau_m;
  for (std::size_t j = 0; j < friction_.size(); ++j) tau_f_[j] = friction_[j].step(dq_[j], h);

  if (integrator_ == Integrator::semi_implicit) {
    derivative(t, q_, dq_, contact, true, ddq0_);
    dq_ += h * ddq0_;
    q_ += h * dq_;
    return;
  }
  // Classic RK4 on (q, dq): k_q = dq, k_dq = ddq.
  derivative(t, q_, dq_, contact, true, k_dq_[0]);
  ddq0_ = k_dq_[0];
  k_q_[0] = dq_;
  q_stage_ = q_ + 0.5 * h * k_q_[0];
  dq_stage_ = dq_ + 0.5 * h * k_dq_[0];
  derivative(t + 0.5 * h, q_stage_, dq_stage_, contact, false, k_dq_[1]);
  k_q_[1] = dq_stage_;
  q_stage_ = q_ + 0.5 * h * k_q_[1];
  dq_stage_ = dq_ + 0.5 * h * k_dq_[1];
  derivative(t + 0.5 * h, q_stage_, dq_stage_, contact, false, k_dq_[2]);
  k_q_[2] = dq_stage_;
  q_stage_ = q_ + h * k_q_[2];
  dq_stage_ = dq_ + h * k_dq_[2];
  derivative(t + h, q_stage_, dq_stage_, contact, false, k_dq_[3]);
  k_q_[3] = dq_stage_;
  q_ += (h / 6) * (k_q_[0] + 2 * k_q_[1] + 2 * k_q_[2] + k_q_[3]);
  dq_ += (h / 6) * (k_dq_[0] + 2 * k_dq_[1] + 2 * k_dq_[2] + k_dq_[3]);
}

double Plant::energy() {
  return model::kinetic_energy(*model_, data_, q_, dq_) + model::potential_energy(*model_, data_, q_);
}

Eigen::VectorXd Plant::bristle_state() const {
  Eigen::VectorXd z = Eigen::VectorXd::Zero(model_->nq);
  for (std::size_t j = 0; j < friction_.size(); ++j) z[j] = friction_[j].z();
  return z;
}

bool ControllerOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(bandwidth_hz) && bandwidth_hz > 0)) return invalid(why, "controller bandwidth must be > 0 Hz");
  if (!(std::isfinite(damping_ratio) && damping_ratio > 0)) return invalid(why, "controller damping ratio must be > 0");
  if (!(std::isfinite(rate_hz) && rate_hz > 0)) return invalid(why, "control rate must be > 0 Hz");
  if (!(std::isfinite(integral_time) && integral_time >= 0)) return invalid(why, "integral time must be >= 0 s");
  if (integral_time > 0 && !(integral_time > 1 / (2 * damping_ratio * 2 * std::numbers::pi * bandwidth_hz)))
    return invalid(why, "integral time must exceed 1 / (2 zeta w) for a stable loop");
  return true;
}

Controller::Controller(const model::Model& model, const ControllerOptions& options)
    : model_(&model), data_(model), options_(options) {
  std::string why;
  if (!options.IsValid(&why)) throw Error(why);
  const double w = 2 * std::numbers::pi * options.bandwidth_hz;
  kp_ = w * w;
  kd_ = 2 * options.damping_ratio * w;
  ki_ = options.integral_time > 0 ? kp_ / options.integral_time : 0;
  command_.setZero(model.nq);
  integral_.setZero(model.nq);
  effort_.resize(model.nq);
  for (int j = 0; j < model.nq; ++j) {
    const double e = model.joints[j].limits.effort;
    effort_[j] = options.limit_effort && std::isfinite(e) && e > 0 ? e : INFINITY;
  }
}

void Controller::compute(const Eigen::VectorXd& q, const Eigen::VectorXd& dq, const Eigen::VectorXd& q_d,
                         const Eigen::VectorXd& dq_d, const Eigen::VectorXd& ddq_d, Eigen::VectorXd& tau_m) {
  if (ki_ > 0) integral_ += (q_d - q) / options_.rate_hz;
  command_ = ddq_d + kp_ * (q_d - q) + kd_ * (dq_d - dq) + ki_ * integral_;
  model::inverse_dynamics(*model_, data_, q, dq, command_, tau_m);
  tau_m = tau_m.cwiseMax(-effort_).cwiseMin(effort_);
}

}  // namespace momentum::sim
