#include "momentum/friction_fit/notes.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "momentum/core/number.hpp"

namespace momentum::friction_fit {

using Params = friction::Parameters<double>;

namespace {

// Why a flagged parameter is not identifiable, in terms of the data.
std::string explain(const Problem& problem, const ModelFit& fit, int i) {
  const auto& d = *problem.data;
  const Params& p = fit.parameters;
  const double rate = 1.0 / std::max(d.median_dt(), 1e-12);
  std::string why;
  if (i == 0 || i == 1) {
    // The bristle state only leaves its steady state for ~ g / (sigma0 |w|) seconds: samples
    // where that is not small against the sample interval carry sigma0 and sigma1.
    std::size_t transient = 0;
    for (std::size_t k = 1; k < d.size(); ++k) {
      if (!d.scored[k]) continue;
      const double g = friction::sliding_level(problem.kind, p, d.dq[k]);
      if (p.sigma0 * std::abs(d.dq[k]) * problem.dt[k] / g < 3.0) ++transient;
    }
    why = "bristle dynamics settle within " +
          core::significant(friction::sliding_level(problem.kind, p, 0.0) / p.sigma0, 2) +
          " rad of travel; only " + std::to_string(transient) + " of " +
          std::to_string(fit.metrics.samples) + " samples at " + core::significant(rate, 4) +
          " Hz see them (near velocity reversals)";
  } else if (i == 5) {
    std::size_t slow = 0;
    for (std::size_t k = 0; k < d.size(); ++k)
      if (d.scored[k] && std::abs(d.dq[k]) < 2.0 * p.w_s) ++slow;
    why = "only " + std::to_string(slow) + " samples move slower than 2 w_s";
  }
  // The strongest partner, if any.
  double strongest = 0;
  int partner = -1;
  for (std::size_t a = 0; a < fit.free.size(); ++a) {
    if (fit.free[a] != i) continue;
    for (std::size_t b = 0; b < fit.free.size(); ++b) {
      if (a == b) continue;
      const double c = fit.correlation(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
      if (std::isfinite(c) && std::abs(c) > std::abs(strongest)) strongest = c, partner = fit.free[b];
    }
  }
  if (partner >= 0 && std::abs(strongest) >= 0.95) {
    if (!why.empty()) why += "; ";
    why += std::string("correlated with ") + friction::kParameterNames[partner] + " (" +
           core::fixed(strongest, 3) + ")";
  }
  return why;
}

}  // namespace

double identifiability_reference(const friction::Parameters<double>& p, int i, const FitOptions& options) {
  const auto u = static_cast<std::size_t>(i);
  const double interval = options.bounds.upper[u] - options.bounds.lower[u];
  if (i >= 6) return std::min(i == 6 ? p.tau_c : p.tau_s, interval);
  double all[kParameterCount];
  p.to_array(all);
  return std::min(std::abs(all[u]), interval);
}

void annotate_estimates(const Problem& problem, const FitOptions& options, const ParameterUncertainty& uncertainty,
                        ModelFit& fit) {
  const std::size_t nfree = problem.free.size();
  for (int i = 0; i < kParameterCount; ++i) {
    auto& e = fit.estimates[static_cast<std::size_t>(i)];
    double all[kParameterCount];
    fit.parameters.to_array(all);
    e.value = all[i];
    const auto used = model_parameters(problem.kind, options.asymmetric);
    e.used = std::find(used.begin(), used.end(), i) != used.end();
  }
  for (std::size_t j = 0; j < nfree; ++j) {
    const int i = problem.free[j];
    const auto u = static_cast<std::size_t>(i);
    auto& e = fit.estimates[u];
    e.free = true;
    e.standard_error = uncertainty.standard_error[j];
    e.discretization_shift = uncertainty.discretization_shift[j];
    e.velocity_noise_shift = uncertainty.velocity_noise_shift[j];
    e.uncertainty = e.standard_error;
    for (double part : {uncertainty.discretization_shift[j], uncertainty.velocity_noise_shift[j]})
      if (std::isfinite(part)) e.uncertainty = std::hypot(e.uncertainty, part);
    const double lo = options.bounds.lower[u], hi = options.bounds.upper[u];
    e.at_bound = options.bounds.side(u, e.value);
    const double reference = identifiability_reference(fit.parameters, i, options);
    std::string note;
    if (!uncertainty.undetermined[j].empty()) {
      e.identifiable = false;
      note = uncertainty.undetermined[j];
      const std::string why = explain(problem, fit, i);
      if (!why.empty()) note += "; " + why;
    } else if (!fit.covariance_ok) {
      e.identifiable = false;
      note = "no standard error: " + fit.covariance_note;
    } else if (!(e.uncertainty <= options.identifiability_threshold * reference)) {
      e.identifiable = false;
      note = "not identifiable: uncertainty " + core::significant(e.uncertainty, 3) +
             (reference > 0 ? (" = " + core::significant(100.0 * e.uncertainty / reference, 3) + "% of ") +
                                  (i >= 6 && reference < hi - lo ? (i == 6 ? "tau_c" : "tau_s")
                                   : reference == std::abs(e.value) ? "the value" : "the bound interval")
                            : std::string(" at a value of 0"));
      const double sub = std::isfinite(e.discretization_shift) ? std::abs(e.discretization_shift) : 0.0;
      const double vel = std::isfinite(e.velocity_noise_shift) ? std::abs(e.velocity_noise_shift) : 0.0;
      if (sub > e.standard_error && sub >= vel)
        note += ", mostly from dynamics faster than the " +
                core::significant(1.0 / std::max(problem.data->median_dt(), 1e-12), 4) + " Hz sampling";
      else if (vel > e.standard_error)
        note += ", mostly from the velocity noise";
      else
        note += ", mostly from noise in r";
      const std::string why = explain(problem, fit, i);
      if (!why.empty()) note += "; " + why;
    }
    if (e.at_bound) {
      const std::string where = e.at_bound < 0 ? "lower" : "upper";
      const std::string bound_note = "at its " + where + " bound " +
                                     core::significant(e.at_bound < 0 ? lo : hi, 6) +
                                     " (the best fit is on or beyond it; widen --bounds to see)";
      note = note.empty() ? bound_note : bound_note + "; " + note;
    }
    e.note = note;
  }
}

}  // namespace momentum::friction_fit
