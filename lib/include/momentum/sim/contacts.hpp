// Collisions for the simulator: a campaign of contacts at random times, each on a random link at
// a random point of its surface, and the joint torques they cause through the contact point's
// Jacobian, tau = J(q)^T F.
//
// Links are modelled as cylinders of a given radius around the segment from the body's joint
// to the next joint (the tip frame for the last body). Two kinds of contact:
//   push   a force of fixed world direction whose magnitude follows a profile: raised-cosine
//          rise to the peak, hold, raised-cosine release (a person bumping into the arm);
//   clamp  a compliant obstacle (a hand, an arm) appears at the contact point, facing the
//          way the point is headed (towards where the trajectory takes it by the end of the
//          hold, else against its velocity); the arm presses into it with force k d + c dd/dt (d: penetration,
//          >= 0 only), saturated at the peak (the obstacle gives way beyond it), until the
//          hold ends, then released like a push. Its force depends on the arm's motion and
//          its controller, so it holds as long as the arm keeps pressing.
//
// Sign convention of the torques reported (truth columns, Contact peaks): the contact's share
// of the disturbance torque tau_d of the design notes, tau_c = -J^T F, so that an observer's
// residual r has the same sign. The dynamics see M ddq + C dq + g = tau_m - tau_f + J^T F.
//
// Units: s, m, N, Nm.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "momentum/model/dynamics.hpp"
#include "momentum/model/model.hpp"

namespace momentum::sim {

// How push directions are drawn.
enum class ContactDirection {
  normal,  // along the inward surface normal of the link cylinder at the point (default)
  any,     // uniform over the sphere, fixed in the world frame
};

// Parses "MIN:MAX" (or a single number, meaning MIN = MAX) into two finite numbers; false when
// the text is not of that form or MIN > MAX.
bool parse_range(const std::string& text, double* min, double* max);

// "normal", "any".
const char* direction_name(ContactDirection direction);
bool parse_direction(const std::string& name, ContactDirection* direction);

struct ContactOptions {
  int count = 0;                 // number of contacts, >= 0
  std::vector<int> links;        // body numbers 1..nq to hit; empty: 2..nq (1 when nq == 1)
  double force_min = 30.0;       // peak force range, N (0 < min <= max)
  double force_max = 150.0;
  double rise_min = 0.02, rise_max = 0.10;        // rise time range, s (> 0)
  double hold_min = 0.05, hold_max = 0.30;        // hold time range, s (>= 0)
  double release_min = 0.02, release_max = 0.10;  // release time range, s (> 0)
  // Quiet time between the end of one contact and the onset of the next, s (>= 0).
  double min_spacing = 2.0;
  ContactDirection direction = ContactDirection::normal;
  // Fraction of the contacts that are clamps (0..1); the clamps are chosen at random.
  double clamp_fraction = 0.0;
  double clamp_hold_min = 0.5, clamp_hold_max = 2.0;  // s (> 0)
  double clamp_stiffness = 30000.0;                   // N/m (> 0); ISO/TS 15066 arm: 30 N/mm
  double clamp_damping = 200.0;                       // N s/m (>= 0)
  // Link cylinder radius per body, m (>= 0); empty: 0.05 m for every body; a single value
  // applies to every body.
  std::vector<double> link_radius;

  bool IsValid(std::string* why) const;
};

// One planned contact. Times are absolute simulation times.
struct Contact {
  int link = 1;                 // body number 1..nq
  bool clamp = false;
  double t_onset = 0;           // force starts rising (push) or the obstacle appears (clamp)
  double t_rise_end = 0;        // push: peak reached
  double t_hold_end = 0;        // release starts
  double t_end = 0;             // force back to zero
  double peak = 0;              // push: peak force; clamp: force limit, N
  Eigen::Vector3d point = Eigen::Vector3d::Zero();      // contact point in the body frame, m
  // Push direction (unit, the force on the robot): in the body frame at onset when
  // direction_in_body (normal mode; turned into a world direction at onset), else world frame.
  // For a clamp: the fallback obstacle normal when the point is at rest at onset.
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();
  bool direction_in_body = true;
};

// Raised-cosine envelope of a push, 0..1, at time t (0 outside [t_onset, t_end]).
double push_envelope(const Contact& contact, double t);

// Draws the campaign: `options.count` contacts with onsets in [t_begin, t_end) and every
// contact over by t_end, separated by at least min_spacing, placed uniformly at random among
// all such arrangements; in onset order. Throws momentum::Error when the options are invalid,
// a link is out of range, or the contacts do not fit (the message says how long they need).
std::vector<Contact> plan_contacts(const ContactOptions& options, const model::Model& model,
                                   double t_begin, double t_end, std::uint64_t seed);

// Seconds the campaign needs at most: the contacts' longest durations plus the spacing.
double campaign_length(const ContactOptions& options);

// The contact in progress during the simulation: its world direction or obstacle fixed at
// onset, the force at any state, and the peaks for the ground truth.
class ActiveContact {
 public:
  // Starts `contact` at state (q, dq) at its onset time. `data` is scratch for the model.
  // `heading` (clamps only, may be null): the world point the contact point is headed for;
  // the obstacle then faces that way. Without it, or when it is within 1 mm, the obstacle
  // faces the point's velocity, and at rest the contact's drawn direction.
  ActiveContact(const Contact& contact, const model::Model& model, model::Data& data,
                const Eigen::VectorXd& q, const Eigen::VectorXd& dq,
                const ContactOptions& options, const Eigen::Vector3d* heading = nullptr);

  // World force on the robot at the contact point at time t and state (q, dq), N.
  Eigen::Vector3d force(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq);
  // Adds the contact's joint torque J^T F at (t, q, dq) to `tau` (nq), i.e. the generalized
  // force on the robot; returns the force. `record`: update the peaks.
  Eigen::Vector3d add_joint_torque(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq,
                                   Eigen::VectorXd& tau, bool record);

  const Contact& contact() const { return contact_; }
  // Largest force magnitude seen (recorded calls), N, and the force vector then.
  double peak_force() const { return peak_force_; }
  const Eigen::Vector3d& peak_force_vector() const { return peak_vector_; }
  // Per joint, the disturbance torque -(J^T F)_j of largest magnitude seen, Nm (signed).
  const Eigen::VectorXd& peak_torque() const { return peak_torque_; }
  // The world direction of a push (or the obstacle normal of a clamp), fixed at onset.
  const Eigen::Vector3d& world_direction() const { return direction_; }

 private:
  Contact contact_;
  const model::Model* model_;
  model::Data* data_;
  double stiffness_, damping_;
  Eigen::Vector3d direction_;
  Eigen::Vector3d anchor_;  // clamp: obstacle surface point, world
  model::Matrix3X<double> J_;
  double peak_force_ = 0;
  Eigen::Vector3d peak_vector_ = Eigen::Vector3d::Zero();
  Eigen::VectorXd peak_torque_;
  Eigen::VectorXd generalized_;  // scratch: J^T F
};

}  // namespace momentum::sim
