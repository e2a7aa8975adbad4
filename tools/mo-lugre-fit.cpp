// mo-lugre-fit: identify each joint's friction (LuGre, Stribeck or Coulomb-viscous) from the
// observer's residual on collision-free motion, through the observer's own filter; write it into
// the robot profile and report what the data say about every parameter.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <mutex>
#include <optional>

#include "momentum/cli/tool.hpp"
#include "momentum/core/file.hpp"
#include "momentum/core/text.hpp"
#include "momentum/fit/data.hpp"
#include "momentum/fit/friction_fit.hpp"
#include "momentum/fit/identify.hpp"
#include "momentum/fit/mirror.hpp"
#include "momentum/fit/report.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/observer/observer.hpp"
#include "momentum/stream/error.hpp"

using namespace momentum;

namespace {

// A joint needs this many counted samples before its fit is written into a profile: six
// parameters from a handful of samples fit noise (one sample fits anything).
constexpr std::size_t kMinimumSamples = 100;

double parse_double(const std::string& text, const std::string& option) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || !std::isfinite(v))
    throw cli::UsageError(option + ": '" + text + "' is not a number");
  return v;
}

// "sigma0=6e4:1e5,w_s=0:0.2" -> bounds; "sigma0=1e5" -> fixed values.
void parse_assignments(const std::string& text, const std::string& option,
                       const std::function<void(int, const std::string&)>& apply) {
  for (const auto& item : core::split(text)) {
    const auto eq = item.find('=');
    const int index = eq == std::string::npos ? -1 : fit::parameter_index(item.substr(0, eq));
    if (index < 0)
      throw cli::UsageError(option + ": '" + item + "' is not NAME=VALUE with NAME one of sigma0, sigma1, sigma2, tau_c, tau_s, w_s, delta_c, delta_s");
    apply(index, item.substr(eq + 1));
  }
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("mo-lugre-fit", "Identify joint friction from the observer's residual of collision-free motion.");
  tool.app().footer("\nExample:\n  mo-lugre-fit -p arm.json -o fitted.json observed.csv\n\nMore: man mo-lugre-fit");
  tool.add_inputs("observed streams (t, dq<j>, r<j>) of collision-free motion; - or none: stdin");
  tool.add_profile(true);
  tool.add_strict();
  tool.add_seed();
  auto& app = tool.app();
  std::string output, report_path, model_name = "lugre", joints_text, window_text, method_name = "ga";
  std::string bounds_text, fix_text;
  bool update = false, force = false, paper = false, no_polish = false, no_static = false;
  double skip = 0;
  std::string min_speed_text = "auto";
  const fit::GeneticOptions quick = fit::quick_search();
  int population = quick.population, generations = quick.generations, restarts = quick.restarts;
  int stall = quick.stall_generations, elite = quick.elite, threads = 0;
  double crossover = quick.crossover, mutation = quick.mutation;
  std::uint64_t evaluations = 0;
  std::size_t max_samples = 200000;
  std::vector<std::string> mirror_logs;
  app.add_flag("--update", update, "write the fitted friction into the profile (-p) in place");
  app.add_option("-o,--output", output, "write the updated profile to FILE instead (- for stdout)")->type_name("FILE");
  app.add_flag("--force", force, "write even when the fit is worse than the profile's current friction");
  app.add_option("--report", report_path, "write the JSON report to FILE (- for stdout)")->type_name("FILE");
  app.add_option("--model", model_name, "lugre (default), stribeck or coulomb-viscous")->type_name("MODEL");
  app.add_option("--joints", joints_text, "joints to fit, e.g. 1,3 (default: every joint in the stream)")->type_name("LIST");
  app.add_option("--skip", skip, "seconds at the start of each log that do not count")->type_name("SECONDS");
  app.add_option("--window", window_text, "count only samples with A <= t <= B (stream time)")->type_name("A:B");
  app.add_option("--min-speed", min_speed_text,
                 "do not count samples slower than W rad/s, nor the observer's settling time after them; "
                 "auto (default): 5 x the velocity noise; 0: count all")->type_name("W|auto");
  app.add_option("--global", method_name, "global search: ga (default), crs2, isres, mlsl or esch")->type_name("METHOD");
  app.add_flag("--paper", paper, "the paper's full GA: population 200, 300 generations, one run, no early stop");
  app.add_option("--population", population, "GA population (default " + std::to_string(population) + ")")->type_name("N");
  app.add_option("--generations", generations, "GA generations per run (default " + std::to_string(generations) + ")")->type_name("N");
  app.add_option("--restarts", restarts, "independent GA runs from new random populations (default " + std::to_string(restarts) + ")")->type_name("N");
  app.add_option("--stall", stall, "stop a run after N generations without improvement, 0 never (default " + std::to_string(stall) + ")")->type_name("N");
  app.add_option("--crossover", crossover, "GA crossover probability (default 0.8)")->type_name("P");
  app.add_option("--mutation", mutation, "GA mutation probability per gene (default 0.2)")->type_name("P");
  app.add_option("--elite", elite, "individuals passed on unchanged (default 2)")->type_name("N");
  app.add_option("--evaluations", evaluations, "budget of the NLopt methods (default population x generations x restarts)")->type_name("N");
  app.add_flag("--no-polish", no_polish, "skip the Ceres least-squares polish");
  app.add_flag("--no-static", no_static, "do not fit the static Stribeck model for comparison");
  bool asymmetric = false;
  app.add_flag("--asymmetric", asymmetric,
               "also fit direction-dependent levels (delta_c, delta_s), and the symmetric model for comparison");
  app.add_option("--bounds", bounds_text, "search box, e.g. sigma0=5e4:2e5,w_s=0.001:0.5 (others: from the robot and the data)")->type_name("LIST");
  bool paper_bounds = false;
  int widenings = 2;
  app.add_flag("--paper-bounds", paper_bounds, "search the paper's box (sigma2, tau_c, tau_s up to 10) instead of one scaled to the robot and the data");
  app.add_option("--widenings", widenings, "refits in a 4 times wider box when a parameter ends on its bound (default 2)")->type_name("N");
  app.add_option("--fix", fix_text, "hold parameters at values, e.g. sigma0=1e5")->type_name("LIST");
  app.add_option("--max-samples", max_samples,
                 "samples kept per joint over all inputs, as windows spread over them; 0 all (default 200000)")
      ->type_name("N");
  app.add_option("--threads", threads, "joints fitted at once (default: one per core)")->type_name("N");
  app.add_option("--mirror", mirror_logs, "check the fit against a trajectory and its mirror (paper's ref. 37)")
      ->expected(2)->type_name("FILE");

  return tool.run(argc, argv, [&] {
    const auto start = std::chrono::steady_clock::now();
    if (update && !output.empty()) throw cli::UsageError("--update and -o are exclusive");
    fit::FitOptions options;
    if (!friction::parse_kind(model_name, &options.kind))
      throw cli::UsageError("--model: unknown model '" + model_name + "'");
    if (!fit::parse_method(method_name, &options.global.method))
      throw cli::UsageError("--global: unknown method '" + method_name + "'");
    auto& ga = options.global.genetic;
    if (paper) {
      auto explicitly = [&](const char* name) { return app.count(name) > 0; };
      if (!explicitly("--population")) population = 200;
      if (!explicitly("--generations")) generations = 300;
      if (!explicitly("--restarts")) restarts = 1;
      if (!explicitly("--stall")) stall = 0;
    }
    ga.population = population;
    ga.generations = generations;
    ga.restarts = restarts;
    ga.stall_generations = stall;
    ga.crossover = crossover;
    ga.mutation = mutation;
    ga.elite = elite;
    ga.seed = tool.seed();
    options.global.max_evaluations = evaluations;
    options.polish.enabled = !no_polish;
    options.compare_static = !no_static;
    options.asymmetric = asymmetric;
    fit::IdentifyOptions identify;
    identify.robot_bounds = !paper_bounds;
    identify.max_widenings = widenings;
    identify.threads = threads;
    parse_assignments(bounds_text, "--bounds", [&](int i, const std::string& range) {
      identify.user_bounds[static_cast<std::size_t>(i)] = true;
      const auto colon = range.find(':');
      if (colon == std::string::npos) throw cli::UsageError("--bounds: '" + range + "' is not LO:HI");
      options.bounds.lower[static_cast<std::size_t>(i)] = parse_double(range.substr(0, colon), "--bounds");
      options.bounds.upper[static_cast<std::size_t>(i)] = parse_double(range.substr(colon + 1), "--bounds");
    });
    parse_assignments(fix_text, "--fix", [&](int i, const std::string& v) {
      options.fixed[static_cast<std::size_t>(i)] = parse_double(v, "--fix");
    });

    fit::SelectOptions select;
    for (const auto& j : core::split(joints_text)) {
      const double v = parse_double(j, "--joints");
      if (v < 1 || v != std::floor(v)) throw cli::UsageError("--joints: '" + j + "' is not a joint number");
      select.joints.push_back(static_cast<int>(v));
    }
    select.skip = skip;
    if (!window_text.empty()) {
      const auto colon = window_text.find(':');
      if (colon == std::string::npos) throw cli::UsageError("--window: '" + window_text + "' is not A:B");
      if (colon > 0) select.window_begin = parse_double(window_text.substr(0, colon), "--window");
      if (colon + 1 < window_text.size()) select.window_end = parse_double(window_text.substr(colon + 1), "--window");
    }

    // The profile: robot (joint count), observer (the filter), current friction (options, and
    // the error to beat).
    // An in-place update holds the profile's lock from this read to the write.
    const auto lock = update ? cli::lock_for_update(tool.profile()) : nullptr;
    const model::Profile profile = model::load_profile(tool.profile());
    const model::Model robot = model::build_model(profile);
    const std::string profile_name = tool.profile();
    observer::ObserverOptions observer_options;
    std::optional<friction::FrictionModel> current;
    try {
      std::vector<std::string> notes;
      if (auto it = profile.document.find("observer"); it != profile.document.end())
        observer_options = observer::observer_options_from_json(*it, &notes);
      if (auto it = profile.document.find("friction"); it != profile.document.end()) {
        try {
          current = friction::friction_from_json(*it, &notes);
        } catch (const Error& e) {
          if (!force) throw;
          warn(profile_name + ": " + e.what() + "; ignored (--force)");
        }
      }
      for (const auto& n : notes) warn(profile_name + ": " + n);
    } catch (const Error& e) {
      throw Error(profile_name + ": " + e.what());
    }
    if (current && static_cast<int>(current->joints.size()) != robot.nq) {
      warn(profile_name + ": the friction section has " + std::to_string(current->joints.size()) +
           " joints, the robot " + std::to_string(robot.nq) + "; not compared");
      current.reset();
    }
    if (current) options.friction = current->options;
    select.gap_factor = observer_options.gap_factor;
    // Long logs are thinned to windows while read: each input its share of the budget, each
    // window long against the observer's memory, which its warm-up lets fade (5 of the
    // slowest time constant, 1/K2 for the second-order observer).
    std::vector<std::string> inputs = tool.inputs();
    if (inputs.empty()) inputs.push_back("-");
    const std::vector<observer::Gains> robot_gains = observer_options.joint_gains(robot.nq);
    if (max_samples > 0) {
      double slowest = 0;
      for (const auto& g : robot_gains) slowest = std::max(slowest, 1.0 / (g.k2 > 0 ? g.k2 : g.k1));
      select.max_samples = std::max<std::size_t>(max_samples / inputs.size(), 1);
      select.thin_warmup = 5 * slowest;
      select.thin_window = std::max(10.0, 10 * select.thin_warmup);
    }
    std::string why;
    identify.fit = options;
    if (!identify.IsValid(&why)) throw cli::UsageError(why);
    if (!select.IsValid(&why)) throw cli::UsageError(why);

    // The data: every log, appended joint by joint.
    std::vector<fit::JointSeries> series;
    for (const auto& path : inputs) {
      auto in = tool.open_input(path);
      auto more = fit::read_series(*in, select);
      if (series.empty()) {
        series = std::move(more);
      } else {
        if (more.size() != series.size())
          throw Error(in->name() + ": has other joints than " + inputs.front());
        fit::append_log(series, more);
      }
    }
    std::vector<observer::Gains> gains;
    for (auto& s : series) {
      if (s.joint > robot.nq)
        throw Error(s.source + ": joint " + std::to_string(s.joint) + " is not a joint of the robot (it has " +
                    std::to_string(robot.nq) + ")");
      gains.push_back(robot_gains[static_cast<std::size_t>(s.joint - 1)]);
    }

    // Samples where a joint (nearly) stands still do not count: the measured velocity cannot
    // resolve sticking there (see man page). The observer forgets them in about 3 / K1 s.
    std::vector<fit::JointReport> slow_samples(series.size());
    for (std::size_t i = 0; i < series.size(); ++i) {
      auto& s = series[i];
      auto& j = slow_samples[i];
      j.velocity_noise = fit::estimate_velocity_noise(s);
      j.min_speed = min_speed_text == "auto" ? 5.0 * j.velocity_noise : parse_double(min_speed_text, "--min-speed");
      if (j.min_speed < 0) throw cli::UsageError("--min-speed must be >= 0");
      if (j.min_speed > 0) j.excluded_slow = fit::exclude_slow_samples(s, j.min_speed, 3.0 / gains[i].k1);
      if (s.scored_count() == 0)
        throw Error(s.source + ": joint " + std::to_string(s.joint) + ": no sample faster than --min-speed " +
                    std::to_string(j.min_speed) + " rad/s left to fit");
    }

    // Fit, with a progress line on a terminal.
    cli::Progress progress(tool.show_progress());
    std::mutex progress_mutex;
    std::vector<std::string> state(series.size());
    auto on_progress = [&](const fit::JointProgress& p) {
      std::lock_guard<std::mutex> lock(progress_mutex);
      for (std::size_t i = 0; i < series.size(); ++i)
        if (series[i].joint == p.joint) {
          char text[96];
          if (std::string(p.stage) == "polish")
            std::snprintf(text, sizeof text, "j%d polish", p.joint);
          else
            std::snprintf(text, sizeof text, "j%d %s run %d gen %d cost %.4g", p.joint, p.stage,
                          p.search.restart + 1, p.search.generation, p.search.best_cost);
          state[i] = text;
        }
      std::string line = "mo-lugre-fit:";
      for (const auto& s : state)
        if (!s.empty()) line += "  " + s;
      progress.update(line);
    };
    std::vector<double> effort, velocity;
    for (const auto& s : series) {
      const auto& limits = robot.joints[static_cast<std::size_t>(s.joint - 1)].limits;
      effort.push_back(limits.effort);
      velocity.push_back(limits.velocity);
    }
    identify.fit = options;
    auto identified = fit::identify_friction(series, gains, effort, velocity, identify, on_progress);
    progress.finish();
    std::vector<fit::JointFit> fits;
    for (const auto& j : identified) fits.push_back(j.fit);

    fit::FitReport report;
    report.inputs = inputs;
    report.profile = profile_name;
    report.options = options;
    report.observer_order = observer_options.order;
    for (std::size_t i = 0; i < fits.size(); ++i) {
      fit::JointReport j = std::move(slow_samples[i]);
      j.fit = fits[i];
      j.bounds = identified[i].bounds;
      j.widenings = identified[i].widenings;
      j.failure = identified[i].failure;
      j.gains = gains[i];
      const double dt = series[i].median_dt();
      j.sample_rate_hz = dt > 0 ? 1.0 / dt : 0.0;
      if (current) {
        j.current_kind = current->kind;
        j.current = fit::evaluate_fit(series[i], gains[i], current->kind,
                                      current->joints[static_cast<std::size_t>(fits[i].joint - 1)], current->options);
      }
      const auto model_r = fit::predict_residual(series[i], gains[i], j.fit.model.kind, j.fit.model.parameters,
                                                 options.friction);
      std::vector<double> left(model_r.size());
      for (std::size_t k = 0; k < left.size(); ++k) left[k] = series[i].r[k] - model_r[k];
      j.residual_split = fit::split_residual(series[i], gains[i], left);
      report.joints.push_back(std::move(j));
    }
    if (!mirror_logs.empty()) {
      std::vector<int> numbers;
      for (const auto& s : series) numbers.push_back(s.joint);
      std::vector<double> k_i(robot.k_i.data(), robot.k_i.data() + robot.k_i.size());
      auto forward = tool.open_input(mirror_logs[0]);
      auto mirror = tool.open_input(mirror_logs[1]);
      const auto reference = fit::mirror_reference(*forward, *mirror, numbers, k_i);
      report.mirror_logs = mirror_logs;
      report.mirror_position_mismatch = reference.max_position_mismatch;
      for (std::size_t i = 0; i < report.joints.size(); ++i) {
        auto& j = report.joints[i];
        const double guard = j.min_speed > 0 ? 3.0 / j.gains.k1 : 0.0;
        j.mirror = fit::compare_mirror(reference, i, j.fit.model.kind, j.fit.model.parameters, options.friction, skip,
                                       j.min_speed, guard);
        if (j.fit.static_model)
          j.mirror_static = fit::compare_mirror(reference, i, friction::Kind::stribeck,
                                                j.fit.static_model->parameters, options.friction, skip,
                                                j.min_speed, guard);
      }
    }

    // The profile: refuse a worse fit unless forced; write a new file and rename it.
    int status = cli::kSuccess;
    const std::string destination = update ? profile_name : output;
    std::string failure;
    if (destination.empty()) {
      report.outcome = "profile not written (use --update or -o)";
    } else {
      const auto worse = fit::worse_than_current(report);
      std::string thin;  // joints with too few samples for a fit worth writing
      for (const auto& s : series)
        if (s.scored_count() < kMinimumSamples) thin += (thin.empty() ? "" : ",") + std::to_string(s.joint);
      std::string failed;
      for (const auto& j : report.joints)
        if (!j.failure.empty()) failed += (failed.empty() ? "joint " : "; joint ") + std::to_string(j.fit.joint) + ": " + j.failure;
      if (!thin.empty()) {
        failure = "joint" + std::string(thin.find(',') != std::string::npos ? "s " : " ") + thin +
                  ": fewer than " + std::to_string(kMinimumSamples) +
                  " samples counted; a fit from so few is not written (profile not written)";
        report.outcome = "refused: " + failure;
        status = cli::kFailure;
      } else if (!failed.empty() && !force) {
        failure = failed + ": the fit failed; profile not written (--force to write anyway)";
        report.outcome = "refused: " + failure;
        status = cli::kFailure;
      } else if (!worse.empty() && !force) {
        std::string list;
        for (int j : worse) list += (list.empty() ? "" : ",") + std::to_string(j);
        failure = "joint" + std::string(worse.size() > 1 ? "s " : " ") + list +
                  ": the new fit is worse than the profile's current friction on these data; profile not written (--force to write anyway)";
        report.outcome = "refused: " + failure;
        status = cli::kFailure;
      } else {
        nlohmann::json document = profile.document;
        const nlohmann::json* current_section =
            document.contains("friction") && current ? &document["friction"] : nullptr;
        document["friction"] = fit::merged_friction_section(current_section, robot.nq, fits, options.kind,
                                                            options.friction);
        model::append_provenance(document, "mo-lugre-fit", fit::provenance_details(report, window_text));
        if (destination == "-") {
          core::write_document("-", document.dump(2) + "\n");
        } else {
          model::save_profile_as(document, profile, destination);
        }
        report.outcome = "friction written to " + (destination == "-" ? std::string("stdout") : destination);
      }
    }
    for (const auto& j : report.joints)
      if (const std::string w = fit::position_dependence_warning(j); !w.empty()) warn(w);
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!tool.quiet()) std::fputs(fit::report_text(report).c_str(), stderr);
    if (!report_path.empty()) {
      core::write_document(report_path, fit::report_json(report).dump(2) + "\n");
    }
    if (!failure.empty()) throw Error(failure);
    return status;
  });
}
