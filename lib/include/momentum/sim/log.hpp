// mo-sim's run as library calls: the campaign's ranges as the command line writes them, the
// robot of a profile with the run completed from it, and the simulated log written where it is
// asked for (a sample stream or the drives' CAN frames, and the ground truth), so that the tool
// is its options and little else.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "momentum/model/model.hpp"
#include "momentum/sim/run.hpp"

namespace momentum::sim {

// The contact ranges of a campaign as text "MIN:MAX" (parse_range), with mo-sim's defaults;
// they are kept as text until parsed so that --mixed can tell which ones were given.
struct ContactRanges {
  std::string force = "30:150";      // peak force, N
  std::string rise = "0.02:0.1";     // s
  std::string hold = "0.05:0.3";     // s
  std::string release = "0.02:0.1";  // s
  std::string clamp_hold = "0.5:2";  // s

  // Parses every range into `contacts`. False, with `why` naming the option (--force, --rise,
  // --hold, --release, --clamp-hold) and the text, at the first one that is not a range.
  bool parse(ContactOptions* contacts, std::string* why) const;
};

// mo-sim --mixed: both kinds of mo-detect's classes, collisions (a stiff obstacle met at speed
// and knocked away or backed off from: 300 N/mm, held 10-50 ms) and contacts (a hand pushing:
// rising over 0.15-0.4 s, held 0.2-0.6 s), half of each. Sets clamp_fraction, clamp_stiffness
// and the ranges, each unless `given` says its option ("--clamping", "--clamp-stiffness",
// "--clamp-hold", "--rise", "--hold", "--release", "--force") was given.
void apply_mixed_campaign(const std::function<bool(const char* option)>& given, ContactOptions* contacts,
                          ContactRanges* ranges);

// A run made ready from a profile: its model, its simulation section, and the options
// completed from them.
struct SimulationSetup {
  std::string profile_path;
  model::Model model;
  SimulationSection section;
  RunOptions run;  // contacts.link_radius from the section; trajectory.duration set
};

// The length of a run when none is given, s: 60, or longer when the campaign needs it (the
// entry and exit blends of the paper, multisine and excite trajectories, 1 s, and twice
// campaign_length).
double default_duration(const RunOptions& run);

// Loads the profile at `profile_path`, builds its model and reads its simulation section;
// `run` is completed with the section's link radii and `duration` (s; default_duration when
// not given). Does not check the options (RunOptions::IsValid). Throws what model::load_profile,
// model::build_model and read_simulation_section throw.
SimulationSetup set_up_simulation(const std::string& profile_path, RunOptions run, std::optional<double> duration);

// Where a simulated log goes.
struct LogOutput {
  std::string path = "-";            // the sample stream, or the frames; "-": stdout
  std::string format = "csv";        // the stream's encoding: csv or bin
  bool line_buffered = false;        // flush the stream after every row
  bool truth_columns = false;        // tau_f_true<j> and tau_c_true<j> in the stream
  bool candump = false;              // candump -L text of the drives' frames instead of a stream
  std::string dbc_path;              // how the drives encode their values (needed by candump)
  std::string truth_path;            // one row per contact (truth_columns); empty: none
  std::string provenance;            // the first comment of the stream and of the truth table

  // False, with the reason in `why`, when candump lacks a DBC or comes with truth_columns or a
  // format other than csv.
  bool IsValid(std::string* why) const;
};

// Simulates `setup` (its options valid) with `seed` and writes the log to `output`: a stream
// whose comments say the seed, trajectory, duration and rate, or the frames; the truth table.
// The outputs are opened only once the run is set up, so that an invalid campaign leaves no
// half-written file. Without friction (`ignore_friction`, or a profile without
// simulation.friction, which is warned about) the arm is frictionless. `progress` (may be
// empty) is called now and then with the simulated time, s, and `progress_done` (may be empty)
// once the run is over, before the closing warnings (momentum::warn: CAN values clamped to
// their signal's range, a tracking error above 0.1 rad), so that a progress line can be cleared
// first. Throws what simulate, can::Database::load, stream::Writer and CandumpOutput throw.
RunSummary write_simulated_log(const SimulationSetup& setup, bool ignore_friction, std::uint64_t seed,
                               const LogOutput& output, const std::function<void(double t)>& progress,
                               const std::function<void()>& progress_done);

}  // namespace momentum::sim
