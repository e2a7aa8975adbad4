#pragma once
// mo-calibrate's work, as a library driver: collision-free residual streams in, one Calibrator
// per signal over all of them, the report (text or JSON Lines), and the profile updated with the
// new thresholds and a provenance entry, unless a check refuses it (a max that looks like a
// contact with reject_contact, a threshold rising over max_rise times the profile's).

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "momentum/calibrate/calibration.hpp"
#include "momentum/detect/thresholds.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/stream/reader.hpp"

namespace momentum::drivers {

enum class ReportFormat { text, jsonl };

struct CalibrateStreamsOptions {
  calibrate::CalibrationOptions calibration;
  // The signals calibrated, each with its own thresholds; empty: mu and r, those the first
  // stream has.
  std::vector<detect::Signal> signals;
  // With mu: judge the rows at rest on the raw r columns when the streams have them (else on
  // mu itself). Every stream must then have them or none.
  bool rest_on_r = true;
  // Refuse, writing nothing, when a threshold would rise over this factor times the profile's
  // (>= 1; 0: no check).
  double max_rise = 0;
  // Refuse, writing nothing, when a max looks like a contact.
  bool reject_contact = false;
  // mu's moving rows count beyond this many standard deviations of the profile's friction
  // model (CalibrationOptions::friction_band, built from the profile's friction covariances
  // when calibration.friction_band is empty), >= 0; 0: none. Three covers the fitted static
  // level being off by the 2-3 uncertainties seen where the data are thin (a creep through
  // the Stribeck dip), while at speed, where the fit is tight, the band stays hundredths of a Nm.
  double friction_band_sigmas = 3;
  // A gap in time longer than this (s, > 0) starts a new stretch of the data for the
  // out-of-sample check (CalibrationResult::out_of_sample), as a new log does; the gap itself is
  // no exposure.
  double stretch_gap = 10;
  ReportFormat format = ReportFormat::text;
  // The profile to compare with and update ("": none, report only); where the updated profile
  // goes ("": the profile itself, "-": standard output, else a new file); dry_run: report only.
  std::string profile_path;
  std::string output;
  bool dry_run = false;
  // Opens an input with the tool's policies (strict, rows counted); null: stream::Reader::open.
  std::function<std::unique_ptr<stream::Reader>(const std::string& path)> open_input;
  // Called with a progress line every 65536 rows of a stream, and with "" at the end of each
  // stream (the line is then cleared); null: none.
  std::function<void(const std::string& line)> progress;
  // Receives the report (text or JSON Lines, one call per signal) instead of standard output
  // (standard error with output "-"); null: those. For callers that are no command-line tool
  // (the Python package), whose process's standard output is not theirs to write.
  std::function<void(const std::string& text)> report;

  // False, with the reason in `why`, for invalid calibration options, max_rise neither 0 nor
  // finite and >= 1, or an output without a profile.
  bool IsValid(std::string* why) const;
};

// Fewer good rows than this cannot show a joint's usual band (a second at 100 Hz): refused.
inline constexpr std::uint64_t kMinimumCalibrationRows = 100;

// Calibrates on `inputs` (paths, "-": standard input) in order. The report goes to
// options.report, else to standard output (to standard error when the profile goes to
// standard output), the calibration's warnings and a clock step (the rows after it count as a
// new stream) through momentum::warn.
// Returns the results, one per signal. Throws momentum::Error when a stream cannot be read or
// lacks t or the signals' columns, when the streams' joint counts differ from the first's or
// from the profile's, when some streams have r and others not (rest_on_r), with fewer than
// kMinimumCalibrationRows good rows, when a check refuses the update (nothing is written then),
// and what writing the profile throws. Throws momentum::Error for invalid options.
std::vector<calibrate::CalibrationResult> calibrate_streams(const std::vector<std::string>& inputs,
                                                 const CalibrateStreamsOptions& options);

}  // namespace momentum::drivers
