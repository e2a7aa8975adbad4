// The local stage of a model's friction fit: a Ceres polish (bounded trust region,
// Levenberg-Marquardt, automatic derivatives) from the global search's result, and on a search
// subset the last steps on every sample.
#pragma once

#include <Eigen/Core>

#include "momentum/friction_fit/friction_fit.hpp"
#include "momentum/friction_fit/problem.hpp"

namespace momentum::friction_fit {

// Polishes fit.global (the global search on `search`, the search's samples: `problem` itself or
// a subset of its data) in scaled parameters x / scale, so that the trust region and the rank
// decisions see comparable columns. Ceres starts from the best of every run of the global
// search (the cost has several basins; the runs usually find different ones) and keeps the
// lowest end point on `search`; on a subset (fit.subset.used) Levenberg-Marquardt then takes it
// to the optimum of every sample of `problem`. With options.polish.enabled false, only the
// Jacobian is evaluated. Sets fit.parameters, the polish counters and message, and adds the
// polish's evaluations to fit.evaluations. Returns the Jacobian of the counted residuals over
// every sample of `problem` with respect to the scaled free parameters at the final estimate
// (problem.scored x free), 0 x 0 when it could not be evaluated (infeasible parameters).
Eigen::MatrixXd polish_fit(const Problem& problem, const Problem& search, const FitOptions& options, int joint,
                           const JointProgressCallback& progress, ModelFit& fit);

}  // namespace momentum::friction_fit
