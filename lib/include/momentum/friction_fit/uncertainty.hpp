// The uncertainty of a model's friction fit: standard errors and correlations from a
// Newey-West sandwich over the observer's settling time or longer (the noise in r went through
// the observer's filter), the Jacobian's rank and condition, the parameter shift of a refit
// that resolves sub-sample dynamics, and the first-order shift from the velocity noise.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "momentum/friction_fit/data.hpp"
#include "momentum/friction_fit/friction_fit.hpp"
#include "momentum/friction_fit/problem.hpp"
#include "momentum/observer/filter.hpp"

namespace momentum::friction_fit {

// Per free parameter (in the order of problem.free), in the parameter's unit; NaN where not
// computed.
struct ParameterUncertainty {
  std::vector<double> standard_error;        // from the sandwich covariance
  std::vector<double> discretization_shift;  // ParameterEstimate::discretization_shift
  std::vector<double> velocity_noise_shift;  // ParameterEstimate::velocity_noise_shift
  std::vector<std::string> undetermined;     // why the data do not determine it; empty if they do
};

// The uncertainty of the estimate fit.parameters of `problem` (built on `data` with `gains`:
// all of a joint's samples or a subset of them), from `jacobian` (as polish_fit returns it; 0 x 0
// when unavailable) and `cost` (problem.cost at the estimate, Nm^2). `seed` seeds the velocity
// noise draws. Sets fit.condition_number, fit.autocorrelation_factor, fit.velocity_noise,
// fit.correlation, fit.covariance_ok and fit.covariance_note.
ParameterUncertainty estimate_uncertainty(const Problem& problem, const JointSeries& data,
                                          const observer::Gains& gains, const FitOptions& options,
                                          std::uint64_t seed, const Eigen::MatrixXd& jacobian, double cost,
                                          ModelFit& fit);

// The upper triangular factor R of a tall matrix a = Q R (a.cols() square), by Householder QR
// of R stacked on one chunk of rows after another: the memory of a chunk, not a copy of a.
Eigen::MatrixXd triangular_factor(const Eigen::MatrixXd& a);

// How far the residuals e stay correlated, in samples: the last lag of Geyer's initial positive
// sequence (pairs of lags summed while their sum stays positive, up to a quarter of the data),
// 0 for white residuals or fewer than 8. On long data every (size / 100000)-th product
// estimates a lag's covariance.
std::size_t correlated_lags(const std::vector<double>& e);

// The covariance of the scores (rows s_k of a matrix, taken at sample indices index[k], sorted
// ascending, one per row) that Newey and West's estimator gives with Bartlett weights over
// `lag` samples: sum over pairs of (1 - |index_k - index_l| / (lag + 1))+ s_k s_l^T. p x p for
// p score columns; O(samples).
Eigen::MatrixXd bartlett_score_covariance(const Eigen::MatrixXd& scores, const std::vector<std::size_t>& index,
                                          std::size_t lag);

}  // namespace momentum::friction_fit
