// What mo-dynfit reads and tells: a log streamed into the identifier, the fit report (text for
// stderr, JSON for --report) and the profile section it writes.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "momentum/inertia/identify.hpp"
#include "momentum/model/model.hpp"
#include "momentum/stream/reader.hpp"

namespace momentum::inertia {

// Streams one log into `identifier` (constant memory): columns t, q<j>, dq<j> and tau_m<j>
// (Nm), or i<j> (A, times the model's k_i) where tau_m<j> is absent, for j = 1..nq. The log
// starts a new filter run. Rows whose time does not increase go through Reader::reject_row
// (skipped with a warning, or an error with --strict). Throws momentum::Error (`file: message`)
// when a column is missing, or the stream has a joint column beyond the model's nq (q<nq+1>:
// the log is of another robot). Returns the number of rows read.
std::uint64_t add_log(stream::Reader& in, const model::Model& model, Identifier& identifier);

// The samples add_log() would give the identifier from `in`: its rows in time order, read and
// not otherwise looked at (for Identifier::plan()).
std::uint64_t count_log(stream::Reader& in);

// Everything the report shows.
struct Report {
  std::vector<std::string> inputs;
  std::string profile;
  IdentifyOptions options;
  IdentifySummary summary;
  std::vector<std::string> body_names;   // nq
  std::vector<std::string> joint_names;  // nq
  bool has_current = false;              // the profile had corrections (summary.rms_current)
  // Why the sample budget was not applied although set (an input that cannot be read twice
  // to count its samples ahead, such as standard input), or empty.
  std::string budget_not_applied;
  double seconds = 0;                    // wall time
  std::string outcome;                   // what happened to the profile
};

// Human report, ends with a newline: data, rank and condition number, held-out RMS per joint
// before / after (/ current), base parameters with standard errors, per-parameter table with
// identifiability (identified / combination / not excited), friction, projections, outcome.
std::string report_text(const Report& report);

// The same as JSON. NaN and infinities are written as null.
nlohmann::json report_json(const Report& report);

// True when the new correction explains the held-out data worse than the profile's current one
// (sum over joints of the mean squares, beyond a relative 1e-9).
bool worse_than_current(const IdentifySummary& summary);

// Limits past which a correction is a failed fit rather than a model of the robot.
struct FitLimits {
  // Physical consistency may move an identified combination by at most this many of its
  // standard errors (> 0): beyond, the data contradict physics. Not 3: the standard errors
  // leave out model error (Coulomb + viscous against the joints' real friction), and a sound
  // fit of two minutes of the simulated arm moves by 4; a current of the wrong sign by 10.
  double max_projection_shift = 8;
  // Coulomb or viscous friction below zero by more than this many standard errors (> 0) is
  // friction that drives the joint: the torque's sign or the model is wrong.
  double max_negative_friction = 3;
  bool IsValid(std::string* why) const;
};

// Why the fit failed, one reason per entry (empty: it did not): a projection beyond the limit,
// a body that kept its nominal parameters for a mass not positive, negative friction, or a
// corrected model that explains the held-out data worse than the nominal one. A failed fit is
// not written to a profile unless forced.
std::vector<std::string> fit_failures(const IdentifySummary& summary, const FitLimits& limits = {});

// Fit metrics stored with the correction in the profile (and in its provenance).
nlohmann::json fit_details(const Report& report);

}  // namespace momentum::inertia
