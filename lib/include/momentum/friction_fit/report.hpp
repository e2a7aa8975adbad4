// What mo-friction-fit tells its user: the fit report (text for stderr, JSON for --report) and
// the profile update (the "friction" section merged, refused when worse than the current one,
// with a provenance entry).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "momentum/friction_fit/friction_fit.hpp"
#include "momentum/friction_fit/mirror.hpp"
#include "momentum/friction_fit/robustness.hpp"
#include "momentum/friction/friction.hpp"

namespace momentum::friction_fit {

// One joint of a report: the fit and what it is compared with.
struct JointReport {
  JointFit fit;
  ParameterBounds bounds;             // the search box of the fit (identify.hpp)
  int widenings = 0;                  // refits in wider boxes
  std::string failure;                // why the fit is not usable; empty when it is
  observer::Gains gains;              // the observer filter used in the model
  double sample_rate_hz = 0;          // 1 / median dt of the joint's data
  double velocity_noise = 0;          // estimated velocity noise, rad/s (estimate_velocity_noise)
  double min_speed = 0;               // slower samples did not count, rad/s (0: all counted)
  std::size_t excluded_slow = 0;      // counted samples removed by min_speed
  // The profile's current friction for this joint, evaluated on the same data (absent when
  // the profile has none).
  std::optional<friction::Kind> current_kind;
  std::optional<FitMetrics> current;
  // The mirror check (mirror.hpp) of the fitted model and of the static model, when run.
  std::optional<MirrorCheck> mirror;
  std::optional<MirrorCheck> mirror_static;
  // What the fitted model leaves, split by what it depends on (robustness.hpp).
  ResidualSplit residual_split;
};

// The warning for a joint whose residual after friction is mostly position-dependent (empty
// when it is not): names the joint and points at mo-dynfit.
std::string position_dependence_warning(const JointReport& joint);

struct FitReport {
  std::vector<std::string> inputs;    // logs fitted
  std::string profile;                // profile read
  FitOptions options;                 // model, search and polish settings
  int observer_order = 1;
  std::vector<JointReport> joints;
  double seconds = 0;                 // wall time of the whole fit
  std::string outcome;                // what happened to the profile, one line
  std::vector<std::string> mirror_logs;  // forward and mirror logs, when checked
  double mirror_position_mismatch = 0;   // rad, see MirrorReference
};

// Relative RMS improvement the asymmetric model must bring over the symmetric one to count.
inline constexpr double kAsymmetryGain = 0.05;

// Whether fitting direction-dependent levels helped on a joint (FitOptions::asymmetric): the
// asymmetric model's RMS is more than kAsymmetryGain (5%) below the symmetric model's, and
// delta_c or delta_s is more than three uncertainties away from 0. False without a symmetric
// comparison.
bool asymmetry_helped(const JointFit& fit);

// The JSON report: settings, and per joint the parameters (value, standard error, free,
// at_bound "lower"/"upper"/null, identifiable, note), correlations of the free parameters,
// metrics (rms, max_abs, r_squared, cost, samples), search and polish statistics, the static
// model in the same form, the current friction's metrics, and the mirror check. NaN and
// infinite numbers are written as null.
nlohmann::json report_json(const FitReport& report);

// The human report for stderr: one block per joint with parameters +- standard errors and
// their flags, RMS, max error, R^2, evaluations and time, then the static model's line (and
// what LuGre gains over it). Ends with a newline.
std::string report_text(const FitReport& report);

// The covariance of a fit's free steady-state parameters (sigma2, tau_c, tau_s, w_s, delta_c,
// delta_s), from their reported uncertainties (ParameterEstimate::uncertainty, which holds the
// discretization and velocity-noise shifts besides the standard error) and the fit's
// correlations. nullopt when the fit has none (covariance not computed, or not finite).
std::optional<friction::SteadyCovariance> steady_covariance(const ModelFit& fit);

// The profile's "friction" section after the fit: the current section (may be null) with the
// fitted joints replaced, each with its steady_covariance when known. The model kind and options of the current section are kept; a new
// section gets `options`. `joints` is the robot's number of joints. Throws momentum::Error
// when the result would be incomplete or mixed: no current section and not every joint fitted,
// or a current section of another model kind (or another joint count) and not every joint
// fitted.
nlohmann::json merged_friction_section(const nlohmann::json* current, int joints,
                                       const std::vector<JointFit>& fits, friction::Kind kind,
                                       const friction::Options& options);

// Joints whose new fit is worse (higher RMS on the same data, beyond a relative 1e-9) than the
// profile's current friction. Empty when nothing is worse or the profile had no friction.
std::vector<int> worse_than_current(const FitReport& report);

// Provenance details for the profile: logs, model, joints, method, seed, window, and per joint
// rms, max_abs, r_squared, samples.
nlohmann::json provenance_details(const FitReport& report, const std::string& window);

}  // namespace momentum::friction_fit
