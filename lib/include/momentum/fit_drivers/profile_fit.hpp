// Friction identification of a robot profile from logs, as mo-friction-fit runs it: read and thin
// the observed logs, leave out the slow samples, fit every joint (identify_friction), compare
// with the profile's current friction and the mirror logs, and write the fitted friction into
// the profile unless the fit is worse or failed. The tool parses its options into
// ProfileFitOptions and calls fit_profile_friction.
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "momentum/friction_fit/data.hpp"
#include "momentum/friction_fit/friction_fit.hpp"
#include "momentum/friction_fit/identify.hpp"
#include "momentum/friction_fit/report.hpp"
#include "momentum/stream/reader.hpp"

namespace momentum::drivers {

// An option value the identification cannot use; what() names the option, e.g. "--bounds:
// 'mu=1:2' is not NAME=VALUE ...". mo-friction-fit reports it as a usage error.
struct OptionError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

// A joint needs this many counted samples before its fit is written into a profile: six
// parameters from a handful of samples fit noise (one sample fits anything).
inline constexpr std::size_t kMinimumSamples = 100;

// Everything one identification needs besides the option parsing.
struct ProfileFitOptions {
  std::string profile;              // the robot profile: robot, observer gains, current friction
  std::vector<std::string> inputs;  // observed logs (t, dq<j>, r<j>), read in order; "-": stdin
  // Where the profile with the fitted friction goes: "" nowhere, "-" stdout, otherwise a file
  // (the profile itself for an in-place update; the caller holds its lock).
  std::string destination;
  // Write even a fit that is worse than the current friction or failed; an unreadable friction
  // section of the profile is then ignored (with a warning).
  bool force = false;
  friction_fit::IdentifyOptions identify;  // the fit: model, search, user bounds and fixed values, widenings
  // Joints, skip and window; the gaps, thinning and sample budget are set from the profile.
  friction_fit::SelectOptions select;
  std::string window_text;               // the window as the user wrote it (provenance)
  std::optional<double> min_speed;       // rad/s, >= 0; nullopt: 5 x each joint's velocity noise
  std::size_t max_samples = 200000;      // per joint over all inputs, as windows; 0: all
  std::vector<std::string> mirror_logs;  // none, or a forward log and its mirror (check_mirror)
};

// What an identification did.
struct ProfileFitSummary {
  friction_fit::FitReport report;     // report_text / report_json; report.outcome says what became of the profile
  std::string failure;  // why the profile was not written when it should have been; empty otherwise
};

// Opens an input by path ("-": stdin); throws momentum::Error when it cannot.
using OpenInput = std::function<std::unique_ptr<stream::Reader>(const std::string& path)>;
// Receives a one-line progress text while the joints are fitted (several times a second at
// most what the caller shows), then "" once when the fitting is over.
using ProgressLine = std::function<void(const std::string& line)>;

// Runs the identification. Throws OptionError for options that are invalid (also those only
// known invalid with the profile, e.g. a search box), momentum::Error for an unreadable profile
// or log, a joint the robot lacks, or a joint left without samples to fit. Warnings (profile
// notes, position dependence) go to momentum::warn.
ProfileFitSummary fit_profile_friction(const ProfileFitOptions& options, const OpenInput& open_input,
                                       const ProgressLine& progress = {});

// Option syntax of the identification; each throws OptionError naming `option` on a bad value.
// A number: finite, the whole text (core::parse_double).
double parse_option_number(const std::string& text, const std::string& option);
// "sigma0=6e4:1e5,w_s=0:0.2": sets bounds.lower/upper and user_bounds of each named parameter.
void parse_bounds(const std::string& text, const std::string& option, friction_fit::ParameterBounds& bounds,
                  std::array<bool, friction_fit::kParameterCount>& user_bounds);
// "sigma0=1e5,tau_c=2": the fixed values of the named parameters.
void parse_fixed(const std::string& text, const std::string& option,
                 std::array<std::optional<double>, friction_fit::kParameterCount>& fixed);
// "1,3": joint numbers >= 1.
std::vector<int> parse_joints(const std::string& text, const std::string& option);
// "A:B", "A:" or ":B": sets select.window_begin and/or window_end (stream time, s).
void parse_window(const std::string& text, const std::string& option, friction_fit::SelectOptions& select);

}  // namespace momentum::drivers
