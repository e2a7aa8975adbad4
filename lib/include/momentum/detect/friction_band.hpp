#pragma once
// The friction model's own uncertainty, as a band the compensated residual mu may stray in
// while a joint moves.
//
// mu = r - tau_f is the external torque only as far as the friction model is right. Its fit
// pins the model down where the data are dense (fast motion: Coulomb level and viscous slope,
// known to a fraction of a percent) and much less where they are few: the Stribeck dip at a
// few hundredths of a rad/s, which a joint crosses in milliseconds but may also creep through
// for a second (a slow approach, the end of a motion). There the fitted static level can be
// off by a few of its reported uncertainties, and a threshold calibrated on fast motion calls
// the difference a contact. The band is k times the first-order uncertainty of the fitted
// steady-state friction at the joint's speed (friction::steady_friction_sd, from the
// covariance mo-lugre-fit writes into the profile): a few hundredths of a Nm at speed, the
// static level's uncertainty when creeping. Calibration measures a moving row of mu by how far
// it lies beyond the band, and the detector widens the moving threshold by it, so the two
// agree on every row.

#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "momentum/friction/friction.hpp"

namespace momentum::detect {

class FrictionBand {
 public:
  // No band: width() is 0 everywhere.
  FrictionBand() = default;
  // `sigmas` (k >= 0) standard deviations of `model`'s steady state, for the joints whose
  // covariance the model holds (the others get none). Throws momentum::Error when sigmas is
  // negative or not finite.
  FrictionBand(const friction::FrictionModel& model, double sigmas);

  // Half-width of the band of joint j (0-based) at velocity w (rad/s), Nm; 0 without a band or
  // for a NaN velocity.
  double width(std::size_t j, double w) const {
    if (j >= joints_.size() || !joints_[j].covariance || std::isnan(w)) return 0;
    return sigmas_ * friction::steady_friction_sd(kind_, joints_[j].parameters, *joints_[j].covariance, w);
  }
  // k, the standard deviations; 0 for no band.
  double sigmas() const { return empty() ? 0 : sigmas_; }
  // True when no joint has a band.
  bool empty() const;

 private:
  struct Joint {
    friction::Parameters<double> parameters;
    std::optional<friction::SteadyCovariance> covariance;
  };
  friction::Kind kind_ = friction::Kind::lugre;
  double sigmas_ = 0;
  std::vector<Joint> joints_;
};

// The band a profile's friction section gives at `sigmas` standard deviations: empty when
// sigmas is 0 or the profile has no friction section or no covariance in it; also for a
// malformed friction section, which is warned about (momentum::warn, `where: friction: ...:
// no friction band`). Throws momentum::Error for a negative or non-finite `sigmas`.
FrictionBand friction_band_from_profile(const nlohmann::json& document, double sigmas, const std::string& where);

}  // namespace momentum::detect
