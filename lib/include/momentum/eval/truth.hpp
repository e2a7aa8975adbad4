#pragma once
// The ground truth of a campaign, as mo-sim --truth writes it (a sample stream, one row per
// contact; columns in mo-sim(1)): the one reader of it, for scoring (eval/) and plots.

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace momentum::eval {

// One true contact.
struct TruthContact {
  double t_onset = 0, t_end = 0;  // s
  int link = 0;                   // 1..n
  bool clamp = false;             // an obstacle met (a collision), else a push (a contact)
  double peak_force = NAN;        // N, NaN when the file has no f_peak column
  Eigen::Vector3d point{NAN, NAN, NAN};  // contact point in its link's frame (px, py, pz), m
  // Largest |tau_peak<j>| over the joints, Nm (NaN without such columns): how hard the contact
  // could move any residual; a contact far below the thresholds is undetectable by design.
  double peak_torque = NAN;
};

struct Truth {
  std::vector<TruthContact> contacts;  // in onset order
  std::optional<double> duration;     // s, from the "# duration: S" comment when present
};

// Reads a truth file (a path, "-": standard input): t_onset, t_end, link required; clamp,
// f_peak, px/py/pz and tau_peak<j> optional; its leading "# duration: S" comment. Throws
// momentum::Error when the file cannot be read or a required column is missing, and
// `file:line: message` for a contact whose t_end precedes its t_onset or whose link is not a
// positive whole number.
Truth read_truth(const std::string& path);

}  // namespace momentum::eval
