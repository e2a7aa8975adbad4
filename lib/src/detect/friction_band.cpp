#include "momentum/detect/friction_band.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"

namespace momentum::detect {

FrictionBand::FrictionBand(const friction::FrictionModel& model, double sigmas) : sigmas_(sigmas) {
  if (!(sigmas >= 0) || !std::isfinite(sigmas))
    throw Error("friction band: " + core::significant(sigmas, 6) + " standard deviations (must be >= 0)");
  for (std::size_t j = 0; j < model.joints.size(); ++j) {
    Joint J;
    J.parameters = model.joints[j];
    if (j < model.covariance.size()) J.covariance = model.covariance[j];
    if (J.covariance) {
      // Past the speed the model names (LuGre, Stribeck: 6 w_s, where nothing of the Stribeck
      // term is left) the gradient of |F| is constant + slope |w|: a quadratic in |w| for the
      // variance, no table.
      const auto& c = *J.covariance;
      const std::size_t n = c.parameters.size();
      for (double direction : {1.0, -1.0}) {
        Quadratic& q = direction > 0 ? J.forward : J.backward;
        double constant_of[friction::Parameters<double>::kSize], slope_of[friction::Parameters<double>::kSize];
        const double from = friction::affine_from(model.kind, J.parameters, direction, constant_of, slope_of);
        J.fast_from = direction > 0 ? from : std::max(J.fast_from, from);
        auto constant = [&constant_of](int parameter) { return constant_of[parameter]; };
        auto slope = [&slope_of](int parameter) { return slope_of[parameter]; };
        for (std::size_t a = 0; a < n; ++a)
          for (std::size_t b = 0; b < n; ++b) {
            const int pa = c.parameters[a], pb = c.parameters[b];
            const double v = c.matrix[a * n + b];
            q.a += constant(pa) * v * constant(pb);
            q.b += (constant(pa) * slope(pb) + slope(pa) * constant(pb)) * v;
            q.c += slope(pa) * v * slope(pb);
          }
      }
    }
    if (J.covariance && J.fast_from > 0)
      for (std::size_t k = 0; k <= kTableSteps; ++k) {
        const double speed = J.fast_from * static_cast<double>(k) / kTableSteps;
        for (double direction : {1.0, -1.0}) {
          const double sd = friction::steady_friction_sd(model.kind, J.parameters, *J.covariance, direction * speed);
          (direction > 0 ? J.forward_table : J.backward_table).push_back(sd * sd);
        }
      }
    empty_ = empty_ && !(sigmas > 0 && J.covariance);
    joints_.push_back(std::move(J));
  }
}

FrictionBand friction_band_from_profile(const nlohmann::json& document, double sigmas, const std::string& where) {
  if (!(sigmas > 0) || !document.is_object() || !document.contains("friction")) return {};
  friction::FrictionModel model;
  try {
    model = friction::friction_from_json(document["friction"]);
  } catch (const Error& e) {
    // The thresholds' own stages do not need the friction model (mo-observe does): go on
    // without the band, and say so.
    warn(where + ": " + e.what() + ": no friction band");
    return {};
  }
  return FrictionBand(model, sigmas);
}

}  // namespace momentum::detect
