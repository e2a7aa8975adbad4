// Friction identification from the observer's residual (Zhang et al. 2020, section 3, done
// with the observer's filter in the model and a least-squares polish).
//
// Model compared with the data: for one joint,  r_model = H(s) tau_f(dq),  where tau_f is the
// friction model (friction::JointFriction, driven by the measured velocity) and H(s) the
// observer's tau_d -> r transfer function (observer::FilterState with the observer's own
// discretisation), restarted wherever the observer restarted. Fitting unfiltered friction to
// the filtered r would bias every parameter (the filter delays and, for the second-order
// observer, high-passes). Cost: J = 1/2 sum over counted samples of (r - r_model)^2 (the
// paper's eq. 15), Nm^2.
//
// Pipeline per joint: a global search over the parameter box (genetic algorithm by default,
// or an NLopt global), then a Ceres polish (bounded trust region, Levenberg-Marquardt,
// automatic derivatives with ceres::Jet through the friction recursion and the filter), then
// the covariance of the estimate (a Newey-West sandwich over the observer's settling time or
// longer, see friction_fit.cpp) giving standard errors, correlations and identifiability flags.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "momentum/friction_fit/data.hpp"
#include "momentum/friction_fit/genetic.hpp"
#include "momentum/friction_fit/subset.hpp"
#include "momentum/friction/friction.hpp"
#include "momentum/observer/filter.hpp"

namespace momentum::friction_fit {

inline constexpr int kParameterCount = friction::Parameters<double>::kSize;  // 8

// Search box for the parameters, in friction::Parameters order (sigma0, sigma1, sigma2, tau_c,
// tau_s, w_s, delta_c, delta_s); units Nm/rad, Nm s/rad, Nm s/rad, Nm, Nm, rad/s, Nm, Nm.
struct ParameterBounds {
  std::array<double, kParameterCount> lower{};
  std::array<double, kParameterCount> upper{};
  // Which bound parameter i's `value` lies on, within a millionth of the box's width: -1 the
  // lower, +1 the upper, 0 neither. How the report and the uncertainty tell a parameter that
  // the box holds (i < kParameterCount).
  int side(std::size_t i, double value) const {
    const double near = 1e-6 * (upper[i] - lower[i]);
    return value >= upper[i] - near ? +1 : value <= lower[i] + near ? -1 : 0;
  }
};

// Every parameter's default search box, the paper's (friction::kDefaultSearchBox, beside the
// parameters' names and units). Combinations that make a level non-positive are infeasible
// (infinite cost).
ParameterBounds paper_bounds();

// Index 0..5 of a parameter name ("sigma0", ..., "w_s"), or -1.
int parameter_index(const std::string& name);

// Which parameters a model uses: LuGre all six; Stribeck sigma2, tau_c, tau_s, w_s;
// Coulomb-viscous sigma2, tau_c. With `asymmetric`, also delta_c (every model) and delta_s
// (LuGre, Stribeck).
std::vector<int> model_parameters(friction::Kind kind, bool asymmetric = false);

// The short genetic search that mo-friction-fit runs before the polish by default: population
// 40, 60 generations, 2 runs, stop after 20 generations without improvement (paper's crossover
// and mutation probabilities). With the polish it ends at least as low as the paper's full GA
// (200 x 300) on the paper's motion at a twentieth of the evaluations (bench/fit_bench.cpp).
GeneticOptions quick_search();

// Options of the local polish.
struct PolishOptions {
  bool enabled = true;
  int max_iterations = 100;          // trust-region iterations, >= 1
  double function_tolerance = 1e-12; // relative cost change that stops it, > 0
  double parameter_tolerance = 1e-12;  // relative step that stops it, > 0
  bool IsValid(std::string* why) const;
};

// Everything one joint's fit needs besides its data.
struct FitOptions {
  friction::Kind kind = friction::Kind::lugre;
  // Velocity conditioning and LuGre update, as the observer will use them (profile's
  // "friction" section); the fit evaluates the model exactly as the observer will.
  friction::Options friction;
  ParameterBounds bounds = paper_bounds();
  // Parameters held at a value instead of fitted (still within sense: see IsValid).
  std::array<std::optional<double>, kParameterCount> fixed{};
  GlobalOptions global;    // method, genetic settings (paper defaults), seed
  PolishOptions polish;
  // The samples the global search (and the polish from each of its runs) sees: a constant-size
  // set of windows on long data (subset.hpp).
  SubsetOptions search_subset;
  // The samples the last polish, the refit from the Stribeck fit (refit_from_static), the
  // ranking of the polished end points and the uncertainties see: a larger constant-size set of
  // windows chosen the same way, so that the fit's cost stops growing with the hours of data
  // (the uncertainties then say what this many samples determine: ModelFit::fit_subset). The
  // metrics (cost, rms, r^2) and the comparison with other fits use every sample.
  SubsetOptions fit_subset{10000, 40, 0, -1};
  // Also fit the static Stribeck model and report it beside LuGre (LuGre fits only).
  bool compare_static = true;
  // Fit direction-dependent levels (delta_c, delta_s: friction::Parameters) as well, and the
  // symmetric model beside it (JointFit::symmetric_model) so that the report says whether the
  // asymmetry helped. The static comparison is then asymmetric too.
  bool asymmetric = false;
  // A free parameter whose uncertainty (ParameterEstimate::uncertainty) exceeds this fraction
  // of its value, or of its bound interval when that is smaller, is flagged as not
  // identifiable. > 0.
  double identifiability_threshold = 0.5;

  // False (reason in `why`) for invalid nested options, a bound pair that is not finite with
  // lower < upper for a free parameter, bounds that allow a parameter the model needs
  // positive to be <= 0 (sigma0, tau_c and tau_s, w_s for LuGre/Stribeck), a fixed value
  // that is invalid the same way, or no free parameter left.
  bool IsValid(std::string* why) const;
};

// Goodness of fit over the counted samples of one joint.
struct FitMetrics {
  std::size_t samples = 0;   // counted samples
  double cost = 0;           // 1/2 sum e^2, Nm^2
  double rms = 0;            // sqrt(mean e^2), Nm
  double max_abs = 0;        // max |e|, Nm
  double r_squared = 0;      // 1 - sum e^2 / sum (r - mean r)^2 (1 = perfect; may be < 0)
};

// One parameter of a fit, with what the data say about it.
struct ParameterEstimate {
  double value = 0;
  bool free = false;            // fitted (false: fixed by the user, or unused by the model)
  bool used = false;            // the model uses it
  // Standard error (same unit as the value), from the counted samples of the fit's subset
  // (ModelFit::fit_subset: every sample on short data); NaN when not free or when the
  // covariance could not be computed.
  double standard_error = std::numeric_limits<double>::quiet_NaN();
  // How far the estimate moves (same unit) when it is fitted again with a model that resolves
  // the motion within the sample intervals where it is slow or reverses (16 steps, velocity
  // interpolated: Problem::resolve_slow) instead of once per sample: the part of the parameter
  // that rests on dynamics faster than the sample rate (LuGre's bristles, the Stribeck dip at a
  // coarse rate). NaN when not free, when the standard error alone leaves the parameter
  // undetermined (it is held in that refit), or when not computed.
  double discretization_shift = std::numeric_limits<double>::quiet_NaN();
  // How far the estimate moves (first order) when the measured velocity that drives the model
  // gets a second dose of its own white noise (the mean of 4 draws): the bias the velocity noise
  // causes in a model nonlinear in the velocity (errors in variables). 0 for noise-free
  // velocity; NaN when not free or not computed.
  double velocity_noise_shift = std::numeric_limits<double>::quiet_NaN();
  // sqrt(standard_error^2 + discretization_shift^2 + velocity_noise_shift^2): the one-sigma
  // uncertainty the report quotes and the identifiability test uses. NaN when the standard
  // error is.
  double uncertainty = std::numeric_limits<double>::quiet_NaN();
  int at_bound = 0;             // -1 at the lower bound, +1 at the upper bound, 0 inside
  bool identifiable = true;     // false: flagged, see `note`
  std::string note;             // why it is flagged (empty when it is not)
};

// The result of fitting one model to one joint.
struct ModelFit {
  friction::Kind kind = friction::Kind::lugre;
  bool asymmetric = false;                          // delta_c, delta_s fitted
  friction::Parameters<double> parameters;          // the estimate
  std::array<ParameterEstimate, kParameterCount> estimates;
  std::vector<int> free;                            // indices of the free parameters
  Eigen::MatrixXd correlation;                      // free x free, NaN when unavailable
  FitMetrics metrics;                               // of the final estimate
  FitMetrics global_metrics;                        // of the global search's best
  GlobalSummary global;                             // the global search
  SubsetSummary subset;                             // the samples the global search saw
  // The samples the polish ended on and the uncertainties come from (FitOptions::fit_subset);
  // fit_subset.counted is the uncertainties' effective sample count.
  SubsetSummary fit_subset;
  // The polish: Ceres iterations, residual and Jacobian evaluations, its message.
  int polish_iterations = 0;
  std::uint64_t polish_residual_evaluations = 0;
  std::uint64_t polish_jacobian_evaluations = 0;
  std::string polish_message;
  // Covariance diagnostics: condition number of the Jacobian with unit-norm columns
  // (infinite when rank deficient), and the geometric mean over the free parameters of the
  // sandwich variance over the white-noise variance (about 1 for white residuals).
  double condition_number = std::numeric_limits<double>::quiet_NaN();
  double autocorrelation_factor = 1;
  double velocity_noise = 0;  // estimated white noise of the measured velocity, rad/s
  bool covariance_ok = false;
  std::string covariance_note;                       // why it is missing or dubious
  std::uint64_t evaluations = 0;                     // global + polish residual evaluations
  double seconds = 0;                                // wall time of this model's fit
};

// One joint: the chosen model and (LuGre with compare_static) the Stribeck model.
struct JointFit {
  int joint = 0;
  ModelFit model;
  std::optional<ModelFit> static_model;
  // With FitOptions::asymmetric: the same model fitted without the asymmetry.
  std::optional<ModelFit> symmetric_model;
  double seconds = 0;         // CPU-thread time spent on this joint (all models), s
  double model_seconds = 0;   // of which the chosen model
  double static_seconds = 0;  // the static model
  double symmetric_seconds = 0;  // and the symmetric model
};

// Progress of one joint's fit, from the worker thread fitting it.
struct JointProgress {
  int joint = 0;
  const char* stage = "";   // "lugre", "stribeck" or "coulomb-viscous" search, or "polish"
  SearchProgress search;
};
using JointProgressCallback = std::function<void(const JointProgress&)>;

// The model's residual r_model for every sample of `data` (NaN-free data assumed), the friction
// torque before the filter in `friction_torque` when non-null. Same evaluation as the fit.
std::vector<double> predict_residual(const JointSeries& data, const observer::Gains& gains,
                                     friction::Kind kind, const friction::Parameters<double>& p,
                                     const friction::Options& options,
                                     std::vector<double>* friction_torque = nullptr);

// Metrics of a given model on the counted samples of `data`.
FitMetrics evaluate_fit(const JointSeries& data, const observer::Gains& gains, friction::Kind kind,
                        const friction::Parameters<double>& p, const friction::Options& options);

// LuGre's steady state is the Stribeck curve, so a LuGre fit (r.model) worse than the joint's
// Stribeck fit (r.static_model) is a search that missed its basin: typically the corner
// without a Stribeck effect (w_s under every counted speed), where the cost is flat in tau_s
// and w_s and no polish leaves it. Fits LuGre again from the Stribeck fit's parameters, the
// bristles at the two ends of their box (soft and damped, stiff and undamped: the data rarely
// determine them, and they trade against each other), each start polished as the search's runs
// are (on the search's and then the fit's samples: FitOptions::fit_subset), and keeps the better
// fit by the cost over all samples; its polish message then says so. Does
// nothing for another model, without a static fit, or when LuGre is not worse. fit_joint and
// fit_joints call it.
void refit_from_static(JointFit& r, const JointSeries& data, const observer::Gains& gains, const FitOptions& options,
                       std::uint64_t seed, const JointProgressCallback& progress = {});

// Fits `options.kind` (and the static model when asked) to one joint. `seed` seeds the global
// search (the caller derives one per joint). Throws std::invalid_argument for invalid options
// or gains, momentum::Error when the data are empty or the fit fails outright.
JointFit fit_joint(const JointSeries& data, const observer::Gains& gains, const FitOptions& options,
                   std::uint64_t seed, const JointProgressCallback& progress = {});

// Fits every joint of `data` (gains[i] for data[i]) on `threads` threads (0: one per core),
// the chosen model and the static comparison of each joint as separate tasks; joint i seeded
// with core::derive_seed(options.global.genetic.seed, data[i].joint) as fit_joint is, so the result
// equals fit_joint's and does not depend on the thread count or on scheduling. Throws as
// fit_joint does; exceptions from a worker are rethrown.
std::vector<JointFit> fit_joints(const std::vector<JointSeries>& data,
                                 const std::vector<observer::Gains>& gains,
                                 const FitOptions& options, int threads = 0,
                                 const JointProgressCallback& progress = {});

// Called when joint `index` (of fit_joints' data) is fitted: true, with `options` changed (e.g.
// a wider box), to fit it again with them, the new fit replacing `fit`. Called from a worker
// thread, one call at a time per joint; calls for different joints may overlap.
using FitAgain = std::function<bool(std::size_t index, const JointFit& fit, FitOptions& options)>;

// The same with options per joint (joint_options[i] for data[i], e.g. each joint's own search
// box); the model, the comparisons (compare_static, asymmetric) and the seed are those of
// joint_options[0] for every joint. With `again`, a joint is fitted again for as long as it
// says so, as soon as its last fit is done and on the first free thread. Throws
// std::invalid_argument when the sizes differ; what `again` throws is rethrown.
std::vector<JointFit> fit_joints(const std::vector<JointSeries>& data,
                                 const std::vector<observer::Gains>& gains,
                                 const std::vector<FitOptions>& joint_options, int threads = 0,
                                 const JointProgressCallback& progress = {}, const FitAgain& again = {});

}  // namespace momentum::friction_fit
