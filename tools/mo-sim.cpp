// mo-sim: simulate a profile's arm following a trajectory, with its true friction and a campaign
// of collisions; write what its drives would report, and the ground truth.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "momentum/cli/progress_text.hpp"
#include "momentum/cli/tool.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/can/dbc.hpp"
#include "momentum/sim/candump_output.hpp"
#include "momentum/sim/run.hpp"
#include "momentum/stream/error.hpp"

using namespace momentum;

namespace {

void range_option(CLI::App& app, const std::string& name, std::string& text, const std::string& help) {
  app.add_option(name, text, help)->type_name("MIN:MAX")->capture_default_str();
}

void parse_range_or_throw(const std::string& option, const std::string& text, double* lo, double* hi) {
  if (!sim::parse_range(text, lo, hi))
    throw cli::UsageError(option + ": '" + text + "' is not a range MIN:MAX of numbers with MIN <= MAX");
}

std::string format_number(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", x);
  return buffer;
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("mo-sim", "Simulate an arm with friction and collisions: a sample stream and its ground truth.");
  tool.app().footer("\nExample:\n  mo-sim -p arm.json --collisions 50 --truth truth.csv > log.csv\n\nMore: man mo-sim");
  tool.add_profile();
  tool.add_seed();
  CLI::App& app = tool.app();

  sim::RunOptions run;
  std::string output = "-", output_format = "csv", truth_path;
  bool line_buffered = false, with_truth = false, no_friction = false;
  app.add_option("-o,--output", output, "output file (default: stdout)")->type_name("FILE");
  app.add_option("--output-format", output_format, "csv or bin")->check(CLI::IsMember({"csv", "bin"}))->capture_default_str();
  app.add_flag("--line-buffered", line_buffered, "flush every row");
  app.add_option("--truth", truth_path, "write one row per contact (ground truth) to FILE")->type_name("FILE");
  app.add_flag("--with-truth-columns", with_truth, "add true friction and contact torques per joint");
  bool candump = false;
  std::string dbc_path;
  auto* candump_flag = app.add_flag("--candump", candump, "write candump -L text of the drives' frames instead of a stream");
  app.add_option("--dbc", dbc_path, "how the drives encode their values (with --candump)")->type_name("FILE")->needs(candump_flag);

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

  std::string links, force = "30:150", rise = "0.02:0.1", hold = "0.05:0.3", release = "0.02:0.1", clamp_hold = "0.5:2";
  app.add_option("--collisions", run.contacts.count, "number of contacts at random times")->type_name("N")->capture_default_str();
  app.add_option("--links", links, "links to hit, e.g. 2,3 (default: 2..n)")->type_name("LIST");
  range_option(app, "--force", force, "peak force range, N");
  range_option(app, "--rise", rise, "rise time range, s");
  range_option(app, "--hold", hold, "hold time range, s");
  range_option(app, "--release", release, "release time range, s");
  app.add_option("--min-spacing", run.contacts.min_spacing, "quiet time between contacts")->type_name("S")->capture_default_str();
  app.add_option("--direction", direction, "normal (to the link surface) or any")
      ->check(CLI::IsMember({"normal", "any"}))->capture_default_str();
  app.add_option("--clamping", run.contacts.clamp_fraction, "fraction of contacts that are clamps")->type_name("F")->capture_default_str();
  range_option(app, "--clamp-hold", clamp_hold, "clamp hold time range, s");
  app.add_option("--clamp-stiffness", run.contacts.clamp_stiffness, "clamping obstacle stiffness")->type_name("N/M")->capture_default_str();
  bool mixed = false;
  app.add_flag("--mixed", mixed, "half impacts on stiff obstacles, half slow pushes (options given win)");

  return tool.run(argc, argv, [&] {
    if (candump && dbc_path.empty()) throw cli::UsageError("--candump needs --dbc FILE");
    if (candump && (with_truth || output_format != "csv"))
      throw cli::UsageError("--candump writes frames: --with-truth-columns and --output-format do not apply");
    sim::parse_trajectory(trajectory, &run.trajectory.kind);
    sim::parse_integrator(integrator, &run.integrator);
    sim::parse_velocity_source(velocity, &run.sensors.velocity);
    sim::parse_direction(direction, &run.contacts.direction);
    if (mixed) {
      // Both kinds of mo-detect's classes: collisions (a stiff obstacle met at speed and
      // knocked away or backed off from: 300 N/mm, held 10-50 ms) and contacts (a hand pushing:
      // rising over 0.15-0.4 s, held 0.2-0.6 s). Each is set unless given explicitly.
      auto preset = [&](const char* option, auto& value, auto preset_value) {
        if (app.count(option) == 0) value = preset_value;
      };
      preset("--clamping", run.contacts.clamp_fraction, 0.5);
      preset("--clamp-stiffness", run.contacts.clamp_stiffness, 300000.0);
      preset("--clamp-hold", clamp_hold, std::string("0.01:0.05"));
      preset("--rise", rise, std::string("0.15:0.4"));
      preset("--hold", hold, std::string("0.2:0.6"));
      preset("--release", release, std::string("0.05:0.2"));
      preset("--force", force, std::string("40:150"));
    }
    parse_range_or_throw("--force", force, &run.contacts.force_min, &run.contacts.force_max);
    parse_range_or_throw("--rise", rise, &run.contacts.rise_min, &run.contacts.rise_max);
    parse_range_or_throw("--hold", hold, &run.contacts.hold_min, &run.contacts.hold_max);
    parse_range_or_throw("--release", release, &run.contacts.release_min, &run.contacts.release_max);
    parse_range_or_throw("--clamp-hold", clamp_hold, &run.contacts.clamp_hold_min, &run.contacts.clamp_hold_max);
    for (double link : cli::parse_number_list(links, "--links")) {
      if (link != std::floor(link)) throw cli::UsageError("--links: '" + format_number(link) + "' is not a link number");
      run.contacts.links.push_back(static_cast<int>(link));
    }

    const model::Profile profile = model::load_profile(tool.profile());
    const model::Model model = model::build_model(profile);
    const sim::SimulationSection section = sim::read_simulation_section(profile, model);
    run.contacts.link_radius = section.link_radius;
    const double blends = run.trajectory.kind == sim::TrajectoryKind::paper ||
                                  run.trajectory.kind == sim::TrajectoryKind::multisine ||
                                  run.trajectory.kind == sim::TrajectoryKind::excite
                              ? 2 * run.trajectory.blend
                              : 0.0;
    run.trajectory.duration =
        duration ? *duration : std::max(60.0, blends + 1.0 + 2.0 * sim::campaign_length(run.contacts));
    std::string why;
    if (!run.IsValid(&why)) throw cli::UsageError(why);
    if (!section.has_friction && !no_friction)
      warn(tool.profile() + ": no simulation.friction: simulating a frictionless arm");
    const friction::FrictionModel* friction = section.has_friction && !no_friction ? &section.friction : nullptr;

    // Outputs are opened once the run has been set up (callbacks.start), so that an invalid
    // campaign leaves no half-written file behind.
    std::unique_ptr<stream::Writer> out;
    std::optional<can::Database> dbc;
    std::unique_ptr<sim::CandumpOutput> bus;
    std::unique_ptr<stream::Writer> truth;
    if (candump) dbc = can::Database::load(dbc_path);
    sim::RunCallbacks callbacks;
    callbacks.start = [&] {
      if (candump) {
        bus = std::make_unique<sim::CandumpOutput>(*dbc, output, model.nq, 1.0 / run.rate_hz);
      } else {
        stream::WriterOptions writer_options;
        writer_options.encoding = stream::parse_encoding(output_format);
        writer_options.line_buffered = line_buffered;
        out = stream::Writer::open(output, writer_options);
        out->comment(tool.provenance());
        out->comment(" mo-sim: seed " + std::to_string(tool.seed()) + ", trajectory " + trajectory + (run.trajectory.mirror ? " mirrored" : "") + ", duration " +
                     format_number(run.trajectory.duration) + " s, rate " + format_number(run.rate_hz) + " Hz");
        out->header(sim::sample_columns(model.nq, with_truth));
      }
      if (!truth_path.empty()) {
        truth = stream::Writer::open(truth_path, {});
        truth->comment(tool.provenance());
        truth->comment(" duration: " + format_number(run.trajectory.duration));
        truth->header(sim::truth_columns(model.nq));
      }
    };

    cli::Progress progress(tool.show_progress());
    std::vector<double> row;
    callbacks.sample = [&](const sim::Sample& s) {
      if (bus) {
        bus->write(s);
        return;
      }
      sim::sample_row(s, with_truth, row);
      out->row(row.data());
    };
    std::vector<double> truth_values;
    callbacks.contact = [&](const sim::ContactTruth& c) {
      if (!truth) return;
      sim::truth_row(c, truth_values);
      truth->row(truth_values.data());
    };
    const auto started = std::chrono::steady_clock::now();
    callbacks.progress = [&](double t) {
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      progress.update("mo-sim: " + cli::progress_text(t / run.trajectory.duration, elapsed) + " of " +
                      format_number(run.trajectory.duration) + " s simulated");
    };
    const sim::RunSummary summary = sim::simulate(model, friction, section.home, run, tool.seed(), callbacks);
    progress.finish();
    if (out) out->close();
    if (bus) bus->close();
    if (truth) truth->close();
    if (bus && bus->saturated())
      warn(std::to_string(bus->saturated()) + " values did not fit their CAN signal and were clamped");
    if (summary.max_tracking_error > 0.1)
      warn("the controller lost track of the trajectory (error up to " + format_number(summary.max_tracking_error) +
           " rad); lower --bandwidth or check the profile's drives");
    return cli::kSuccess;
  });
}
