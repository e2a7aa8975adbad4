// Is what the friction model leaves over friction at all? A residual that depends on where the
// arm is (gravity or inertia from wrong masses, a payload the profile does not know) rather
// than on how fast a joint moves is a model error, which no friction model should absorb and
// mo-dynfit(1) corrects.
//
// Method: the part of r that the fitted friction does not explain, e = r - r_model over the
// counted samples, is regressed (least squares with an intercept) once on smooth functions of
// the joint positions, and once on functions of the joint's own velocity, each feature passed
// through the observer's filter exactly as a torque would be (restarted where the observer
// restarted), so that both sides see what r sees. Position features: sin and cos of every sum
// q_a + ... + q_b of consecutive joints (the angles gravity and the inertia of a serial chain
// depend on). Velocity features: w, w |w|, w^3, sign(w), sign(w) exp(-(w / 0.1)^2) (a Stribeck
// bump): what a friction model of the wrong shape leaves. The fraction of the variance of e
// each explains is the adjusted R^2 (so that many features do not explain noise).
#pragma once

#include <cstddef>
#include <vector>

#include "momentum/friction_fit/data.hpp"
#include "momentum/observer/filter.hpp"

namespace momentum::friction_fit {

// The warning's rule: the positions explain at least `position_fraction` of the residual's
// variance (more than half: the model error is larger than everything else left), more than
// the velocity features do, and the part they explain has an RMS of at least
// `relative_size` times the RMS of r itself (so that a tiny structured misfit of a good fit,
// which positions along a periodic motion always describe in part, does not count).
struct ResidualSplitOptions {
  double position_fraction = 0.5;  // (0, 1]
  double relative_size = 0.01;     // >= 0
  // False (reason in `why`) outside those ranges.
  bool IsValid(std::string* why) const;
};

// What the friction model leaves on one joint, split by what it depends on.
struct ResidualSplit {
  bool computed = false;          // false: no positions in the data, or too few samples
  std::size_t samples = 0;        // counted samples used
  std::size_t position_features = 0;
  double residual_rms = 0;        // RMS of e about its mean, Nm
  double position_fraction = 0;   // adjusted R^2 of e on the position features, <= 1 (clamped at 0)
  double velocity_fraction = 0;   // adjusted R^2 of e on the velocity features
  double explained_rms = 0;       // RMS of the position features' fit of e, Nm
  double signal_rms = 0;          // RMS of r over the same samples, Nm
  bool position_dependent = false;  // the warning: see ResidualSplitOptions
};

// `residual` is r - r_model for every sample of `data` (predict_residual). Not computed
// (computed = false) when data.positions is empty or fewer than 10 samples per feature count.
ResidualSplit split_residual(const JointSeries& data, const observer::Gains& gains,
                             const std::vector<double>& residual, const ResidualSplitOptions& options = {});

}  // namespace momentum::friction_fit
