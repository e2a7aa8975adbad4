// mo-dynfit: identify corrections to the URDF's inertial parameters from collision-free logs,
// in the observer's filtered momentum form; write them into the robot profile and report what
// the data determine.
#include <chrono>
#include <cstdio>
#include <string>

#include "momentum/cli/tool.hpp"
#include "momentum/core/error.hpp"
#include "momentum/core/file.hpp"
#include "momentum/inertia/report.hpp"
#include "momentum/fit_drivers/inertia_run.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"

using namespace momentum;

int main(int argc, char** argv) {
  cli::Tool tool("mo-dynfit", "Identify corrections to the URDF's inertial parameters from collision-free logs.");
  tool.app().footer("\nExample:\n  mo-dynfit -p arm.json --torque-held --update log.csv\n\nMore: man mo-dynfit");
  tool.add_stream_inputs("streams of collision-free motion (t, q<j>, dq<j>, tau_m<j> or i<j>); - or none: stdin");
  tool.add_profile(true);
  tool.add_strict();
  tool.add_payload();
  tool.add_seed();
  auto& app = tool.app();
  drivers::InertiaRunOptions options;
  std::string output, report_path;
  bool update = false, no_friction = false;
  double filter_gain = 0;
  // Velocity noise reaches the filtered momentum derivative K (p - F[p]) multiplied by K, and
  // biases the fit (errors in variables): a gain well below the observer's works better.
  options.identify.filter_gain = 10.0;
  app.add_flag("--update", update, "write the corrections into the profile (-p) in place");
  app.add_option("-o,--output", output, "write the updated profile to FILE instead (- for stdout)")->type_name("FILE");
  app.add_flag("--force", options.force, "write even a failed fit, or one worse than the profile's current correction");
  app.add_option("--report", report_path, "write the JSON report to FILE (- for stdout)")->type_name("FILE");
  app.add_flag("--gravity-only", options.identify.gravity_only,
               "fit only masses and first moments (m, m c): for slow motion that excites little else");
  app.add_flag("--torque-held", options.identify.torque_held,
               "each sample's motor torque was applied until the next sample (zero-order hold; mo-sim's drives)");
  app.add_flag("--no-friction", no_friction, "do not fit Coulomb + viscous friction (inputs already compensated)");
  app.add_option("--filter-gain", filter_gain, "K of the low-pass K/(s+K), 1/s (default 10)")
      ->type_name("K");
  app.add_option("--coulomb-speed", options.identify.coulomb_speed, "speed scale of the smoothed Coulomb term, rad/s (default 0.02)")
      ->type_name("W");
  options.identify.min_speed = 0.2;
  app.add_option("--min-speed", options.identify.min_speed,
                 "a joint's equation does not count while it is slower than W rad/s, nor for 8/K s after (default 0.2; 0: count all)")
      ->type_name("W");
  app.add_option("--rank-tol", options.identify.rank_tolerance,
                 "relative singular value below which a combination is not identified (default 1e-3)")->type_name("TOL");
  app.add_option("--holdout-segment", options.identify.holdout_segment, "length of the validation segments, s (default 10)")
      ->type_name("SECONDS");
  app.add_option("--holdout-every", options.identify.holdout_every, "hold out every N-th segment, 0 none (default 5)")->type_name("N");
  app.add_option("--max-projection-shift", options.limits.max_projection_shift,
                 "a failed fit when physical consistency moves an identified combination by more standard errors (8)")
      ->type_name("SE");
  app.add_option("--velocity-noise-draws", options.identify.velocity_noise_draws,
                 "fits with the velocity noise doubled, for its bias in the uncertainty; 0 none (default 2)")
      ->type_name("N");
  app.add_option("--velocity-noise-seconds", options.identify.velocity_noise_seconds,
                 "seconds of log those fits run over, 0 all (default 600)")
      ->type_name("S");

  app.add_option("--friction-probe-seconds", options.identify.friction_probe_seconds,
                 "seconds of log the friction-model probe runs over (default 0: all)")
      ->type_name("S");
  app.add_option("--max-samples", options.identify.max_samples,
                 "fit at most N samples of the logs, in stretches spread evenly over them; 0: all (default " +
                     std::to_string(options.identify.max_samples) + ")")
      ->type_name("N")
      ->check(cli::whole_number());  // an unsigned option would take -1 as 2^64 - 1
  options.identify.threads = 2;
  app.add_option("--threads", options.identify.threads,
                 "threads: 2 (default) fits the friction probe beside the fit; the results do not depend on it")
      ->type_name("N");

  return tool.run(argc, argv, [&] {
    const auto start = std::chrono::steady_clock::now();
    if (update && !output.empty()) throw cli::UsageError("--update and -o are exclusive");
    const std::string profile_name = tool.profile();
    // A profile write (--update or -o FILE) holds the written file's lock from this read to
    // the write, so that a concurrent run's section is not lost.
    const std::string destination = update ? profile_name : output;
    const auto lock = !destination.empty() && !core::is_standard_output(destination) ? cli::lock_for_update(destination)
                                                                                    : nullptr;
    model::Profile profile = model::load_profile(profile_name);
    model::select_payload(profile, tool.payload());
    tool.set_chain_joints(model::build_model(profile).joint_names());  // a bag's joints are matched to them by name
    if (filter_gain > 0) options.identify.filter_gain = filter_gain;
    options.identify.fit_friction = !no_friction;
    options.identify.seed = tool.seed();
    options.destination = update ? profile_name : output;
    std::string why;
    if (!options.IsValid(&why)) throw cli::UsageError(why);
    std::vector<std::string> inputs = tool.inputs();
    if (inputs.empty()) inputs.push_back("-");
    drivers::InertiaRunResult result = drivers::run_inertia_fit(
        profile, inputs, options, [&](const std::string& path) { return tool.open_input(path); });
    result.report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!tool.quiet()) std::fputs(inertia::report_text(result.report).c_str(), stderr);
    if (!report_path.empty()) core::write_document(report_path, inertia::report_json(result.report).dump(2) + "\n");
    if (!result.failure.empty()) throw Error(result.failure);
    return cli::kSuccess;
  });
}
