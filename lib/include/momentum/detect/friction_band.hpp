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
// covariance mo-friction-fit writes into the profile): a few hundredths of a Nm at speed, the
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
    const Joint& J = joints_[j];
    const double speed = std::abs(w);
    // Past the Stribeck dip the variance is a quadratic in the speed (tau_c, sigma2 and
    // delta_c): the detector asks on every row, most of them at speed.
    if (speed >= J.fast_from) {
      const Quadratic& q = w < 0 ? J.backward : J.forward;
      return sigmas_ * std::sqrt(std::max(0.0, q.a + speed * (q.b + speed * q.c)));
    }
    // In the dip, the variance tabulated over the speed and interpolated (within 1e-3 of the
    // propagation: the table has kTableSteps steps up to fast_from).
    const std::vector<double>& table = w < 0 ? J.backward_table : J.forward_table;
    const double at = speed / J.fast_from * kTableSteps;
    const auto k = std::min(static_cast<std::size_t>(at), kTableSteps - 1);
    const double f = at - static_cast<double>(k);
    return sigmas_ * std::sqrt(std::max(0.0, table[k] + f * (table[k + 1] - table[k])));
  }
  // k, the standard deviations; 0 for no band.
  double sigmas() const { return empty_ ? 0 : sigmas_; }
  // True when no joint has a band.
  bool empty() const { return empty_; }

 private:
  // The variance a + b |w| + c w^2 of one direction, Nm^2.
  struct Quadratic {
    double a = 0, b = 0, c = 0;
  };
  struct Joint {
    friction::Parameters<double> parameters;
    std::optional<friction::SteadyCovariance> covariance;
    double fast_from = INFINITY;  // rad/s: the quadratics hold from here on
    Quadratic forward, backward;
    std::vector<double> forward_table, backward_table;  // variance at k fast_from / kTableSteps
  };
  static constexpr std::size_t kTableSteps = 512;
  double sigmas_ = 0;
  bool empty_ = true;
  std::vector<Joint> joints_;
};

// The band a profile's friction section gives at `sigmas` standard deviations: empty when
// sigmas is 0 or the profile has no friction section or no covariance in it; also for a
// malformed friction section, which is warned about (momentum::warn, `where: friction: ...:
// no friction band`). Throws momentum::Error for a negative or non-finite `sigmas`.
FrictionBand friction_band_from_profile(const nlohmann::json& document, double sigmas, const std::string& where);

}  // namespace momentum::detect
