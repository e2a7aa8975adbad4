// A sanity check of a profile against a collision-free log, before its residuals are trusted
// (mo-model --check). It asks of the log what the rigid-body model predicts, and reports what
// disagrees, each finding with what to change:
//
//   columns   joint columns numbered from 0 (q0..q5), read as joints 1..n for the other checks;
//   units     velocity that is not the derivative of position (per joint, the least-squares
//             scale s of the trapezoidal integral of dq against the change of q: 180/pi means
//             q in degrees, pi/180 dq in deg/s), positions beyond the URDF's limits that
//             degrees explain;
//   gravity   the measured motor torque of the resting rows against g(q): per joint the
//             least-squares scale a (tau_m = a g) with its uncertainty;
//   torque    the measured motor torque of every row against the inverse dynamics
//             tau_id(q, dq, ddq) (ddq by central differences of dq), per joint the scale a of
//             tau_m = a tau_id + viscous dq + Coulomb sign(dq) + offset, friction being unknown:
//             a near -1 is a torque constant of the wrong sign, a near 1000 or 1/1000 current
//             in mA or a constant in the wrong unit, any other a far from 1 a wrong constant;
//   order     every order of the stream's joints (n <= 7) is fitted on a few hundred rows with
//             the profile's constants at their word (scale 1, friction fitted beside), and one
//             with half the misfit or less (and no implausible scale; when the chain's order
//             has one, half its misfit with free scales too) is reported, of those within 20%
//             of the best the one that moves the fewest joints.
//
// A scale is judged against its uncertainty: the fit's standard error and the model's own
// error, taken as 5% of the joint's effort limit (the URDF's nominal inertias are off by that
// much on a real arm: 13 Nm of 330 on the UR10e's shoulder), over the spread of the predicted
// torque. It is determined when that uncertainty is under 0.5, and implausible when it lies
// outside [0.5, 2] by more than three uncertainties.
//
// Streams are read in constant memory: the velocity check runs on every row, the fits on at
// most max_samples rows spread evenly over the log.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "momentum/model/model.hpp"
#include "momentum/stream/reader.hpp"

namespace momentum::model {

struct LogCheckOptions {
  // Rows kept for the torque fits, spread over the log (>= 50).
  std::size_t max_samples = 4000;
  // Rows with every |dq| below this are at rest, rad/s or m/s (> 0).
  double rest_speed = 0.02;
  // The model's error as a share of each joint's effort limit (>= 0); joints without an effort
  // limit take model_error_torque.
  double model_error_share = 0.01;
  double model_error_torque = 5.0;  // Nm (>= 0)
  // Every order of the joints is tried up to this many joints (<= 8; 0: none).
  int max_permuted_joints = 7;
  bool IsValid(std::string* why) const;
};

// A least-squares scale between measured and predicted torque for one joint.
struct ScaleFit {
  double scale = 0;        // a in tau_m = a * predicted (+ friction terms)
  double uncertainty = 0;  // standard error and model error combined; inf when undetermined
  std::size_t rows = 0;
  double unexplained = 1;  // residual variance over the measured torque's variance, 0..1
  double spread = 0;       // RMS of the predicted torque (about its mean for the full fit), Nm
  double model_error = 0;  // the model's error for the joint, Nm (LogCheckOptions)
  // The predicted torque varies by three times the model's error or more (a ratio to a torque
  // near zero means nothing), and the uncertainty is under half the scale's size (under 0.5
  // for a scale under 1).
  bool determined() const {
    return spread >= 3 * model_error && uncertainty < 0.5 * std::max(1.0, std::abs(scale));
  }
  // Determined and outside [0.5, 2] by more than three uncertainties.
  bool implausible() const;
};

struct LogCheckFinding {
  std::string kind;     // columns, units, gravity, torque, order
  int joint = 0;        // 1..n, or 0 for the whole log
  std::string message;  // what was seen and what to change (no trailing period)
};

struct LogCheckSummary {
  std::uint64_t rows = 0;          // rows read
  std::uint64_t resting_rows = 0;  // of them at rest
  int first_joint_column = 1;      // 0 when the columns are q0..q(n-1)
  std::vector<double> velocity_scale;  // per joint, NaN when the joint did not move
  std::vector<ScaleFit> gravity;       // per joint, over the resting rows
  std::vector<ScaleFit> torque;        // per joint, over the rows kept
  std::vector<int> better_order;       // stream joint (1-based) for each chain joint; empty: none
  std::vector<LogCheckFinding> findings;
};

// Reads `in` to its end and checks it against `model` (with its torque constants k_i for
// current columns i<j>). Throws momentum::Error (located at the stream) when the stream lacks
// t, q, dq and tau_m or i columns for model.nq joints (numbered from 1 or from 0), or holds
// fewer than 10 rows; and what the reader throws. Invalid options: std::invalid_argument.
LogCheckSummary check_log(stream::Reader& in, const Model& model, const LogCheckOptions& options = {});

// The summary as text for people: one line per joint with the scales, then the findings.
std::string describe_log_check(const LogCheckSummary& summary);

}  // namespace momentum::model
