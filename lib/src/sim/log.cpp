#include "momentum/sim/log.hpp"

#include <algorithm>
#include <memory>
#include <utility>
#include <vector>

#include "momentum/can/dbc.hpp"
#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/sim/candump_output.hpp"
#include "momentum/stream/format.hpp"
#include "momentum/stream/writer.hpp"

namespace momentum::sim {

bool ContactRanges::parse(ContactOptions* contacts, std::string* why) const {
  const struct {
    const char* option;
    const std::string& text;
    double* min;
    double* max;
  } ranges[] = {
      {"--force", force, &contacts->force_min, &contacts->force_max},
      {"--rise", rise, &contacts->rise_min, &contacts->rise_max},
      {"--hold", hold, &contacts->hold_min, &contacts->hold_max},
      {"--release", release, &contacts->release_min, &contacts->release_max},
      {"--clamp-hold", clamp_hold, &contacts->clamp_hold_min, &contacts->clamp_hold_max},
  };
  for (const auto& range : ranges) {
    if (parse_range(range.text, range.min, range.max)) continue;
    *why = std::string(range.option) + ": '" + range.text + "' is not a range MIN:MAX of numbers with MIN <= MAX";
    return false;
  }
  return true;
}

void apply_mixed_campaign(const std::function<bool(const char* option)>& given, ContactOptions* contacts,
                          ContactRanges* ranges) {
  auto preset = [&](const char* option, auto& value, auto preset_value) {
    if (!given(option)) value = preset_value;
  };
  preset("--clamping", contacts->clamp_fraction, 0.5);
  preset("--clamp-stiffness", contacts->clamp_stiffness, 300000.0);
  preset("--clamp-hold", ranges->clamp_hold, "0.01:0.05");
  preset("--rise", ranges->rise, "0.15:0.4");
  preset("--hold", ranges->hold, "0.2:0.6");
  preset("--release", ranges->release, "0.05:0.2");
  preset("--force", ranges->force, "40:150");
}

double default_duration(const RunOptions& run) {
  const TrajectoryKind kind = run.trajectory.kind;
  const bool blended = kind == TrajectoryKind::paper || kind == TrajectoryKind::multisine || kind == TrajectoryKind::excite;
  const double blends = blended ? 2 * run.trajectory.blend : 0.0;
  return std::max(60.0, blends + 1.0 + 2.0 * campaign_length(run.contacts));
}

SimulationSetup set_up_simulation(const std::string& profile_path, RunOptions run, std::optional<double> duration) {
  const model::Profile profile = model::load_profile(profile_path);
  model::Model model = model::build_model(profile);
  SimulationSection section = read_simulation_section(profile, model);
  run.contacts.link_radius = section.link_radius;
  run.trajectory.duration = duration ? *duration : default_duration(run);
  return {profile_path, std::move(model), std::move(section), std::move(run)};
}

bool LogOutput::IsValid(std::string* why) const {
  if (candump && dbc_path.empty()) {
    *why = "--candump needs --dbc FILE";
    return false;
  }
  if (candump && (truth_columns || format != "csv")) {
    *why = "--candump writes frames: --with-truth-columns and --output-format do not apply";
    return false;
  }
  return true;
}

RunSummary write_simulated_log(const SimulationSetup& setup, bool ignore_friction, std::uint64_t seed,
                               const LogOutput& output, const std::function<void(double t)>& progress,
                               const std::function<void()>& progress_done) {
  const RunOptions& run = setup.run;
  const int nq = setup.model.nq;
  if (!setup.section.has_friction && !ignore_friction)
    warn(setup.profile_path + ": no simulation.friction: simulating a frictionless arm");
  const friction::FrictionModel* friction =
      setup.section.has_friction && !ignore_friction ? &setup.section.friction : nullptr;

  std::unique_ptr<stream::Writer> out;
  std::optional<can::Database> dbc;
  std::unique_ptr<CandumpOutput> bus;
  std::unique_ptr<stream::Writer> truth;
  if (output.candump) dbc = can::Database::load(output.dbc_path);
  RunCallbacks callbacks;
  callbacks.start = [&] {
    if (output.candump) {
      bus = std::make_unique<CandumpOutput>(*dbc, output.path, nq, 1.0 / run.rate_hz);
    } else {
      stream::WriterOptions writer_options;
      writer_options.encoding = stream::parse_encoding(output.format);
      writer_options.line_buffered = output.line_buffered;
      out = stream::Writer::open(output.path, writer_options);
      out->comment(output.provenance);
      out->comment(" mo-sim: seed " + std::to_string(seed) + ", trajectory " + trajectory_name(run.trajectory.kind) +
                   (run.trajectory.mirror ? " mirrored" : "") + ", duration " +
                   core::short_number(run.trajectory.duration) + " s, rate " + core::short_number(run.rate_hz) + " Hz");
      out->header(sample_columns(nq, output.truth_columns));
    }
    if (!output.truth_path.empty()) {
      truth = stream::Writer::open(output.truth_path, {});
      truth->comment(output.provenance);
      truth->comment(" duration: " + core::short_number(run.trajectory.duration));
      truth->header(truth_columns(nq));
    }
  };
  std::vector<double> row;
  callbacks.sample = [&](const Sample& s) {
    if (bus) {
      bus->write(s);
      return;
    }
    sample_row(s, output.truth_columns, row);
    out->row(row.data());
  };
  std::vector<double> truth_values;
  callbacks.contact = [&](const ContactTruth& c) {
    if (!truth) return;
    truth_row(c, truth_values);
    truth->row(truth_values.data());
  };
  // The glitches are sensor faults, not contacts: comments of the truth table, in time order
  // with its rows, so that mo-eval reads the contacts alone and a test finds the glitches.
  callbacks.glitch = [&](double t, const Glitch& g) {
    if (!truth) return;
    truth->comment(" glitch: t=" + core::exact(t) + " kind=" + glitch_kind_name(g.kind) +
                   (g.joint >= 0 ? " joint=" + std::to_string(g.joint + 1) : std::string(" joint=all")));
  };
  callbacks.progress = progress;
  const RunSummary summary = simulate(setup.model, friction, setup.section.home, run, seed, callbacks);
  if (progress_done) progress_done();
  if (out) out->close();
  if (bus) bus->close();
  if (truth) truth->close();
  if (bus && bus->saturated())
    warn(std::to_string(bus->saturated()) + " values did not fit their CAN signal and were clamped");
  if (summary.max_tracking_error > 0.1)
    warn("the controller lost track of the trajectory (error up to " + core::short_number(summary.max_tracking_error) +
         " rad); lower --bandwidth or check the profile's drives");
  return summary;
}

}  // namespace momentum::sim
