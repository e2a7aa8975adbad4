// mo-sim: simulate a profile's arm following a trajectory, with its true friction and a campaign
// of collisions; write what its drives would report, and the ground truth.
#include <chrono>
#include <cmath>
#include <optional>
#include <string>

#include "momentum/cli/progress_text.hpp"
#include "momentum/cli/tool.hpp"
#include "momentum/core/number.hpp"
#include "momentum/core/text.hpp"
#include "momentum/sim/log.hpp"

using namespace momentum;

namespace {

void range_option(CLI::App& app, const std::string& name, std::string& text, const std::string& help) {
  app.add_option(name, text, help)->type_name("MIN:MAX")->capture_default_str();
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("mo-sim", "Simulate an arm with friction and collisions: a sample stream and its ground truth.");
  tool.app().footer("\nExample:\n  mo-sim -p arm.json --collisions 50 --truth truth.csv > log.csv\n\nMore: man mo-sim");
  tool.add_profile();
  tool.add_seed();
  CLI::App& app = tool.app();

  sim::RunOptions run;
  sim::LogOutput output;
  bool no_friction = false;
  app.add_option("-o,--output", output.path, "output file (default: stdout)")->type_name("FILE");
  app.add_option("--output-format", output.format, "csv or bin")->check(CLI::IsMember({"csv", "bin"}))->capture_default_str();
  app.add_flag("--line-buffered", output.line_buffered, "flush every row");
  app.add_option("--truth", output.truth_path, "write one row per contact (ground truth) to FILE")->type_name("FILE");
  app.add_flag("--with-truth-columns", output.truth_columns, "add true friction and contact torques per joint");
  auto* candump_flag = app.add_flag("--candump", output.candump, "write candump -L text of the drives' frames instead of a stream");
  app.add_option("--dbc", output.dbc_path, "how the drives encode their values (with --candump)")->type_name("FILE")->needs(candump_flag);

  std::string trajectory = "paper", integrator = "rk4", velocity = "measured", direction = "normal";
  std::optional<double> duration;
  app.add_option("--trajectory", trajectory, "paper, multisine, excite, ptp or hold")
      ->check(CLI::IsMember({"paper", "multisine", "excite", "ptp", "hold"}))->capture_default_str();
  app.add_flag("--mirror", run.trajectory.mirror, "play the trajectory backwards in time (the mirror of mo-lugre-fit --mirror)");
  app.add_option("--duration", duration, "length in seconds (default: 60, longer for many collisions)")->type_name("S");
  app.add_option("--rate", run.rate_hz, "output sample rate (125 for the paper)")->type_name("HZ")->capture_default_str();
  app.add_option("--amplitude", run.trajectory.amplitude, "paper/multisine/excite amplitude")->type_name("RAD")->capture_default_str();
  app.add_option("--frequency", run.trajectory.frequency, "paper sine frequency")->type_name("HZ")->capture_default_str();
  app.add_option("--blend", run.trajectory.blend, "quintic entry and exit blends")->type_name("S")->capture_default_str();
  app.add_option("--internal-rate", run.internal_rate_hz, "integration rate")->type_name("HZ")->capture_default_str();
  app.add_option("--integrator", integrator, "rk4 or semi-implicit")
      ->check(CLI::IsMember({"rk4", "semi-implicit"}))->capture_default_str();
  app.add_option("--control-rate", run.controller.rate_hz, "controller update rate")->type_name("HZ")->capture_default_str();
  app.add_option("--bandwidth", run.controller.bandwidth_hz, "controller closed-loop bandwidth")->type_name("HZ")->capture_default_str();
  app.add_option("--integral-time", run.controller.integral_time, "integral time of the position loop, 0 none")->type_name("S")->capture_default_str();
  app.add_flag("--no-friction", no_friction, "ignore the profile's simulation.friction");

  app.add_option("--encoder-bits", run.sensors.encoder_bits, "encoder resolution per revolution, 0: exact")->type_name("N")->capture_default_str();
  app.add_option("--current-noise", run.sensors.current_noise, "current noise, standard deviation")->type_name("A")->capture_default_str();
  app.add_option("--velocity", velocity, "measured or difference (of encoder positions)")
      ->check(CLI::IsMember({"measured", "difference"}))->capture_default_str();
  app.add_option("--velocity-noise", run.sensors.velocity_noise, "measured velocity noise, standard deviation")->type_name("RAD/S")->capture_default_str();
  app.add_option("--time-jitter", run.sensors.time_jitter, "sampling instant jitter, standard deviation (default 10% of the period)")->type_name("S");
  app.add_option("--velocity-resolution", run.sensors.velocity_resolution, "step of the reported velocity, 0 none")->type_name("RAD/S")->capture_default_str();
  app.add_option("--drop-rate", run.sensors.drop_rate, "probability that a sample is lost")->type_name("P")->capture_default_str();

  std::string links;
  sim::ContactRanges ranges;
  app.add_option("--collisions", run.contacts.count, "number of contacts at random times")->type_name("N")->capture_default_str();
  app.add_option("--links", links, "links to hit, e.g. 2,3 (default: 2..n)")->type_name("LIST");
  range_option(app, "--force", ranges.force, "peak force range, N");
  range_option(app, "--rise", ranges.rise, "rise time range, s");
  range_option(app, "--hold", ranges.hold, "hold time range, s");
  range_option(app, "--release", ranges.release, "release time range, s");
  app.add_option("--min-spacing", run.contacts.min_spacing, "quiet time between contacts")->type_name("S")->capture_default_str();
  app.add_option("--direction", direction, "normal (to the link surface) or any")
      ->check(CLI::IsMember({"normal", "any"}))->capture_default_str();
  app.add_option("--clamping", run.contacts.clamp_fraction, "fraction of contacts that are clamps")->type_name("F")->capture_default_str();
  range_option(app, "--clamp-hold", ranges.clamp_hold, "clamp hold time range, s");
  app.add_option("--clamp-stiffness", run.contacts.clamp_stiffness, "clamping obstacle stiffness")->type_name("N/M")->capture_default_str();
  std::string glitch_kinds;
  app.add_option("--glitches", run.glitches.count, "sensor glitches at random rows away from the contacts (listed as comments of --truth)")->type_name("N")->capture_default_str();
  app.add_option("--glitch-kinds", glitch_kinds, "glitch kinds in turn: stop, velocity, encoder, current (default stop,velocity,encoder)")->type_name("LIST");
  app.add_option("--glitch-current", run.glitches.current, "current of a stop or current glitch")->type_name("A")->capture_default_str();
  app.add_option("--glitch-velocity", run.glitches.velocity_jump, "velocity jump of a stop or velocity glitch")->type_name("RAD/S")->capture_default_str();
  bool mixed = false;
  app.add_flag("--mixed", mixed, "half impacts on stiff obstacles, half slow pushes (options given win)");

  return tool.run(argc, argv, [&] {
    std::string why;
    if (!output.IsValid(&why)) throw cli::UsageError(why);
    sim::parse_trajectory(trajectory, &run.trajectory.kind);
    sim::parse_integrator(integrator, &run.integrator);
    sim::parse_velocity_source(velocity, &run.sensors.velocity);
    sim::parse_direction(direction, &run.contacts.direction);
    if (mixed) sim::apply_mixed_campaign([&](const char* option) { return app.count(option) > 0; }, &run.contacts, &ranges);
    if (!ranges.parse(&run.contacts, &why)) throw cli::UsageError(why);
    for (double link : cli::parse_number_list(links, "--links")) {
      // Out of int's range the conversion below is undefined (UBSan, the hostile test).
      if (link != std::floor(link) || std::fabs(link) > 1e6) throw cli::UsageError("--links: '" + core::short_number(link) + "' is not a link number");
      run.contacts.links.push_back(static_cast<int>(link));
    }

    if (!glitch_kinds.empty()) {
      run.glitches.kinds.clear();
      for (const std::string& name : core::split(glitch_kinds)) {
        sim::GlitchKind kind;
        if (!sim::parse_glitch_kind(name, &kind))
          throw cli::UsageError("--glitch-kinds: '" + name + "' is not stop, velocity, encoder or current");
        run.glitches.kinds.push_back(kind);
      }
    }
    const sim::SimulationSetup setup = sim::set_up_simulation(tool.profile(), run, duration);
    if (!setup.run.IsValid(&why)) throw cli::UsageError(why);
    output.provenance = tool.provenance();
    cli::Progress progress(tool.show_progress());
    const auto started = std::chrono::steady_clock::now();
    auto show_progress = [&](double t) {
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      const double length = setup.run.trajectory.duration;
      progress.update("mo-sim: " + cli::progress_text(t / length, elapsed) + " of " + core::short_number(length) + " s simulated");
    };
    sim::write_simulated_log(setup, no_friction, tool.seed(), output, show_progress, [&] { progress.finish(); });
    return cli::kSuccess;
  });
}
