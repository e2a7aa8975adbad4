// mo-dynfit: identify corrections to the URDF's inertial parameters from collision-free logs,
// in the observer's filtered momentum form; write them into the robot profile and report what
// the data determine.
#include <chrono>
#include <cstdio>
#include <iostream>

#include "momentum/cli/tool.hpp"
#include "momentum/core/file.hpp"
#include "momentum/dynfit/identify.hpp"
#include "momentum/dynfit/regressor.hpp"
#include "momentum/dynfit/report.hpp"
#include "momentum/model/inertial_corrections.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/stream/error.hpp"

using namespace momentum;

int main(int argc, char** argv) {
  cli::Tool tool("mo-dynfit", "Identify corrections to the URDF's inertial parameters from collision-free logs.");
  tool.app().footer("\nExample:\n  mo-dynfit -p arm.json --torque-held --update log.csv\n\nMore: man mo-dynfit");
  tool.add_inputs("streams of collision-free motion (t, q<j>, dq<j>, tau_m<j> or i<j>); - or none: stdin");
  tool.add_profile(true);
  tool.add_strict();
  tool.add_payload();
  tool.add_seed();
  auto& app = tool.app();
  dynfit::IdentifyOptions options;
  std::string output, report_path;
  bool update = false, force = false, no_friction = false;
  double filter_gain = 0;
  // Velocity noise reaches the filtered momentum derivative K (p - F[p]) multiplied by K, and
  // biases the fit (errors in variables): a gain well below the observer's works better.
  options.filter_gain = 10.0;
  app.add_flag("--update", update, "write the corrections into the profile (-p) in place");
  app.add_option("-o,--output", output, "write the updated profile to FILE instead (- for stdout)")->type_name("FILE");
  app.add_flag("--force", force, "write even a failed fit, or one worse than the profile's current correction");
  app.add_option("--report", report_path, "write the JSON report to FILE (- for stdout)")->type_name("FILE");
  app.add_flag("--gravity-only", options.gravity_only,
               "fit only masses and first moments (m, m c): for slow motion that excites little else");
  app.add_flag("--torque-held", options.torque_held,
               "each sample's motor torque was applied until the next sample (zero-order hold; mo-sim's drives)");
  app.add_flag("--no-friction", no_friction, "do not fit Coulomb + viscous friction (inputs already compensated)");
  app.add_option("--filter-gain", filter_gain, "K of the low-pass K/(s+K), 1/s (default 10)")
      ->type_name("K");
  app.add_option("--coulomb-speed", options.coulomb_speed, "speed scale of the smoothed Coulomb term, rad/s (default 0.02)")
      ->type_name("W");
  options.min_speed = 0.2;
  app.add_option("--min-speed", options.min_speed,
                 "a joint's equation does not count while it is slower than W rad/s, nor for 8/K s after (default 0.2; 0: count all)")
      ->type_name("W");
  app.add_option("--rank-tol", options.rank_tolerance,
                 "relative singular value below which a combination is not identified (default 1e-3)")->type_name("TOL");
  app.add_option("--holdout-segment", options.holdout_segment, "length of the validation segments, s (default 10)")
      ->type_name("SECONDS");
  app.add_option("--holdout-every", options.holdout_every, "hold out every N-th segment, 0 none (default 5)")->type_name("N");
  dynfit::FitLimits limits;
  app.add_option("--max-projection-shift", limits.max_projection_shift,
                 "a failed fit when physical consistency moves an identified combination by more standard errors (8)")
      ->type_name("SE");
  app.add_option("--velocity-noise-draws", options.velocity_noise_draws,
                 "fits with the velocity noise doubled, for its bias in the uncertainty; 0 none (default 2)")
      ->type_name("N");
  app.add_option("--velocity-noise-seconds", options.velocity_noise_seconds,
                 "seconds of log those fits run over, 0 all (default 600)")
      ->type_name("S");

  app.add_option("--friction-probe-seconds", options.friction_probe_seconds,
                 "seconds of log the friction-model probe runs over (default 0: all)")
      ->type_name("S");
  options.threads = 2;
  app.add_option("--threads", options.threads,
                 "threads: 2 (default) fits the friction probe beside the fit; the results do not depend on it")
      ->type_name("N");

  return tool.run(argc, argv, [&] {
    const auto start = std::chrono::steady_clock::now();
    if (update && !output.empty()) throw cli::UsageError("--update and -o are exclusive");
    const std::string profile_name = tool.profile();
    // An in-place update holds the profile's lock from this read to the write.
    const auto lock = update ? cli::lock_for_update(profile_name) : nullptr;
    model::Profile profile = model::load_profile(profile_name);
    model::select_payload(profile, tool.payload());
    // Identify against the URDF as it is; the profile's current corrections are compared.
    const model::Model nominal = model::build_nominal_model(profile);
    const auto current_list = model::read_inertial_corrections(profile);
    Eigen::VectorXd current = Eigen::VectorXd::Zero(dynfit::kBodyParameters * nominal.nq);
    for (const auto& [name, delta] : current_list) {
      for (int k = 0; k < nominal.nq; ++k) {
        if (nominal.bodies[static_cast<std::size_t>(k)].name == name) current.segment<10>(10 * k) += delta;
      }
    }
    if (filter_gain > 0) options.filter_gain = filter_gain;
    options.fit_friction = !no_friction;
    options.seed = tool.seed();
    std::string why;
    if (!options.IsValid(&why) || !limits.IsValid(&why)) throw cli::UsageError(why);

    dynfit::Identifier identifier(nominal, options);
    std::vector<std::string> inputs = tool.inputs();
    if (inputs.empty()) inputs.push_back("-");
    for (const auto& path : inputs) {
      auto in = tool.open_input(path);
      dynfit::add_log(*in, nominal, identifier);
    }
    dynfit::Report report;
    report.inputs = inputs;
    report.profile = profile_name;
    report.options = options;
    report.has_current = !current_list.empty();
    report.summary = identifier.solve(report.has_current ? &current : nullptr);
    for (const auto& b : nominal.bodies) report.body_names.push_back(b.name);
    for (const auto& j : nominal.joints) report.joint_names.push_back(j.name);

    // The profile: refuse a worse correction unless forced; write a new file and rename it.
    int status = cli::kSuccess;
    std::string failure;
    const std::string destination = update ? profile_name : output;
    if (destination.empty()) {
      report.outcome = "profile not written (use --update or -o)";
    } else if (const auto failures = dynfit::fit_failures(report.summary, limits);
               !failures.empty() && !force) {
      failure = "failed fit: " + failures.front();
      for (std::size_t k = 1; k < failures.size(); ++k) failure += "; " + failures[k];
      failure += "; profile not written (--force to write anyway)";
      report.outcome = "refused: " + failure;
      status = cli::kFailure;
    } else if (dynfit::worse_than_current(report.summary) && !force) {
      failure = "the new correction explains the held-out data worse than the profile's current one; "
                "profile not written (--force to write anyway)";
      report.outcome = "refused: " + failure;
      status = cli::kFailure;
    } else {
      nlohmann::json document = profile.document;
      const nlohmann::json details = dynfit::fit_details(report);
      document["inertial_corrections"] = model::inertial_corrections_section(nominal, report.summary.delta, details);
      model::append_provenance(document, "mo-dynfit", details);
      // The corrected model must build (the payload, if any, applies on top).
      model::build_model(model::profile_from_document(document, profile.path));
      if (destination == "-") {
        core::write_document("-", document.dump(2) + "\n");
      } else {
        model::save_profile_as(document, profile, destination);
      }
      report.outcome = "corrections written to " + (destination == "-" ? std::string("stdout") : destination);
    }
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!tool.quiet()) std::fputs(dynfit::report_text(report).c_str(), stderr);
    if (!report_path.empty()) core::write_document(report_path, dynfit::report_json(report).dump(2) + "\n");
    if (!failure.empty()) throw Error(failure);
    return status;
  });
}
