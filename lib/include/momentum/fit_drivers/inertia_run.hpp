// mo-dynfit's work between its command line and its outputs: the logs streamed into an
// identifier against the profile's URDF, the profile's current corrections compared, and the
// decision whether the new correction may be written (and where).
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "momentum/inertia/identify.hpp"
#include "momentum/inertia/report.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/stream/reader.hpp"

namespace momentum::drivers {

// What mo-dynfit does besides identifying: where the corrected profile goes and when not.
struct InertiaRunOptions {
  inertia::IdentifyOptions identify;
  inertia::FitLimits limits;
  // Where the corrected profile is written: empty not at all, "-" stdout, else a file (which
  // may be the profile's own path: an in-place update, under the caller's lock).
  std::string destination;
  // Write even a failed fit, or one that explains the held-out data worse than the profile's
  // current correction.
  bool force = false;
  // False (with the reason in `why`, when non-null) when identify or limits are invalid.
  bool IsValid(std::string* why) const;
};

// What a run ends with. `failure` empty: the report's outcome says what was written;
// otherwise why the profile was refused (report.outcome is "refused: " + failure).
struct InertiaRunResult {
  inertia::Report report;
  std::string failure;
};

// Opens one input by name ("-": stdin) as a stream reader; throws momentum::Error when it
// cannot.
using OpenInput = std::function<std::unique_ptr<stream::Reader>(const std::string& path)>;

// Identifies corrections to `profile`'s URDF (payload already selected) from `inputs` (each a
// log, in order; the filters restart between them), solves, and writes the corrected profile
// to options.destination unless the fit failed or is worse than the current correction (and
// not forced). report.seconds is left 0 for the caller. Throws momentum::Error for invalid
// options, unreadable inputs, a fit without samples, or a corrected model that does not build.
InertiaRunResult run_inertia_fit(const model::Profile& profile, const std::vector<std::string>& inputs, const InertiaRunOptions& options,
              const OpenInput& open);

}  // namespace momentum::drivers
