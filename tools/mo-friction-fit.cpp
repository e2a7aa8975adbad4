// mo-friction-fit: identify each joint's friction (any model of friction/registry.hpp: LuGre by
// default) from the observer's residual on collision-free motion, through the observer's own
// filter; write it into the robot profile and report what the data say about every parameter.
// Also installed as mo-lugre-fit, its former name: called by that name it names itself so in
// its messages, help and version, so that what scripts written for it see does not change.
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "momentum/cli/tool.hpp"
#include "momentum/core/error.hpp"
#include "momentum/core/file.hpp"
#include "momentum/friction_fit/friction_fit.hpp"
#include "momentum/fit_drivers/profile_fit.hpp"
#include "momentum/friction_fit/report.hpp"

using namespace momentum;

int main(int argc, char** argv) {
  const char* called = argc > 0 ? std::strrchr(argv[0], '/') : nullptr;
  called = called ? called + 1 : argc > 0 ? argv[0] : "";
  const std::string name = std::strcmp(called, "mo-lugre-fit") == 0 ? "mo-lugre-fit" : "mo-friction-fit";
  cli::Tool tool(name, "Identify joint friction from the observer's residual of collision-free motion.");
  tool.app().footer("\nExample:\n  " + name + " -p arm.json -o fitted.json observed.csv\n\nMore: man mo-friction-fit");
  tool.add_stream_inputs("observed streams (t, dq<j>, r<j>) of collision-free motion; - or none: stdin");
  tool.add_profile(true);
  tool.add_strict();
  tool.add_seed();
  auto& app = tool.app();
  drivers::ProfileFitOptions o;  // what the options do not set: from the profile and the data
  friction_fit::FitOptions& options = o.identify.fit;
  auto& ga = options.global.genetic;
  ga = friction_fit::quick_search();
  std::string output, report_path, model_name = "lugre", joints_text, method_name = "ga";
  std::string bounds_text, fix_text, min_speed_text = "auto";
  bool update = false, paper = false, no_polish = false, no_static = false, paper_bounds = false;
  app.add_flag("--update", update, "write the fitted friction into the profile (-p) in place");
  app.add_option("-o,--output", output, "write the updated profile to FILE instead (- for stdout)")->type_name("FILE");
  app.add_flag("--force", o.force, "write even when the fit is worse than the profile's current friction");
  app.add_option("--report", report_path, "write the JSON report to FILE (- for stdout)")->type_name("FILE");
  app.add_option("--model", model_name, friction::kind_names_text(" (default)"))->type_name("MODEL");
  app.add_option("--joints", joints_text, "joints to fit, e.g. 1,3 (default: every joint in the stream)")->type_name("LIST");
  app.add_option("--skip", o.select.skip, "seconds at the start of each log that do not count")->type_name("SECONDS");
  app.add_option("--window", o.window_text, "count only samples with A <= t <= B (stream time)")->type_name("A:B");
  app.add_option("--min-speed", min_speed_text,
                 "do not count samples slower than W rad/s, nor the observer's settling time after them; "
                 "auto (default): 5 x the velocity noise; 0: count all")->type_name("W|auto");
  app.add_option("--global", method_name, "global search: ga (default), crs2, isres, mlsl or esch")->type_name("METHOD");
  app.add_flag("--paper", paper, "the paper's full GA: population 200, 300 generations, one run, no early stop");
  app.add_option("--population", ga.population, "GA population (default " + std::to_string(ga.population) + ")")->type_name("N");
  app.add_option("--generations", ga.generations, "GA generations per run (default " + std::to_string(ga.generations) + ")")->type_name("N");
  app.add_option("--restarts", ga.restarts, "independent GA runs from new random populations (default " + std::to_string(ga.restarts) + ")")->type_name("N");
  app.add_option("--stall", ga.stall_generations, "stop a run after N generations without improvement, 0 never (default " + std::to_string(ga.stall_generations) + ")")->type_name("N");
  app.add_option("--crossover", ga.crossover, "GA crossover probability (default 0.8)")->type_name("P");
  app.add_option("--mutation", ga.mutation, "GA mutation probability per gene (default 0.2)")->type_name("P");
  app.add_option("--elite", ga.elite, "individuals passed on unchanged (default 2)")->type_name("N");
  app.add_option("--evaluations", options.global.max_evaluations, "budget of the NLopt methods (default population x generations x restarts)")->type_name("N");
  app.add_flag("--no-polish", no_polish, "skip the Ceres least-squares polish");
  app.add_flag("--no-static", no_static, "do not fit the static Stribeck model for comparison");
  app.add_flag("--asymmetric", options.asymmetric,
               "also fit direction-dependent levels (delta_c, delta_s), and the symmetric model for comparison");
  app.add_option("--bounds", bounds_text, "search box, e.g. sigma0=5e4:2e5,w_s=0.001:0.5 (others: from the robot and the data)")->type_name("LIST");
  app.add_flag("--paper-bounds", paper_bounds, "search the paper's box (sigma2, tau_c, tau_s up to 10) instead of one scaled to the robot and the data");
  app.add_option("--widenings", o.identify.max_widenings, "refits in a 4 times wider box when a parameter ends on its bound (default 2)")->type_name("N");
  app.add_option("--fix", fix_text, "hold parameters at values, e.g. sigma0=1e5")->type_name("LIST");
  app.add_option("--max-samples", o.max_samples,
                 "samples kept per joint over all inputs, as windows spread over them; 0 all (default 200000)")
      ->type_name("N")
      ->check(cli::whole_number());  // an unsigned option would take -1 as 2^64 - 1
  app.add_option("--threads", o.identify.threads, "joints fitted at once (default: one per core)")->type_name("N");
  app.add_option("--mirror", o.mirror_logs, "check the fit against a trajectory and its mirror (paper's ref. 37)")
      ->expected(2)->type_name("FILE");

  return tool.run(argc, argv, [&] {
    if (update && !output.empty()) throw cli::UsageError("--update and -o are exclusive");
    if (!friction::parse_kind(model_name, &options.kind)) throw cli::UsageError("--model: unknown model '" + model_name + "'");
    if (!friction_fit::parse_method(method_name, &options.global.method))
      throw cli::UsageError("--global: unknown method '" + method_name + "'");
    if (paper) {  // the paper's GA, but for what was given explicitly
      if (!app.count("--population")) ga.population = 200;
      if (!app.count("--generations")) ga.generations = 300;
      if (!app.count("--restarts")) ga.restarts = 1;
      if (!app.count("--stall")) ga.stall_generations = 0;
    }
    ga.seed = tool.seed();
    options.polish.enabled = !no_polish;
    options.compare_static = !no_static;
    o.identify.robot_bounds = !paper_bounds;
    o.profile = tool.profile();
    o.destination = update ? o.profile : output;
    o.inputs = tool.inputs();
    try {
      drivers::parse_bounds(bounds_text, "--bounds", options.bounds, o.identify.user_bounds);
      drivers::parse_fixed(fix_text, "--fix", options.fixed);
      o.select.joints = drivers::parse_joints(joints_text, "--joints");
      drivers::parse_window(o.window_text, "--window", o.select);
      if (min_speed_text != "auto") o.min_speed = drivers::parse_option_number(min_speed_text, "--min-speed");
      // A profile write (--update or -o FILE) holds the written file's lock from the read to
      // the write, so that a concurrent run's section is not lost.
      const auto lock = !o.destination.empty() && !core::is_standard_output(o.destination)
                            ? cli::lock_for_update(o.destination)
                            : nullptr;
      cli::Progress progress(tool.show_progress());
      const auto summary = drivers::fit_profile_friction(
          o, [&](const std::string& path) { return tool.open_input(path); },
          [&](const std::string& line) { line.empty() ? progress.finish() : progress.update(line); });
      if (!tool.quiet()) std::fputs(friction_fit::report_text(summary.report).c_str(), stderr);
      if (!report_path.empty()) core::write_document(report_path, friction_fit::report_json(summary.report).dump(2) + "\n");
      if (!summary.failure.empty()) throw Error(summary.failure);
      return cli::kSuccess;
    } catch (const drivers::OptionError& e) {
      throw cli::UsageError(e.what());
    }
  });
}
