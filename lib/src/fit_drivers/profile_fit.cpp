#include "momentum/fit_drivers/profile_fit.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>

#include "momentum/core/error.hpp"
#include "momentum/core/file.hpp"
#include "momentum/core/number.hpp"
#include "momentum/core/text.hpp"
#include "momentum/friction_fit/mirror.hpp"
#include "momentum/friction/friction.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/observer/observer.hpp"

namespace momentum::drivers {

// This driver runs the friction fitting stage: its names are this file's vocabulary.
using namespace friction_fit;

double parse_option_number(const std::string& text, const std::string& option) {
  const auto v = core::parse_double(text);
  if (!v || !std::isfinite(*v)) throw OptionError(option + ": '" + text + "' is not a number");
  return *v;
}

namespace {

// "NAME=VALUE,..." with NAME a parameter: apply(index, VALUE) for each.
void parse_assignments(const std::string& text, const std::string& option,
                       const std::function<void(int, const std::string&)>& apply) {
  for (const auto& item : core::split(text)) {
    const auto eq = item.find('=');
    const int index = eq == std::string::npos ? -1 : parameter_index(item.substr(0, eq));
    if (index < 0)
      throw OptionError(option + ": '" + item +
                        "' is not NAME=VALUE with NAME one of sigma0, sigma1, sigma2, tau_c, tau_s, w_s, delta_c, delta_s");
    apply(index, item.substr(eq + 1));
  }
}

// The profile's observer and current friction (nullopt when it has none, or when it does not
// match the robot, or when it cannot be read and `force` says to go on without it).
struct ProfileState {
  model::Profile profile;
  model::Model robot;
  observer::ObserverOptions observer;
  std::optional<friction::FrictionModel> current;
};

ProfileState read_profile(const std::string& name, bool force) {
  ProfileState s{model::load_profile(name), {}, {}, {}};
  s.robot = model::build_model(s.profile);
  try {
    std::vector<std::string> notes;
    if (auto it = s.profile.document.find("observer"); it != s.profile.document.end())
      s.observer = observer::observer_options_from_json(*it, &notes);
    if (auto it = s.profile.document.find("friction"); it != s.profile.document.end()) {
      try {
        s.current = friction::friction_from_json(*it, &notes);
      } catch (const Error& e) {
        if (!force) throw;
        warn(name + ": " + e.what() + "; ignored (--force)");
      }
    }
    for (const auto& n : notes) warn(name + ": " + n);
  } catch (const Error& e) {
    throw Error(name + ": " + e.what());
  }
  if (s.current && static_cast<int>(s.current->joints.size()) != s.robot.nq) {
    warn(name + ": the friction section has " + std::to_string(s.current->joints.size()) + " joints, the robot " +
         std::to_string(s.robot.nq) + "; not compared");
    s.current.reset();
  }
  return s;
}

// The progress line of the joints being fitted: the latest state of each.
class ProgressText {
 public:
  ProgressText(const std::vector<JointSeries>& series, const ProgressLine& out)
      : series_(series), out_(out), state_(series.size()) {}
  void operator()(const JointProgress& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (std::size_t i = 0; i < series_.size(); ++i)
      if (series_[i].joint == p.joint) {
        char text[96];
        if (std::string(p.stage) == "polish")
          std::snprintf(text, sizeof text, "j%d polish", p.joint);
        else
          std::snprintf(text, sizeof text, "j%d %s run %d gen %d cost %.4g", p.joint, p.stage, p.search.restart + 1,
                        p.search.generation, p.search.best_cost);
        state_[i] = text;
      }
    std::string line = "mo-lugre-fit:";
    for (const auto& s : state_)
      if (!s.empty()) line += "  " + s;
    out_(line);
  }

 private:
  const std::vector<JointSeries>& series_;
  const ProgressLine& out_;
  std::vector<std::string> state_;
  std::mutex mutex_;
};

// Why the fit must not be written (empty: it may): too few samples, a failed or a worse fit.
std::string refusal(const FitReport& report, const std::vector<JointSeries>& series, bool force) {
  std::string thin;  // joints with too few samples for a fit worth writing
  for (const auto& s : series)
    if (s.scored_count() < kMinimumSamples) thin += (thin.empty() ? "" : ",") + std::to_string(s.joint);
  if (!thin.empty())
    return "joint" + std::string(thin.find(',') != std::string::npos ? "s " : " ") + thin + ": fewer than " +
           std::to_string(kMinimumSamples) + " samples counted; a fit from so few is not written (profile not written)";
  std::string failed;
  for (const auto& j : report.joints)
    if (!j.failure.empty())
      failed += (failed.empty() ? "joint " : "; joint ") + std::to_string(j.fit.joint) + ": " + j.failure;
  if (!failed.empty() && !force) return failed + ": the fit failed; profile not written (--force to write anyway)";
  const auto worse = worse_than_current(report);
  if (!worse.empty() && !force) {
    std::string list;
    for (int j : worse) list += (list.empty() ? "" : ",") + std::to_string(j);
    return "joint" + std::string(worse.size() > 1 ? "s " : " ") + list +
           ": the new fit is worse than the profile's current friction on these data; profile not written (--force to "
           "write anyway)";
  }
  return "";
}

}  // namespace

void parse_bounds(const std::string& text, const std::string& option, ParameterBounds& bounds,
                  std::array<bool, kParameterCount>& user_bounds) {
  parse_assignments(text, option, [&](int i, const std::string& range) {
    const auto u = static_cast<std::size_t>(i);
    user_bounds[u] = true;
    const auto colon = range.find(':');
    if (colon == std::string::npos) throw OptionError(option + ": '" + range + "' is not LO:HI");
    bounds.lower[u] = parse_option_number(range.substr(0, colon), option);
    bounds.upper[u] = parse_option_number(range.substr(colon + 1), option);
  });
}

void parse_fixed(const std::string& text, const std::string& option,
                 std::array<std::optional<double>, kParameterCount>& fixed) {
  parse_assignments(text, option, [&](int i, const std::string& v) {
    fixed[static_cast<std::size_t>(i)] = parse_option_number(v, option);
  });
}

std::vector<int> parse_joints(const std::string& text, const std::string& option) {
  std::vector<int> joints;
  for (const auto& j : core::split(text)) {
    const double v = parse_option_number(j, option);
    // Out of int's range the conversion below is undefined (UBSan, the hostile test).
    if (v < 1 || v > 1e6 || v != std::floor(v)) throw OptionError(option + ": '" + j + "' is not a joint number");
    joints.push_back(static_cast<int>(v));
  }
  return joints;
}

void parse_window(const std::string& text, const std::string& option, SelectOptions& select) {
  if (text.empty()) return;
  const auto colon = text.find(':');
  if (colon == std::string::npos) throw OptionError(option + ": '" + text + "' is not A:B");
  if (colon > 0) select.window_begin = parse_option_number(text.substr(0, colon), option);
  if (colon + 1 < text.size()) select.window_end = parse_option_number(text.substr(colon + 1), option);
}

ProfileFitSummary fit_profile_friction(const ProfileFitOptions& options, const OpenInput& open_input,
                                       const ProgressLine& progress) {
  const auto start = std::chrono::steady_clock::now();
  const ProfileState state = read_profile(options.profile, options.force);
  const model::Model& robot = state.robot;
  IdentifyOptions identify = options.identify;
  if (state.current) identify.fit.friction = state.current->options;
  SelectOptions select = options.select;
  select.gap_factor = state.observer.gap_factor;
  // Long logs are thinned to windows while read: each input its share of the budget, each
  // window long against the observer's memory, which its warm-up lets fade (5 of the
  // slowest time constant, 1/K2 for the second-order observer); then the logs together to
  // the whole budget, since a share is never less than one window.
  std::vector<std::string> inputs = options.inputs;
  if (inputs.empty()) inputs.push_back("-");
  const std::vector<observer::Gains> robot_gains = state.observer.joint_gains(robot.nq);
  if (options.max_samples > 0) {
    double slowest = 0;
    for (const auto& g : robot_gains) slowest = std::max(slowest, 1.0 / (g.k2 > 0 ? g.k2 : g.k1));
    select.max_samples = std::max<std::size_t>(options.max_samples / inputs.size(), 1);
    select.thin_warmup = 5 * slowest;
    select.thin_window = std::max(10.0, 10 * select.thin_warmup);
  }
  std::string why;
  if (!identify.IsValid(&why)) throw OptionError(why);
  if (!select.IsValid(&why)) throw OptionError(why);

  // The data: every log, appended joint by joint.
  std::vector<JointSeries> series;
  for (const auto& path : inputs) {
    auto in = open_input(path);
    auto more = read_series(*in, select);
    if (series.empty()) {
      series = std::move(more);
    } else {
      if (more.size() != series.size()) throw Error(in->name() + ": has other joints than " + inputs.front());
      append_log(series, more);
    }
  }
  thin_to_budget(series, options.max_samples);
  std::vector<observer::Gains> gains;
  for (auto& s : series) {
    if (s.joint > robot.nq)
      throw Error(s.source + ": joint " + std::to_string(s.joint) + " is not a joint of the robot (it has " +
                  std::to_string(robot.nq) + ")");
    gains.push_back(robot_gains[static_cast<std::size_t>(s.joint - 1)]);
  }

  // Samples where a joint (nearly) stands still do not count: the measured velocity cannot
  // resolve sticking there (see man page). The observer forgets them in about 3 / K1 s.
  FitReport report;
  report.joints.resize(series.size());
  for (std::size_t i = 0; i < series.size(); ++i) {
    auto& s = series[i];
    auto& j = report.joints[i];
    j.velocity_noise = estimate_velocity_noise(s);
    j.min_speed = options.min_speed ? *options.min_speed : 5.0 * j.velocity_noise;
    if (j.min_speed < 0) throw OptionError("--min-speed must be >= 0");
    if (j.min_speed > 0) j.excluded_slow = exclude_slow_samples(s, j.min_speed, 3.0 / gains[i].k1);
    if (s.scored_count() == 0)
      throw Error(s.source + ": joint " + std::to_string(s.joint) + ": no sample faster than --min-speed " +
                  std::to_string(j.min_speed) + " rad/s left to fit");
  }

  // Fit.
  std::vector<double> effort, velocity;
  for (const auto& s : series) {
    const auto& limits = robot.joints[static_cast<std::size_t>(s.joint - 1)].limits;
    effort.push_back(limits.effort);
    velocity.push_back(limits.velocity);
  }
  JointProgressCallback on_progress;
  ProgressText text(series, progress);
  if (progress) on_progress = [&text](const JointProgress& p) { text(p); };
  const auto identified = identify_friction(series, gains, effort, velocity, identify, on_progress);
  if (progress) progress("");

  const FitOptions& fit_options = identify.fit;
  report.inputs = inputs;
  report.profile = options.profile;
  report.options = fit_options;
  report.observer_order = state.observer.order;
  std::vector<JointFit> fits;
  for (std::size_t i = 0; i < identified.size(); ++i) {
    fits.push_back(identified[i].fit);
    JointReport& j = report.joints[i];
    j.fit = identified[i].fit;
    j.bounds = identified[i].bounds;
    j.widenings = identified[i].widenings;
    j.failure = identified[i].failure;
    j.gains = gains[i];
    const double dt = series[i].median_dt();
    j.sample_rate_hz = dt > 0 ? 1.0 / dt : 0.0;
    if (state.current) {
      j.current_kind = state.current->kind;
      j.current = evaluate_fit(series[i], gains[i], state.current->kind,
                               state.current->joints[static_cast<std::size_t>(j.fit.joint - 1)], state.current->options);
    }
    const auto model_r =
        predict_residual(series[i], gains[i], j.fit.model.kind, j.fit.model.parameters, fit_options.friction);
    std::vector<double> left(model_r.size());
    for (std::size_t k = 0; k < left.size(); ++k) left[k] = series[i].r[k] - model_r[k];
    j.residual_split = split_residual(series[i], gains[i], left);
  }
  if (!options.mirror_logs.empty()) {
    std::vector<int> numbers;
    for (const auto& s : series) numbers.push_back(s.joint);
    std::vector<double> k_i(robot.k_i.data(), robot.k_i.data() + robot.k_i.size());
    auto forward = open_input(options.mirror_logs[0]);
    auto mirror = open_input(options.mirror_logs[1]);
    const auto reference = mirror_reference(*forward, *mirror, numbers, k_i);
    report.mirror_logs = options.mirror_logs;
    report.mirror_position_mismatch = reference.max_position_mismatch;
    const double skip = options.select.skip;
    for (std::size_t i = 0; i < report.joints.size(); ++i) {
      auto& j = report.joints[i];
      const double guard = j.min_speed > 0 ? 3.0 / j.gains.k1 : 0.0;
      j.mirror = compare_mirror(reference, i, j.fit.model.kind, j.fit.model.parameters, fit_options.friction, skip,
                                j.min_speed, guard);
      if (j.fit.static_model)
        j.mirror_static = compare_mirror(reference, i, friction::Kind::stribeck, j.fit.static_model->parameters,
                                         fit_options.friction, skip, j.min_speed, guard);
    }
  }

  // The profile: refuse a worse fit unless forced; write a new file and rename it.
  ProfileFitSummary summary;
  const std::string& destination = options.destination;
  if (destination.empty()) {
    report.outcome = "profile not written (use --update or -o)";
  } else if (summary.failure = refusal(report, series, options.force); !summary.failure.empty()) {
    report.outcome = "refused: " + summary.failure;
  } else {
    nlohmann::json document = state.profile.document;
    const nlohmann::json* current_section = document.contains("friction") && state.current ? &document["friction"] : nullptr;
    document["friction"] =
        merged_friction_section(current_section, robot.nq, fits, fit_options.kind, fit_options.friction);
    model::append_provenance(document, "mo-lugre-fit", provenance_details(report, options.window_text));
    report.outcome = "friction written to " + model::write_updated_profile(document, state.profile, destination);
  }
  for (const auto& j : report.joints)
    if (const std::string w = position_dependence_warning(j); !w.empty()) warn(w);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary.report = std::move(report);
  return summary;
}

}  // namespace momentum::drivers
