// The paper's independent friction check (Zhang et al. 2020, section 3, after its ref. [37]):
// run a trajectory and its mirror, the same motion played backwards in time, so that at
// mirrored instants the position and acceleration agree and the velocity is opposite. The
// rigid-body torques (M ddq + C(q,dq) dq + g, even in dq) then cancel in the difference of the
// motor torques, and for friction odd in the velocity
//     f(dq) = (tau_m(t) - tau_m_mirror(T - t)) / 2.
// This reference needs no observer and no model; the fitted friction, driven by the forward
// log's velocity, is compared with it (RMS per joint: the paper's Table 2).
// Limits: LuGre's memory (hysteresis) and any even part of the friction are not odd in the
// velocity, and controller tracking errors do not cancel; the check is an approximation, as in
// the paper.
#pragma once

#include <cstddef>
#include <vector>

#include "momentum/friction/friction.hpp"
#include "momentum/stream/reader.hpp"

namespace momentum::friction_fit {

// Reference friction along the forward log, per requested joint.
struct MirrorReference {
  std::vector<int> joints;                     // 1-based joint numbers
  std::vector<double> t;                       // forward log's times, s
  std::vector<std::vector<double>> dq;         // [joint][sample] forward velocity, rad/s
  // [joint][sample] the mirror's velocity at the mirrored instant, sign reversed (equal to dq
  // for perfect mirrors), rad/s.
  std::vector<std::vector<double>> dq_mirror;
  std::vector<std::vector<double>> friction;   // [joint][sample] reference friction, Nm
  std::size_t skipped = 0;                     // forward rows outside the mirror's time span
  double max_position_mismatch = 0;  // max |q(t) - q_mirror(T - t)| over joints and samples, rad
  double max_velocity_mismatch = 0;  // max |dq(t) + dq_mirror(T - t)|, rad/s
};

// Reads both logs whole. Columns: t, q<j>, dq<j>, and tau_m<j> (or i<j>, multiplied by
// k_i[j-1]; k_i may be empty when tau_m columns are present). The mirror is sampled at the
// mirrored time by linear interpolation: forward time t (elapsed s = t - t_first) pairs with
// mirror time t_mirror_first + (D - s), D the forward log's duration. Rows with NaN are
// skipped. Throws momentum::Error (`file: message`) for missing columns, logs with fewer than
// two rows, or durations that differ by more than 1%.
MirrorReference mirror_reference(stream::Reader& forward, stream::Reader& mirror,
                                 const std::vector<int>& joints, const std::vector<double>& k_i);

// Agreement of a friction model with the reference for joint index `index` of `reference`.
struct MirrorCheck {
  std::size_t samples = 0;    // compared samples
  std::size_t excluded = 0;   // samples after `skip` left out near slow motion (see below)
  double rms = 0;      // Nm
  double max_abs = 0;  // Nm
};

// Runs the model (JointFriction, the forward log's measured velocity, the forward log's time
// steps) and compares it with the reference on samples at least `skip` seconds after the
// first. With min_speed > 0 (rad/s), samples where either log moves slower than min_speed, and
// those within `guard` seconds of such a sample (before or after: the mirror's "after" is the
// forward log's "before"), are not compared. Near a velocity reversal the reference is not
// friction: the joint sticks (presliding friction is not odd in the velocity), the instants of
// reversal in the two logs differ by the controllers' tracking lags, and a step of 2 tau_c
// between them lands in the difference; on simulated paper-arm data these windows hold almost
// all of the reference's error. The fit leaves the same samples out (--min-speed).
MirrorCheck compare_mirror(const MirrorReference& reference, std::size_t index, friction::Kind kind,
                           const friction::Parameters<double>& parameters,
                           const friction::Options& options, double skip = 0,
                           double min_speed = 0, double guard = 0);

}  // namespace momentum::friction_fit
