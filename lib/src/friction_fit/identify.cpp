#include "momentum/friction_fit/identify.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"

namespace momentum::friction_fit {

JointScale measure_scale(const JointSeries& data, double effort_limit, double velocity_limit) {
  JointScale s;
  s.effort_limit = effort_limit > 0 ? effort_limit : std::numeric_limits<double>::infinity();
  s.velocity_limit = velocity_limit > 0 ? velocity_limit : std::numeric_limits<double>::infinity();
  std::vector<double> r, speed;
  for (std::size_t k = 0; k < data.size(); ++k)
    if (data.scored[k]) {
      r.push_back(std::abs(data.r[k]));
      speed.push_back(std::abs(data.dq[k]));
    }
  auto quantile = [](std::vector<double>& v, double q) {
    if (v.empty()) return 0.0;
    auto at = v.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), at, v.end());
    return *at;
  };
  s.residual_scale = quantile(r, 0.99);
  s.speed_scale = quantile(speed, 0.5);
  return s;
}

ParameterBounds scaled_bounds(const JointScale& scale) {
  ParameterBounds b = paper_bounds();
  if (!(scale.residual_scale > 0) || !(scale.speed_scale > 0) || !std::isfinite(scale.residual_scale) ||
      !std::isfinite(scale.speed_scale))
    return b;
  const double torque = std::min(2.0 * scale.residual_scale, scale.effort_limit);
  for (std::size_t i = 0; i < b.lower.size(); ++i) {
    switch (friction::kParameterQuantities[i]) {
      case friction::Quantity::stiffness:
      case friction::Quantity::damping:
        break;
      case friction::Quantity::viscous:
        b.upper[i] = torque / scale.speed_scale;
        break;
      case friction::Quantity::level:
        b.upper[i] = torque;
        b.lower[i] = 1e-6 * torque;
        break;
      case friction::Quantity::velocity:
        b.upper[i] = std::min(b.upper[i], scale.velocity_limit);
        b.lower[i] = 1e-6 * b.upper[i];
        break;
      case friction::Quantity::asymmetry:
        b.upper[i] = 0.3 * torque;
        b.lower[i] = -0.3 * torque;
        break;
    }
  }
  return b;
}

bool physical_bound(int parameter, int side) { return side < 0 && friction::physical_lower_bound(parameter); }

bool IdentifyOptions::IsValid(std::string* why) const {
  if (!fit.IsValid(why)) return false;
  if (max_widenings < 0) return invalid(why, "widenings must be >= 0");
  if (!(widen_factor > 1) || !std::isfinite(widen_factor)) return invalid(why, "widen factor must be > 1");
  return true;
}

namespace {

// Parameters of the fit that end on a bound that is not physical and that the model needs
// determined: (index, side). The bristles' sigma0 and sigma1 only when the data determine them:
// a wider box for a parameter the data do not see lets it wander (sigma1 in the thousands) and
// drag the others with it.
std::vector<std::pair<int, int>> on_bounds(const ModelFit& m) {
  std::vector<std::pair<int, int>> out;
  for (int i : m.free) {
    const auto& e = m.estimates[static_cast<std::size_t>(i)];
    if (i <= 1 && !e.identifiable) continue;
    if (e.at_bound != 0 && !physical_bound(i, e.at_bound)) out.emplace_back(i, e.at_bound);
  }
  return out;
}

}  // namespace

std::vector<JointIdentification> identify_friction(const std::vector<JointSeries>& data,
                                                   const std::vector<observer::Gains>& gains,
                                                   const std::vector<double>& effort_limit,
                                                   const std::vector<double>& velocity_limit,
                                                   const IdentifyOptions& options,
                                                   const JointProgressCallback& progress) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument("friction identification: " + why);
  if (effort_limit.size() != data.size() || velocity_limit.size() != data.size())
    throw std::invalid_argument("friction identification: one pair of limits per joint needed");
  std::vector<JointIdentification> result(data.size());
  std::vector<FitOptions> joint_options(data.size(), options.fit);
  for (std::size_t i = 0; i < data.size(); ++i) {
    auto& r = result[i];
    r.scale = measure_scale(data[i], effort_limit[i], velocity_limit[i]);
    r.bounds = options.fit.bounds;
    if (options.robot_bounds) {
      const ParameterBounds scaled = scaled_bounds(r.scale);
      for (std::size_t p = 0; p < static_cast<std::size_t>(kParameterCount); ++p)
        if (!options.user_bounds[p]) {
          r.bounds.lower[p] = scaled.lower[p];
          r.bounds.upper[p] = scaled.upper[p];
        }
    }
    joint_options[i].bounds = r.bounds;
  }
  // A joint is fitted again as soon as its fit ends on a bound, while the others are still
  // being fitted.
  auto widen_or_judge = [&](std::size_t i, const JointFit& fit, FitOptions& joint) {
    auto& r = result[i];
    r.bounds = joint.bounds;
    const auto hits = on_bounds(fit.model);
    std::vector<std::pair<int, int>> widen;
    for (const auto& [p, side] : hits)
      if (!options.user_bounds[static_cast<std::size_t>(p)]) widen.emplace_back(p, side);
    if (!widen.empty() && r.widenings < options.max_widenings) {
      auto& box = joint.bounds;
      for (const auto& [p, side] : widen) {
        const auto u = static_cast<std::size_t>(p);
        if (p >= 6) {
          box.lower[u] *= options.widen_factor;
          box.upper[u] *= options.widen_factor;
        } else if (side > 0) {
          box.upper[u] *= options.widen_factor;
        } else {
          box.lower[u] /= options.widen_factor;
        }
      }
      ++r.widenings;
      return true;
    }
    // What is left on a bound: a failure when the model needs the parameter determined.
    for (const auto& [p, side] : hits) {
      const auto u = static_cast<std::size_t>(p);
      const double bound = side > 0 ? r.bounds.upper[u] : r.bounds.lower[u];
      if (!r.failure.empty()) r.failure += "; ";
      r.failure += std::string(friction::kParameterNames[p]) + " ends on its " + (side > 0 ? "upper" : "lower") +
                   " bound " + core::significant(bound, 6) +
                   (options.user_bounds[u] ? std::string(" (given by --bounds)")
                                           : " after " + std::to_string(r.widenings) + " widening" +
                                                 (r.widenings == 1 ? "" : "s"));
    }
    return false;
  };
  auto fits = fit_joints(data, gains, joint_options, options.threads, progress, widen_or_judge);
  for (std::size_t i = 0; i < data.size(); ++i) result[i].fit = std::move(fits[i]);
  return result;
}

}  // namespace momentum::friction_fit
