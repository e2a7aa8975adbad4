// The notes of a model's friction fit: each parameter's estimate, whether the data identify it,
// and if not, why, in terms of the data (bristle transients, slow samples, a correlated
// partner, the part of the uncertainty that dominates).
#pragma once

#include "momentum/friction_fit/friction_fit.hpp"
#include "momentum/friction_fit/problem.hpp"
#include "momentum/friction_fit/uncertainty.hpp"

namespace momentum::friction_fit {

// What parameter i's uncertainty is judged against for identifiability, in its unit: the
// smaller of its magnitude (an asymmetry's: its level, tau_c or tau_s, since it is often truly
// 0) and its bound interval in options.bounds.
double identifiability_reference(const friction::Parameters<double>& p, int i, const FitOptions& options);

// Fills fit.estimates from fit.parameters, `uncertainty` and options.bounds: values, which
// parameters are used and free, standard errors, shifts, the quoted uncertainty, bounds reached
// and the identifiability flags and notes (FitOptions::identifiability_threshold). Needs
// fit.free, fit.correlation, fit.metrics and the covariance fields set.
void annotate_estimates(const Problem& problem, const FitOptions& options, const ParameterUncertainty& uncertainty,
                        ModelFit& fit);

}  // namespace momentum::friction_fit
