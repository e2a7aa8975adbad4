// The local stage of a model's friction fit: a Ceres polish (bounded trust region,
// Levenberg-Marquardt, automatic derivatives) from the global search's result, and on a search
// subset the last steps on every sample.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "momentum/friction_fit/friction_fit.hpp"
#include "momentum/friction_fit/problem.hpp"

namespace momentum::friction_fit {

// Levenberg-Marquardt on every counted sample of `problem` from scaled free parameters x close
// to its optimum (so close that a few steps do): each step costs one dual-number pass and one
// plain pass of the model. x stays within [lower, upper] (scaled); a parameter on a bound whose
// gradient points out is held there, and one with lower == upper is fixed. On return x is the
// best point found, e and jacobian are at x (when the last step was too small to matter: at the
// point before it); plain passes are added to *plain_passes. Returns the number of passes with
// derivatives, at most max_iterations + 1; 0 when the first one failed (infeasible parameters).
int refine_levenberg_marquardt(const Problem& problem, std::vector<double>& x, const std::vector<double>& lower,
                               const std::vector<double>& upper, Eigen::VectorXd& e, Eigen::MatrixXd& jacobian,
                               std::uint64_t* plain_passes, int max_iterations = 20);

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
