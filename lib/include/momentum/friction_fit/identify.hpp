// Friction identification for a robot: search boxes scaled to the robot and its data instead of
// the paper's small arm, and a fit that ends on a bound of its box searched again in a wider
// one, or reported as failed (mo-friction-fit writes no profile from a failed fit unless forced).
#pragma once

#include <array>
#include <limits>
#include <string>
#include <vector>

#include "momentum/friction_fit/friction_fit.hpp"

namespace momentum::friction_fit {

// What a joint's default search box is scaled to.
struct JointScale {
  double effort_limit = std::numeric_limits<double>::infinity();    // Nm (URDF); inf: unknown
  double velocity_limit = std::numeric_limits<double>::infinity();  // rad/s (URDF); inf: unknown
  double residual_scale = 0;  // Nm: 99th percentile of |r| over the counted samples
  double speed_scale = 0;     // rad/s: median |dq| over the counted samples
};

// The scale of one joint's data, with the URDF's limits of that joint (inf when unknown).
JointScale measure_scale(const JointSeries& data, double effort_limit, double velocity_limit);

// The default box for a joint. The friction the observer sees cannot be much larger than the
// residual it leaves (the filter's gain at low frequency is 1), so with T = 2 x residual_scale
// (at most the effort limit): tau_c, tau_s in (0, T]; sigma2 in [0, T / speed_scale] (viscous
// friction alone at the median speed at most T); delta_c, delta_s in [-0.3 T, 0.3 T]; w_s and
// the bristles' sigma0, sigma1 in the paper's box (w_s at most the velocity limit): a larger box
// for them made the search end in wrong basins on the paper arm at 1 kHz, and the widening
// (identify_friction) moves their bounds when the data determine them. The paper's box when the
// data give no scale (residual_scale or speed_scale 0).
ParameterBounds scaled_bounds(const JointScale& scale);

// True when a bound is a physical limit the search may not pass: the lower ends that
// friction::physical_lower_bound names (sigma1, sigma2 >= 0; tau_c, tau_s, w_s > 0, whose lower
// bounds are tiny fractions of the upper ones); side -1 lower, +1 upper.
bool physical_bound(int parameter, int side);

struct IdentifyOptions {
  FitOptions fit;  // fit.bounds: the box of parameters the user bounded (see user_bounds)
  // Scale each joint's box to its robot and data (scaled_bounds); false: fit.bounds for all.
  bool robot_bounds = true;
  // Parameters whose bounds the user gave (fit.bounds holds them): never scaled nor widened.
  std::array<bool, kParameterCount> user_bounds{};
  // Times a joint is fitted again after a parameter it needs (JointIdentification::failure
  // says which) ended on a bound that is not physical,
  // with that bound moved by widen_factor (upper x factor, lower / factor; both asymmetries'
  // bounds x factor). >= 0; factor > 1.
  int max_widenings = 2;
  double widen_factor = 4;
  int threads = 0;  // fits at once (0: one per core)

  bool IsValid(std::string* why) const;
};

// One joint's identification.
struct JointIdentification {
  JointFit fit;
  ParameterBounds bounds;   // the box of the last fit
  JointScale scale;
  int widenings = 0;        // refits in wider boxes
  // Empty when the fit is usable; otherwise why not, e.g. "sigma2 ends on its upper bound 84
  // Nm s/rad after 2 widenings". A parameter on a bound counts when the model needs it
  // determined: sigma2, tau_c, tau_s, w_s and the asymmetries always, the bristles' sigma0,
  // sigma1 only when the data determine them (ParameterEstimate::identifiable).
  std::string failure;
};

// Fits every joint (data[i] with gains[i] and limits effort[i], velocity[i], each +inf when
// unknown) as fit_joints does, then refits joints with a parameter on a bound that is not
// physical in a wider box, up to max_widenings times. Deterministic for a seed as fit_joints.
// Throws as fit_joints does, and std::invalid_argument for invalid options or sizes.
std::vector<JointIdentification> identify_friction(const std::vector<JointSeries>& data,
                                                   const std::vector<observer::Gains>& gains,
                                                   const std::vector<double>& effort_limit,
                                                   const std::vector<double>& velocity_limit,
                                                   const IdentifyOptions& options,
                                                   const JointProgressCallback& progress = {});

}  // namespace momentum::friction_fit
