// What the robot's drives report: encoder positions with a finite resolution, a velocity
// (measured with noise, or the encoder difference), and the motor current i = tau_m / k_i with
// noise; the sampling instants may jitter and samples may be lost on the way.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "momentum/core/random.hpp"

namespace momentum::sim {

enum class VelocitySource {
  measured,    // true velocity plus white noise (a velocity sensor or a fine motor encoder)
  difference,  // backward difference of the quantised positions over the actual sample interval
};

// "measured", "difference".
const char* velocity_source_name(VelocitySource source);
bool parse_velocity_source(const std::string& name, VelocitySource* source);

struct SensorOptions {
  // Encoder resolution in bits per revolution (revolute: 2 pi / 2^bits rad; prismatic:
  // 1 / 2^bits m). 0 turns quantisation off. 0..52. Default: the paper's 19-bit absolute encoder.
  int encoder_bits = 19;
  // Standard deviation of the white noise on the current, A (>= 0).
  double current_noise = 0.005;
  VelocitySource velocity = VelocitySource::measured;
  // Standard deviation of the velocity noise (measured velocity), rad/s (>= 0).
  double velocity_noise = 0.002;
  // Resolution of the reported velocity, rad/s (m/s), >= 0; 0 turns it off. Drives report
  // velocity as an integer count (a UR10e's controller in steps of 1e-4 rad/s), so a joint at
  // rest reads exactly 0 most of the time and jumps by a step.
  double velocity_resolution = 1e-3;
  // Standard deviation of the sampling-instant jitter, s (>= 0); each instant is clipped to
  // within 0.45 sample periods of its nominal time so that samples stay in order. NaN: 10% of
  // the sample period (a real controller's log: rows 10 and 12 ms apart at 100 Hz).
  double time_jitter = NAN;
  // Probability that a sample is lost (never written), 0 <= p < 1.
  double drop_rate = 0.0;

  bool IsValid(std::string* why) const;
};

// Sensor faults at single rows, injected into what the drives report (the arm's motion is not
// touched), as seen in real logs (momentum(7), "Rows whose signals disagree"):
enum class GlitchKind {
  stop,      // the row a trajectory ends on in some real logs: every velocity flips its sign and
             // jumps by velocity_jump against the motion, every current reads `current` A
             // against the motion, the positions do not move; the next row is normal again
  velocity,  // one joint's velocity jumps by velocity_jump for one row
  encoder,   // one joint's position reads `position` rad for one row (an encoder word gone bad)
  current,   // one joint's current reads `current` A more for one row; q and dq agree
};
// "stop", "velocity", "encoder", "current".
const char* glitch_kind_name(GlitchKind kind);
bool parse_glitch_kind(const std::string& name, GlitchKind* kind);

struct GlitchOptions {
  int count = 0;  // glitches at random rows of the steady part, away from contacts (>= 0)
  std::vector<GlitchKind> kinds{GlitchKind::stop, GlitchKind::velocity, GlitchKind::encoder};  // in turn
  double velocity_jump = 0.09;  // rad/s (> 0)
  double current = 5.0;         // A (finite)
  double position = 1e6;        // rad (finite)

  bool IsValid(std::string* why) const;
};

// One planned glitch: the first written row at or after t gets it.
struct Glitch {
  double t = 0;  // s
  GlitchKind kind = GlitchKind::stop;
  int joint = -1;  // 0-based; -1: every joint (stop)
};

// Applies `glitch` to a reported sample (q, dq, i of nq joints; dq_true: the true velocity,
// whose sign says which way the arm moves).
void apply_glitch(const Glitch& glitch, const GlitchOptions& options, const Eigen::VectorXd& dq_true,
                  Eigen::VectorXd& q, Eigen::VectorXd& dq, Eigen::VectorXd& i);

class Sensors {
 public:
  // `k_i` (nq): torque constants, Nm/A, nonzero; `revolute` (nq) selects the encoder unit.
  // Throws momentum::Error for invalid options or a zero torque constant.
  Sensors(const SensorOptions& options, const Eigen::VectorXd& k_i,
          const Eigen::Array<bool, Eigen::Dynamic, 1>& revolute, std::uint64_t seed);

  // Measures the true state at sample time t (s, increasing from call to call): writes the
  // reported q, dq (rad, rad/s) and current i (A). Every sample must be measured, including
  // those that will be dropped, so that velocity differences span the right interval.
  void measure(double t, const Eigen::VectorXd& q_true, const Eigen::VectorXd& dq_true,
               const Eigen::VectorXd& tau_m, Eigen::VectorXd& q, Eigen::VectorXd& dq,
               Eigen::VectorXd& i);

  // Jitter of the next sampling instant, s (clipped to +-0.45 period), drawn in sample order.
  double next_jitter(double period);
  // Whether the next sample is lost.
  bool next_dropped();

  const SensorOptions& options() const { return options_; }

 private:
  SensorOptions options_;
  Eigen::VectorXd k_i_;
  Eigen::VectorXd resolution_;  // per joint, 0 = exact
  core::Random noise_, timing_;
  Eigen::VectorXd previous_q_;
  double previous_t_ = 0;
  bool started_ = false;
};

}  // namespace momentum::sim
