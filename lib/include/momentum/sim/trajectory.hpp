// Reference trajectories for the simulator's tracking controller: positions, velocities and
// accelerations of every joint as functions of time, all twice continuously differentiable so
// that the computed-torque controller sees no steps.
//
//   paper      each joint home + A sin(2 pi f (t - T_b)) (Zhang et al. 2020: A = 0.6 rad,
//              f = 0.2 Hz), entered from rest and left to rest by fifth-degree polynomial
//              blends of T_b seconds, as in the paper;
//   multisine  per joint a sum of harmonics of a base frequency with random phases, scaled to a
//              peak amplitude and to half the joint's velocity limit: rich excitation for
//              friction and dynamics identification; same blends;
//   excite     an excitation for inertial-parameter identification (dynfit): per joint j of n a
//              sum of harmonics k = j + 1 + n i (i = 0..harmonics-1) of base_frequency / n
//              (period n / base_frequency, the same frequency band as multisine), so no
//              two joints share a frequency and the joints' motions are uncorrelated over a
//              period; Schroeder phases (low crest factor, so more amplitude fits within the
//              limits); scaled like multisine to 0.8 of the room to the nearer limit (at most
//              amplitude) and half the velocity limit; same blends. Deterministic (no seed);
//   ptp        quintic point-to-point moves (rest to rest) through random poses within the
//              joint limits, with random dwell times at each pose;
//   hold       every joint at rest at the home pose.
//
// Units: rad (m for prismatic joints), s, Hz.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "momentum/model/model.hpp"
#include "momentum/core/random.hpp"

namespace momentum::sim {

// The longest trajectory one run simulates, s (116 days; longer is refused by IsValid).
inline constexpr double kMaxTrajectoryDuration = 1e7;

enum class TrajectoryKind { paper, multisine, excite, ptp, hold };

// "paper", "multisine", "excite", "ptp", "hold".
const char* trajectory_name(TrajectoryKind kind);
// Inverse of trajectory_name; false when unknown.
bool parse_trajectory(const std::string& name, TrajectoryKind* kind);

struct TrajectoryOptions {
  TrajectoryKind kind = TrajectoryKind::paper;
  // Total length, s (> 0). The trajectory holds its last pose after it.
  double duration = 60.0;
  // Length of the quintic entry and exit blends (paper, multisine, excite), s (> 0, <= duration / 2).
  double blend = 1.0;
  // paper: amplitude of each joint's sine, rad. multisine, excite: peak amplitude before the limit and
  // velocity scaling, rad. > 0.
  double amplitude = 0.6;
  // paper: frequency of the sine, Hz (> 0).
  double frequency = 0.2;
  // multisine: harmonics k = 1..harmonics of base_frequency (Hz), random phases per joint.
  // excite: harmonics per joint, interleaved across joints (see above).
  int harmonics = 5;
  double base_frequency = 0.1;
  // ptp: poses are drawn inside the limits shrunk by this fraction of the range at each end
  // (0 <= margin < 0.5); moves take peak velocity speed_fraction times the joint's velocity
  // limit (2 rad/s when the URDF gives none), and at least min_move seconds; after each move
  // the arm rests for a time uniform in [0, max_dwell] seconds.
  double limit_margin = 0.1;
  double speed_fraction = 0.4;
  double min_move = 1.0;
  double max_dwell = 1.0;
  // Play the motion backwards in time, q_mirror(t) = q(duration - t): the same path with the
  // velocity reversed and the same acceleration at mirrored instants (the paper's friction
  // check, fit/mirror.hpp). Not for ptp, whose poses are drawn as time advances.
  bool mirror = false;

  // False (with the reason in `why`, when non-null) for values outside the ranges above, and
  // for mirror with ptp.
  bool IsValid(std::string* why) const;
};

// A quintic polynomial on [t0, t0 + T] matching position, velocity and acceleration at both
// ends. Outside the interval it is clamped to its end states (constant position, no motion).
struct Quintic {
  double t0 = 0, T = 1;
  double c[6] = {0, 0, 0, 0, 0, 0};  // in powers of (t - t0)
  double p1 = 0;                     // end position, held after t0 + T
  static Quintic make(double t0, double T, double p0, double v0, double a0, double p1,
                      double v1, double a1);
  void evaluate(double t, double& p, double& v, double& a) const;
};

class Trajectory {
 public:
  // Builds a trajectory for `model`'s joints starting at rest at or near `home` (nq). Random
  // draws (multisine phases, ptp poses and dwells) come from `seed`. Throws momentum::Error
  // when the options are invalid, home has the wrong size or lies outside the joint limits, or
  // the motion would leave a joint's limits (paper, multisine, excite: checked over the blends and
  // one full period).
  Trajectory(const TrajectoryOptions& options, const model::Model& model,
             const Eigen::VectorXd& home, std::uint64_t seed);

  // Desired q, dq, ddq at time t (s). For ptp, t must not decrease between calls (the poses
  // are drawn as time advances, in constant memory); the other kinds accept any t.
  void evaluate(double t, Eigen::VectorXd& q, Eigen::VectorXd& dq, Eigen::VectorXd& ddq);

  // The part of the motion where the arm is in its steady regime (after the entry blend and
  // before the exit blend for paper, multisine and excite), s. Contacts are placed in it.
  double steady_begin() const { return steady_begin_; }
  double steady_end() const { return steady_end_; }
  const TrajectoryOptions& options() const { return options_; }

 private:
  struct Harmonic {
    double amplitude, omega, phase;
  };
  void evaluate_forward(double t, Eigen::VectorXd& q, Eigen::VectorXd& dq, Eigen::VectorXd& ddq);
  void steady(int joint, double tau, double& p, double& v, double& a) const;
  void next_ptp_segment();
  // multisine, excite: scales each joint's harmonics to the amplitude, limits and velocity limit.
  void scale_harmonics(double period);

  TrajectoryOptions options_;
  int n_ = 0;
  Eigen::VectorXd home_, lower_, upper_, vmax_;
  std::vector<std::vector<Harmonic>> harmonics_;  // paper, multisine, excite: per joint
  std::vector<Quintic> entry_, exit_;             // paper, multisine, excite: per joint
  // ptp: the current move of each joint, ending at segment_end_, then rest until next_start_.
  std::vector<Quintic> segment_;
  double segment_end_ = 0, next_start_ = 0;
  core::Random random_;
  double steady_begin_ = 0, steady_end_ = 0;
};

}  // namespace momentum::sim
