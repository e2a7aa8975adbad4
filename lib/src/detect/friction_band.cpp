#include "momentum/detect/friction_band.hpp"

#include <cmath>
#include <string>

#include "momentum/core/number.hpp"
#include "momentum/core/error.hpp"
#include "momentum/stream/error.hpp"

namespace momentum::detect {

FrictionBand::FrictionBand(const friction::FrictionModel& model, double sigmas) : kind_(model.kind), sigmas_(sigmas) {
  if (!(sigmas >= 0) || !std::isfinite(sigmas))
    throw Error("friction band: " + core::significant(sigmas, 6) + " standard deviations (must be >= 0)");
  for (std::size_t j = 0; j < model.joints.size(); ++j)
    joints_.push_back(Joint{model.joints[j], j < model.covariance.size() ? model.covariance[j] : std::nullopt});
}

bool FrictionBand::empty() const {
  if (!(sigmas_ > 0)) return true;
  for (const auto& joint : joints_)
    if (joint.covariance) return false;
  return true;
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
