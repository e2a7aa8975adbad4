// A whole simulated log: the arm of a profile follows a trajectory under its controller, with
// its true friction and a campaign of contacts, sampled by its sensors. Rows and ground truth
// are handed to callbacks as they are produced (constant memory, any length).
//
// Timing: the state is advanced in internal steps of h = 1 / (rate * m) seconds, m =
// round(internal_rate / rate) (at least 1), so output instants fall on step boundaries; the
// controller updates every round(1 / (control_rate h)) steps and holds its torque in between.
// A sample (with jitter, at the nearest step boundary) reports the state at that instant, the
// motor current of the torque then applied, the friction torque of the step that ended there,
// and the contact torque at that instant.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "momentum/friction/friction.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/sim/contacts.hpp"
#include "momentum/sim/plant.hpp"
#include "momentum/sim/sensors.hpp"
#include "momentum/sim/trajectory.hpp"

namespace momentum::sim {

// The profile's "simulation" section: what is true about the simulated robot but not known to
// the tools that observe it.
//   "simulation": {"friction": {...same schema as the "friction" section...},   // true friction
//                  "home": [q1, ...],            // rad; default: middle of each joint's limits
//                  "link_radius": [r1, ...]}     // m, contact cylinders; default 0.05
struct SimulationSection {
  bool has_friction = false;
  friction::FrictionModel friction;
  Eigen::VectorXd home;
  std::vector<double> link_radius;
};

// Reads profile.document["simulation"] (absent: no friction, default home). Throws
// momentum::Error naming the profile file when a key has the wrong type or size, or the friction
// section is invalid (as friction::friction_from_json). Unknown keys are reported through
// momentum::warn.
SimulationSection read_simulation_section(const model::Profile& profile, const model::Model& model);

struct RunOptions {
  double rate_hz = 1000.0;            // output sample rate, Hz (> 0)
  double internal_rate_hz = 10000.0;  // integration rate, Hz (>= rate_hz)
  Integrator integrator = Integrator::rk4;
  TrajectoryOptions trajectory;       // trajectory.duration is the length of the run
  ControllerOptions controller;
  SensorOptions sensors;
  ContactOptions contacts;
  GlitchOptions glitches;

  bool IsValid(std::string* why) const;
};

// The glitches of a run: options.count rows at uniformly random times in [begin, end], each at
// least kGlitchClearance s from every contact (from its onset to its end) and from the other
// glitches, kinds in turn, the joint of a one-joint kind at random. Sorted by time. Fewer when
// the run has no room for them (the caller can compare the size).
std::vector<Glitch> plan_glitches(const GlitchOptions& options, int nq, double begin, double end,
                                  const std::vector<Contact>& contacts, std::uint64_t seed);
constexpr double kGlitchClearance = 2.5;

// One output sample. The vectors are nq long.
struct Sample {
  double t = 0;                 // s
  Eigen::VectorXd q, dq, i;     // as reported by the sensors: rad, rad/s, A
  Eigen::VectorXd tau_f_true;   // true friction torque, Nm
  Eigen::VectorXd tau_c_true;   // true contact torque -J^T F (part of tau_d), Nm
};

// The ground truth of one contact, reported when it has ended.
struct ContactTruth {
  Contact contact;                                  // as planned (times, link, body point)
  Eigen::Vector3d point_world = Eigen::Vector3d::Zero();  // contact point at onset, m
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  // force on the robot at its peak, N
  double peak_force = 0;                            // |force|, N
  Eigen::VectorXd peak_torque;                      // per joint, signed -J^T F of largest |.|, Nm
};

struct RunSummary {
  std::uint64_t samples = 0;        // written
  std::uint64_t dropped = 0;        // lost by --drop-rate
  std::uint64_t glitches = 0;       // glitches written
  std::uint64_t steps = 0;          // internal steps
  int contacts = 0;
  double duration = 0;              // s
  double internal_rate_hz = 0;      // the rate actually used (a multiple of the output rate)
  // Largest |q_d - q| over the joints, rad, outside the contacts and the loop's recovery after
  // each (ten time constants of its PD part plus one integral time): what the controller did
  // not follow of its own accord (effort limits, a bandwidth the control rate cannot hold).
  double max_tracking_error = 0;
  // Largest |q_d - q| during a contact and its recovery, rad: the contacts' deflection.
  double max_contact_deflection = 0;
};

struct RunCallbacks {
  std::function<void()> start;                       // once set up and validated, before any sample
  std::function<void(const Sample&)> sample;         // every written sample, in time order
  std::function<void(const ContactTruth&)> contact;  // every contact, when it has ended
  std::function<void(double t, const Glitch&)> glitch;  // every glitch written, t of its row
  std::function<void(double t)> progress;            // now and then with the simulated time
};

// Runs the simulation. `friction` may be null (frictionless). Throws momentum::Error for
// invalid options, a home pose outside the limits, contacts that do not fit, or a state that
// stops being finite (the message suggests a higher internal rate).
RunSummary simulate(const model::Model& model, const friction::FrictionModel* friction,
                    const Eigen::VectorXd& home, const RunOptions& options, std::uint64_t seed,
                    const RunCallbacks& callbacks);

// Column names of the sample stream: t, q1..n, dq1..n, i1..n, and with truth columns
// tau_f_true1..n, tau_c_true1..n.
std::vector<std::string> sample_columns(int nq, bool with_truth);
// Fills `row` (resized) with a sample in the order of sample_columns.
void sample_row(const Sample& sample, bool with_truth, std::vector<double>& row);

// Column names of the truth table: t_onset, t_end, link, clamp, px, py, pz (body frame), wx, wy,
// wz (world, at onset), fx, fy, fz (world force at peak), f_peak, tau_peak1..n.
std::vector<std::string> truth_columns(int nq);
void truth_row(const ContactTruth& truth, std::vector<double>& row);

}  // namespace momentum::sim
