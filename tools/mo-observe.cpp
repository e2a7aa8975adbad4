// mo-observe: the generalized-momentum observer over a sample stream; appends the residual r
// per joint and, with a friction model in the profile, the model friction tau_f and the
// compensated residual mu.
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <string>

#include "momentum/cli/tool.hpp"
#include "momentum/core/error.hpp"
#include "momentum/core/text.hpp"
#include "momentum/drivers/observe_stream.hpp"
#include "momentum/friction/friction.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"

using namespace momentum;

int main(int argc, char** argv) {
  cli::Tool tool("mo-observe", "Estimate joint disturbance torques with a momentum observer.");
  tool.app().footer("\nExample:\n  mo-observe -p arm.json log.csv > observed.csv\n\nMore: man mo-observe");
  tool.add_stream_inputs("input stream (- or none: stdin)");
  tool.add_stream_output();
  tool.add_profile();
  tool.add_payload();
  std::optional<int> order;
  std::string k1, k2, k3, cutoff, update;
  std::optional<double> gap_factor, bridge_tolerance, deadband, velocity_cutoff, signal_sigmas, limit_factor;
  bool no_friction = false, restart_column = false, flag_column = false, no_signal_check = false;
  auto& app = tool.app();
  app.add_option("--order", order, "observer order: 1, or 2 (the paper's eq. 9/11)")->type_name("N")->check(CLI::IsMember({1, 2}));
  app.add_option("--k1", k1, "low-pass gain K1, 1/s (one value or one per joint)")->type_name("LIST");
  app.add_option("--k2", k2, "high-pass gain K2 of the second order, 1/s")->type_name("LIST");
  app.add_option("--k3", k3, "feed-forward gain K3 of the second order, 1/s")->type_name("LIST");
  app.add_option("--cutoff", cutoff, "set K1 = 2 pi HZ from a cutoff frequency")->type_name("HZ");
  app.add_option("--gap-factor", gap_factor, "bridge gaps of up to X median steps, restart after longer ones (default 5)")->type_name("X");
  app.add_option("--bridge-tolerance", bridge_tolerance, "largest position mismatch across a bridged gap, rad (default 0.001)")->type_name("RAD");
  app.add_flag("--no-signal-check", no_signal_check, "take every row at its word (no test of q, dq and currents against each other and the limits)");
  app.add_option("--signal-sigmas", signal_sigmas, "tolerance of the position-velocity disagreement and of a velocity's departure from its trend, in robust standard deviations of their own (default 10)")->type_name("Z");
  app.add_option("--limit-factor", limit_factor, "values beyond X times the URDF's limits are sensor faults (default 2)")->type_name("X");
  app.add_flag("--flag-column", flag_column, "append a column 'flagged' (1 on rows left out because their signals disagree)");
  app.add_flag("--no-friction", no_friction, "ignore the profile's friction model (r only)");
  app.add_option("--friction-deadband", deadband, "treat |dq| below W as rest in the friction model, rad/s")->type_name("W");
  app.add_option("--friction-cutoff", velocity_cutoff, "low-pass the velocity driving the friction model, Hz")->type_name("HZ");
  app.add_option("--lugre-update", update, "LuGre update: exact or semi-implicit")->type_name("NAME");
  app.add_flag("--restart-column", restart_column, "append a column 'restart' (1 where r starts again)");

  return tool.run(argc, argv, [&] {
    if (tool.inputs().size() > 1) throw cli::UsageError("one input stream at a time");
    const std::string input = tool.inputs().empty() ? "-" : tool.inputs().front();
    model::Profile profile = model::load_profile(tool.profile());
    model::select_payload(profile, tool.payload());
    const model::Model robot = model::build_model(profile);
    tool.set_chain_joints(robot.joint_names());  // a bag's joints are matched to them by name

    drivers::ObserveStreamOptions options;
    options.observer = drivers::observer_options_from_profile(profile);
    observer::ObserverOptions& o = options.observer;
    if (order) o.order = *order;
    if (!k1.empty() && !cutoff.empty()) throw cli::UsageError("give either --k1 or --cutoff, not both");
    if (!k1.empty()) o.k1 = cli::parse_number_list(k1, "--k1");
    if (!cutoff.empty()) {
      o.k1 = cli::parse_number_list(cutoff, "--cutoff");
      for (double& k : o.k1) k *= 2 * std::numbers::pi;
    }
    if (!k2.empty()) o.k2 = cli::parse_number_list(k2, "--k2");
    if (!k3.empty()) o.k3 = cli::parse_number_list(k3, "--k3");
    if (o.order == 1 && (!k2.empty() || !k3.empty())) throw cli::UsageError("--k2 and --k3 need --order 2");
    if (gap_factor) o.gap_factor = *gap_factor;
    if (bridge_tolerance) o.bridge_tolerance = *bridge_tolerance;
    if (no_signal_check) o.signals.enabled = false;
    if (signal_sigmas) o.signals.sigmas = *signal_sigmas;
    if (limit_factor) o.signals.limit_factor = *limit_factor;
    for (const auto& [option, text] : {std::pair{"--k1", &k1}, {"--cutoff", &cutoff}, {"--k2", &k2}, {"--k3", &k3}}) {
      const std::size_t count = core::split(*text).size();
      if (count > 1 && count != static_cast<std::size_t>(robot.nq))
        throw cli::UsageError(std::string(option) + ": " + std::to_string(count) + " values for " +
                              std::to_string(robot.nq) + " joints");
    }
    std::string why;
    if (!o.IsValid(&why)) throw cli::UsageError(why);
    try {
      o.joint_gains(robot.nq);  // the profile's list lengths against the chain
    } catch (const Error& e) {
      throw Error(located(profile.path.string(), 0, e.what()));
    }

    std::optional<friction::FrictionModel> friction;
    if (!no_friction) friction = drivers::friction_from_profile(profile, robot.nq);
    const bool friction_options = deadband || velocity_cutoff || !update.empty();
    if (friction_options && !friction) {
      warn("--friction-deadband, --friction-cutoff and --lugre-update have no effect without a friction model");
    }
    if (friction) {
      if (deadband) friction->options.velocity_deadband = *deadband;
      if (velocity_cutoff) friction->options.velocity_cutoff_hz = *velocity_cutoff;
      if (!update.empty() && !friction::parse_update(update, &friction->options.update))
        throw cli::UsageError("--lugre-update: '" + update + "' is not exact or semi-implicit");
      if (!friction->options.IsValid(&why)) throw cli::UsageError(why);
      options.friction = &*friction;
    }
    options.restart_column = restart_column;
    options.flag_column = flag_column;
    options.strict = tool.strict();

    cli::Progress progress(tool.show_progress());
    options.progress = [&](std::uint64_t rows, double t) {
      char line[96];
      std::snprintf(line, sizeof line, "mo-observe: %" PRIu64 " rows, t = %.3f s", rows, t);
      progress.update(line);
    };
    auto in = tool.open_input(input);
    drivers::StreamObserver observe(*in, robot, options);
    auto out = tool.open_output(*in);
    observe.run(*out);  // skipped rows and the exit status they give: cli::Tool's rows policy
    out->close();
    progress.finish();
    return cli::kSuccess;
  });
}
