// The notes of a model's friction fit: each parameter's estimate, whether the data identify it,
// and if not, why, in terms of the data (bristle transients, slow samples, a correlated
// partner, the part of the uncertainty that dominates).
#pragma once

#include "momentum/friction_fit/friction_fit.hpp"
#include "momentum/friction_fit/problem.hpp"
#include "momentum/friction_fit/uncertainty.hpp"

namespace momentum::friction_fit {

// Fills fit.estimates from fit.parameters, `uncertainty` and options.bounds: values, which
// parameters are used and free, standard errors, shifts, the quoted uncertainty, bounds reached
// and the identifiability flags and notes (FitOptions::identifiability_threshold). Needs
// fit.free, fit.correlation, fit.metrics and the covariance fields set.
void annotate_estimates(const Problem& problem, const FitOptions& options, const ParameterUncertainty& uncertainty,
                        ModelFit& fit);

}  // namespace momentum::friction_fit
