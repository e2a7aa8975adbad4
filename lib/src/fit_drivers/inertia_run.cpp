#include "momentum/fit_drivers/inertia_run.hpp"

#include <filesystem>
#include <string>
#include <system_error>

#include <Eigen/Core>

#include "momentum/core/error.hpp"
#include "momentum/core/file.hpp"
#include "momentum/inertia/regressor.hpp"
#include "momentum/model/inertial_corrections.hpp"
#include "momentum/model/model.hpp"

namespace momentum::drivers {

bool InertiaRunOptions::IsValid(std::string* why) const { return identify.IsValid(why) && limits.IsValid(why); }

InertiaRunResult run_inertia_fit(const model::Profile& profile, const std::vector<std::string>& inputs, const InertiaRunOptions& options,
              const OpenInput& open) {
  std::string why;
  if (!options.IsValid(&why)) throw Error("dynfit: " + why);
  // Identify against the URDF as it is; the profile's current corrections are compared.
  const model::Model nominal = model::build_nominal_model(profile);
  const auto current_list = model::read_inertial_corrections(profile);
  Eigen::VectorXd current = Eigen::VectorXd::Zero(inertia::kBodyParameters * nominal.nq);
  for (const auto& [name, delta] : current_list) {
    for (int k = 0; k < nominal.nq; ++k) {
      if (nominal.bodies[static_cast<std::size_t>(k)].name == name) current.segment<10>(10 * k) += delta;
    }
  }
  inertia::Identifier identifier(nominal, options.identify);
  InertiaRunResult result;
  inertia::Report& report = result.report;
  if (options.identify.max_samples > 0) {
    // The sample budget spreads its stretches over all the logs, so their samples are counted
    // first: reading rows is cheap next to fitting them. An input that cannot be read twice
    // (standard input, a pipe) leaves every sample fitted.
    for (const auto& path : inputs) {
      std::error_code error;
      if (path.empty() || path == "-" || !std::filesystem::is_regular_file(path, error)) {
        report.budget_not_applied = (path.empty() || path == "-" ? std::string("standard input") : path) +
                                    " cannot be read twice to count its samples";
        break;
      }
    }
    if (report.budget_not_applied.empty()) {
      // The fit reads them again and reports their bad rows and warnings then, once.
      const WarningSink warnings = set_warning_sink([](std::string_view) {});
      const RowWarningSink rows = set_row_warning_sink([](std::string_view, std::string_view) {});
      std::uint64_t samples = 0;
      try {
        for (const auto& path : inputs) samples += inertia::count_log(*open(path));
      } catch (...) {
        set_warning_sink(warnings);
        set_row_warning_sink(rows);
        throw;
      }
      set_warning_sink(warnings);
      set_row_warning_sink(rows);
      identifier.plan(samples);
    }
  }
  for (const auto& path : inputs) inertia::add_log(*open(path), nominal, identifier);

  report.inputs = inputs;
  report.profile = profile.path.string();
  report.options = options.identify;
  report.has_current = !current_list.empty();
  report.summary = identifier.solve(report.has_current ? &current : nullptr);
  for (const auto& b : nominal.bodies) report.body_names.push_back(b.name);
  for (const auto& j : nominal.joints) report.joint_names.push_back(j.name);

  // The profile: refuse a failed or worse correction unless forced; write a new file and
  // rename it.
  const std::string& destination = options.destination;
  if (destination.empty()) {
    report.outcome = "profile not written (use --update or -o)";
    return result;
  }
  if (const auto failures = fit_failures(report.summary, options.limits); !failures.empty() && !options.force) {
    result.failure = "failed fit: " + failures.front();
    for (std::size_t k = 1; k < failures.size(); ++k) result.failure += "; " + failures[k];
    result.failure += "; profile not written (--force to write anyway)";
  } else if (worse_than_current(report.summary) && !options.force) {
    result.failure = "the new correction explains the held-out data worse than the profile's current one; "
                     "profile not written (--force to write anyway)";
  }
  if (!result.failure.empty()) {
    report.outcome = "refused: " + result.failure;
    return result;
  }
  nlohmann::json document = profile.document;
  const nlohmann::json details = fit_details(report);
  document["inertial_corrections"] = model::inertial_corrections_section(nominal, report.summary.delta, details);
  model::append_provenance(document, "mo-dynfit", details);
  // The corrected model must build (the payload, if any, applies on top).
  model::build_model(model::profile_from_document(document, profile.path));
  report.outcome = "corrections written to " + model::write_updated_profile(document, profile, destination);
  return result;
}

}  // namespace momentum::drivers
