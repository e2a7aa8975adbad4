#include "momentum/friction_fit/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>

#include "momentum/core/error.hpp"
#include "momentum/model/json_number.hpp"
#include "momentum/version.hpp"

namespace momentum::friction_fit {

namespace {

using nlohmann::json;

json metrics_json(const FitMetrics& m) {
  return {{"samples", m.samples}, {"rms", model::json_number(m.rms)}, {"max_abs", model::json_number(m.max_abs)},
          {"r_squared", model::json_number(m.r_squared)}, {"cost", model::json_number(m.cost)}};
}

json model_json(const ModelFit& m) {
  json out;
  out["model"] = friction::kind_name(m.kind);
  json parameters = json::object();
  for (int i = 0; i < kParameterCount; ++i) {
    const auto& e = m.estimates[static_cast<std::size_t>(i)];
    if (!e.used) continue;
    parameters[friction::kParameterNames[i]] = {
        {"value", model::json_number(e.value)},
        {"standard_error", model::json_number(e.standard_error)},
        {"uncertainty", model::json_number(e.uncertainty)},
        {"discretization_shift", model::json_number(e.discretization_shift)},
        {"velocity_noise_shift", model::json_number(e.velocity_noise_shift)},
        {"free", e.free},
        {"at_bound", e.at_bound < 0 ? json("lower") : e.at_bound > 0 ? json("upper") : json(nullptr)},
        {"identifiable", e.identifiable},
        {"note", e.note}};
  }
  out["parameters"] = parameters;
  json names = json::array();
  for (int i : m.free) names.push_back(friction::kParameterNames[i]);
  json matrix = json::array();
  for (Eigen::Index a = 0; a < m.correlation.rows(); ++a) {
    json row = json::array();
    for (Eigen::Index b = 0; b < m.correlation.cols(); ++b) row.push_back(model::json_number(m.correlation(a, b)));
    matrix.push_back(row);
  }
  out["correlation"] = {{"parameters", names}, {"matrix", matrix}};
  out["metrics"] = metrics_json(m.metrics);
  out["evaluations"] = m.evaluations;
  out["seconds"] = m.seconds;
  out["global"] = {{"cost", model::json_number(m.global.cost)},
                   {"rms", model::json_number(m.global_metrics.rms)},
                   {"evaluations", m.global.evaluations},
                   {"generations", m.global.generations},
                   {"runs", m.global.runs},
                   {"seconds", m.global.seconds},
                   {"message", m.global.message},
                   {"subset", {{"used", m.subset.used},
                               {"segments", m.subset.segments},
                               {"samples", m.subset.samples},
                               {"counted", m.subset.counted},
                               {"counted_total", m.subset.counted_total}}}};
  out["polish"] = {{"iterations", m.polish_iterations},
                   {"residual_evaluations", m.polish_residual_evaluations},
                   {"jacobian_evaluations", m.polish_jacobian_evaluations},
                   {"message", m.polish_message},
                   {"subset", {{"used", m.fit_subset.used},
                               {"segments", m.fit_subset.segments},
                               {"samples", m.fit_subset.samples},
                               {"counted", m.fit_subset.counted},
                               {"counted_total", m.fit_subset.counted_total}}}};
  // The counted samples the standard errors rest on (the fit's subset on long data).
  out["covariance"] = {{"samples", m.fit_subset.used ? m.fit_subset.counted : m.metrics.samples},
                       {"ok", m.covariance_ok},
                       {"condition_number", model::json_number(m.condition_number)},
                       {"autocorrelation_factor", model::json_number(m.autocorrelation_factor)},
                       {"note", m.covariance_note}};
  return out;
}

std::string printf_string(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string printf_string(const char* fmt, ...) {
  char buffer[1024];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buffer, sizeof buffer, fmt, args);
  va_end(args);
  return buffer;
}

std::string metrics_line(const FitMetrics& m) {
  return printf_string("rms %.4g Nm  max %.4g Nm  R^2 %.6f", m.rms, m.max_abs, m.r_squared);
}

}  // namespace

std::string position_dependence_warning(const JointReport& j) {
  const auto& s = j.residual_split;
  if (!s.computed || !s.position_dependent) return {};
  return printf_string("joint %d: %.0f%% of the residual the friction model leaves (rms %.3g Nm) depends on the "
                       "joint positions (velocity explains %.0f%%): a model error (masses, inertia, payload), not "
                       "friction; correct the model with mo-dynfit(1) and fit the friction again",
                       j.fit.joint, 100.0 * s.position_fraction, s.residual_rms, 100.0 * s.velocity_fraction);
}

bool asymmetry_helped(const JointFit& fit) {
  if (!fit.symmetric_model || !fit.model.asymmetric) return false;
  const auto& m = fit.model;
  const auto& s = *fit.symmetric_model;
  if (!(m.metrics.rms < (1.0 - kAsymmetryGain) * s.metrics.rms)) return false;
  for (int i : {6, 7}) {
    const auto& e = m.estimates[static_cast<std::size_t>(i)];
    if (e.used && e.free && std::isfinite(e.uncertainty) && std::abs(e.value) > 3.0 * e.uncertainty) return true;
  }
  return false;
}

namespace {

void append_parameters(std::string& out, const ModelFit& m, const char* indent) {
  for (int i = 0; i < kParameterCount; ++i) {
    const auto& e = m.estimates[static_cast<std::size_t>(i)];
    if (!e.used) continue;
    std::string se;
    if (!e.free)
      se = "(fixed)";
    else if (!std::isfinite(e.uncertainty))
      se = "+- ?";
    else if (std::isfinite(e.discretization_shift) && std::isfinite(e.velocity_noise_shift))
      se = printf_string("+- %-9.3g (r noise %.2g, sub-sample %.2g, dq noise %.2g)", e.uncertainty,
                         e.standard_error, std::abs(e.discretization_shift), std::abs(e.velocity_noise_shift));
    else
      se = printf_string("+- %.3g", e.uncertainty);
    out += printf_string("%s%-7s %-12.6g ", indent, friction::kParameterNames[i], e.value);
    out += e.note.empty() ? se : printf_string("%-58s", se.c_str());
    if (!e.note.empty()) out += "  " + e.note;
    out += '\n';
  }
}

}  // namespace

json report_json(const FitReport& r) {
  json out;
  out["tool"] = "mo-lugre-fit";
  out["version"] = kVersion;
  out["inputs"] = r.inputs;
  out["profile"] = r.profile;
  out["model"] = friction::kind_name(r.options.kind);
  const auto& g = r.options.global;
  out["search"] = {{"method", method_name(g.method)},
                   {"population", g.genetic.population},
                   {"generations", g.genetic.generations},
                   {"crossover", g.genetic.crossover},
                   {"mutation", g.genetic.mutation},
                   {"elite", g.genetic.elite},
                   {"restarts", g.genetic.restarts},
                   {"stall_generations", g.genetic.stall_generations},
                   {"seed", g.genetic.seed},
                   {"polish", r.options.polish.enabled}};
  json bounds = json::object();
  for (int i = 0; i < kParameterCount; ++i)
    bounds[friction::kParameterNames[i]] = {r.options.bounds.lower[static_cast<std::size_t>(i)],
                                            r.options.bounds.upper[static_cast<std::size_t>(i)]};
  out["bounds"] = bounds;
  out["observer_order"] = r.observer_order;
  json joints = json::array();
  for (const auto& j : r.joints) {
    json entry;
    entry["joint"] = j.fit.joint;
    entry["sample_rate_hz"] = model::json_number(j.sample_rate_hz);
    entry["velocity_noise"] = model::json_number(j.velocity_noise);
    entry["min_speed"] = model::json_number(j.min_speed);
    entry["excluded_slow_samples"] = j.excluded_slow;
    json joint_bounds = json::object();
    for (int i = 0; i < kParameterCount; ++i)
      joint_bounds[friction::kParameterNames[i]] = {model::json_number(j.bounds.lower[static_cast<std::size_t>(i)]),
                                                    model::json_number(j.bounds.upper[static_cast<std::size_t>(i)])};
    entry["bounds"] = joint_bounds;
    entry["widenings"] = j.widenings;
    entry["failure"] = j.failure;
    entry["observer_gains"] = {{"k1", j.gains.k1}, {"k2", j.gains.k2}, {"k3", j.gains.k3}};
    entry["fit"] = model_json(j.fit.model);
    entry["static"] = j.fit.static_model ? model_json(*j.fit.static_model) : json(nullptr);
    entry["asymmetric"] = j.fit.model.asymmetric;
    if (j.residual_split.computed)
      entry["residual_split"] = {{"samples", j.residual_split.samples},
                                 {"residual_rms", model::json_number(j.residual_split.residual_rms)},
                                 {"position_fraction", model::json_number(j.residual_split.position_fraction)},
                                 {"velocity_fraction", model::json_number(j.residual_split.velocity_fraction)},
                                 {"explained_rms", model::json_number(j.residual_split.explained_rms)},
                                 {"signal_rms", model::json_number(j.residual_split.signal_rms)},
                                 {"position_features", j.residual_split.position_features},
                                 {"position_dependent", j.residual_split.position_dependent}};
    else
      entry["residual_split"] = nullptr;
    if (j.fit.symmetric_model) {
      entry["symmetric"] = model_json(*j.fit.symmetric_model);
      entry["asymmetry_helped"] = asymmetry_helped(j.fit);
    }
    if (j.current)
      entry["current"] = {{"model", friction::kind_name(*j.current_kind)}, {"metrics", metrics_json(*j.current)}};
    else
      entry["current"] = nullptr;
    if (j.mirror) {
      entry["mirror"] = {{"samples", j.mirror->samples}, {"excluded", j.mirror->excluded}, {"rms", model::json_number(j.mirror->rms)}, {"max_abs", model::json_number(j.mirror->max_abs)}};
      if (j.mirror_static)
        entry["mirror"]["static_rms"] = model::json_number(j.mirror_static->rms);
    }
    entry["seconds"] = j.fit.seconds;
    joints.push_back(entry);
  }
  out["joints"] = joints;
  if (!r.mirror_logs.empty())
    out["mirror"] = {{"logs", r.mirror_logs}, {"max_position_mismatch", r.mirror_position_mismatch}};
  out["seconds"] = r.seconds;
  out["outcome"] = r.outcome;
  return out;
}

std::string report_text(const FitReport& r) {
  std::string out;
  const auto& g = r.options.global;
  out += printf_string("mo-lugre-fit: %s, %zu joint%s, search %s", friction::kind_name(r.options.kind),
                       r.joints.size(), r.joints.size() == 1 ? "" : "s", method_name(g.method));
  if (g.method == GlobalMethod::ga)
    out += printf_string(" (population %d, %d generations, %d run%s)", g.genetic.population,
                         g.genetic.generations, g.genetic.restarts, g.genetic.restarts == 1 ? "" : "s");
  out += r.options.polish.enabled ? " + Ceres polish" : ", no polish";
  out += printf_string(", seed %llu, %.3f s\n", static_cast<unsigned long long>(g.genetic.seed), r.seconds);
  for (const auto& j : r.joints) {
    const auto& m = j.fit.model;
    out += printf_string("joint %d: %s  %zu samples at %.4g Hz, observer k1 %g k2 %g k3 %g\n", j.fit.joint,
                         friction::kind_name(m.kind), m.metrics.samples, j.sample_rate_hz, j.gains.k1,
                         j.gains.k2, j.gains.k3);
    if (j.min_speed > 0)
      out += printf_string("  %zu samples slower than %.3g rad/s (velocity noise %.3g rad/s) or settling after them not counted\n",
                           j.excluded_slow, j.min_speed, j.velocity_noise);
    out += printf_string("  search box sigma2 <= %.4g, tau_c, tau_s <= %.4g, w_s <= %.4g%s\n", j.bounds.upper[2],
                         j.bounds.upper[3], j.bounds.upper[5],
                         j.widenings ? printf_string(" (widened %d time%s)", j.widenings, j.widenings == 1 ? "" : "s").c_str() : "");
    if (!j.failure.empty()) out += "  FAILED: " + j.failure + "\n";
    out += "  " + metrics_line(m.metrics) +
           printf_string("  %llu evaluations  %.3f s\n", static_cast<unsigned long long>(m.evaluations), m.seconds);
    if (m.global.runs > 0 && r.options.polish.enabled)
      out += printf_string("  global search rms %.4g Nm (%s), polish: %d iterations\n", m.global_metrics.rms,
                           m.global.message.c_str(), m.polish_iterations);
    if (m.subset.used)
      out += printf_string("  searched on %zu of %zu counted samples (%zu windows), ", m.subset.counted,
                           m.subset.counted_total, m.subset.segments) +
             (m.fit_subset.used ? printf_string("polished and uncertainties on %zu (%zu windows)\n", m.fit_subset.counted,
                                                m.fit_subset.segments)
                                : std::string("polished on all\n"));
    append_parameters(out, m, "  ");
    std::string strong;
    for (Eigen::Index a = 0; a < m.correlation.rows(); ++a)
      for (Eigen::Index b = a + 1; b < m.correlation.cols(); ++b) {
        const double c = m.correlation(a, b);
        if (std::isfinite(c) && std::abs(c) >= 0.9)
          strong += printf_string(" %s/%s %.3f", friction::kParameterNames[m.free[static_cast<std::size_t>(a)]],
                                  friction::kParameterNames[m.free[static_cast<std::size_t>(b)]], c);
      }
    if (!strong.empty()) out += "  correlations >= 0.9:" + strong + "\n";
    if (!m.covariance_note.empty()) out += "  covariance: " + m.covariance_note + "\n";
    if (j.fit.static_model) {
      const auto& s = *j.fit.static_model;
      out += "  static (stribeck): " + metrics_line(s.metrics);
      if (s.metrics.rms > 0)
        out += printf_string("  (lugre: %+.1f%% rms)", 100.0 * (m.metrics.rms / s.metrics.rms - 1.0));
      out += '\n';
      append_parameters(out, s, "    ");
    }
    if (j.residual_split.computed) {
      const auto& split = j.residual_split;
      out += printf_string("  left after friction: rms %.4g Nm, of which positions explain %.1f%%, velocity %.1f%%%s\n",
                           split.residual_rms, 100.0 * split.position_fraction, 100.0 * split.velocity_fraction,
                           split.position_dependent ? " (position-dependent: see the warning)" : "");
    }
    if (j.fit.symmetric_model) {
      const auto& s = *j.fit.symmetric_model;
      out += printf_string("  symmetric %s: ", friction::kind_name(s.kind)) + metrics_line(s.metrics);
      if (s.metrics.rms > 0)
        out += printf_string("  (asymmetric: %+.1f%% rms, R^2 %+.2g)", 100.0 * (m.metrics.rms / s.metrics.rms - 1.0),
                             m.metrics.r_squared - s.metrics.r_squared);
      out += asymmetry_helped(j.fit) ? ": the asymmetry helped\n" : ": the asymmetry did not help (keep the symmetric model)\n";
    }
    if (j.current)
      out += printf_string("  current profile friction (%s): ", friction::kind_name(*j.current_kind)) +
             metrics_line(*j.current) + "\n";
    if (j.mirror) {
      out += printf_string("  mirror check: rms %.4g Nm  max %.4g Nm over %zu samples (%zu near slow motion left out)",
                           j.mirror->rms, j.mirror->max_abs, j.mirror->samples, j.mirror->excluded);
      if (j.mirror_static) out += printf_string("  (stribeck rms %.4g Nm)", j.mirror_static->rms);
      out += '\n';
    }
  }
  if (!r.mirror_logs.empty())
    out += printf_string("mirror logs %s / %s: largest position mismatch %.3g rad\n", r.mirror_logs[0].c_str(),
                         r.mirror_logs.size() > 1 ? r.mirror_logs[1].c_str() : "?", r.mirror_position_mismatch);
  if (!r.outcome.empty()) out += r.outcome + "\n";
  return out;
}

std::optional<friction::SteadyCovariance> steady_covariance(const ModelFit& fit) {
  if (!fit.covariance_ok) return std::nullopt;
  std::vector<std::size_t> rows;  // positions in `free`
  friction::SteadyCovariance c;
  for (std::size_t k = 0; k < fit.free.size(); ++k)
    if (fit.free[k] >= 2) {
      rows.push_back(k);
      c.parameters.push_back(fit.free[k]);
    }
  if (rows.empty() || fit.correlation.rows() != static_cast<Eigen::Index>(fit.free.size())) return std::nullopt;
  for (std::size_t a : rows)
    for (std::size_t b : rows) {
      // The correlation's two halves agree only to rounding (a near-zero correlation can differ
      // in its leading digit); their mean, multiplied in one order, is the same both ways, so the
      // profile holds a matrix that is symmetric to the bit.
      const auto i = static_cast<Eigen::Index>(a), k = static_cast<Eigen::Index>(b);
      const double correlation = 0.5 * (fit.correlation(std::min(i, k), std::max(i, k)) +
                                        fit.correlation(std::max(i, k), std::min(i, k)));
      const double u_a = fit.estimates[static_cast<std::size_t>(fit.free[a])].uncertainty;
      const double u_b = fit.estimates[static_cast<std::size_t>(fit.free[b])].uncertainty;
      const double value = correlation * std::min(u_a, u_b) * std::max(u_a, u_b);
      if (!std::isfinite(value)) return std::nullopt;
      c.matrix.push_back(value);
    }
  return c;
}

json merged_friction_section(const json* current, int joints, const std::vector<JointFit>& fits,
                             friction::Kind kind, const friction::Options& options) {
  std::vector<bool> fitted(static_cast<std::size_t>(joints), false);
  for (const auto& f : fits) {
    if (f.joint < 1 || f.joint > joints)
      throw Error("joint " + std::to_string(f.joint) + " is not a joint of the robot (it has " +
                  std::to_string(joints) + ")");
    fitted[static_cast<std::size_t>(f.joint - 1)] = true;
  }
  std::string missing;
  for (int j = 1; j <= joints; ++j)
    if (!fitted[static_cast<std::size_t>(j - 1)]) missing += (missing.empty() ? "" : ",") + std::to_string(j);
  json section;
  if (current && !current->is_null()) {
    const friction::FrictionModel old = friction::friction_from_json(*current);
    const bool same_shape = old.kind == kind && static_cast<int>(old.joints.size()) == joints;
    if (!same_shape && !missing.empty())
      throw Error(std::string("the profile's friction is ") + friction::kind_name(old.kind) + " for " +
                  std::to_string(old.joints.size()) + " joints; a " + friction::kind_name(kind) +
                  " fit of some joints would leave joints " + missing +
                  " inconsistent: fit every joint, or use --model " + friction::kind_name(old.kind));
    section = *current;
    if (!same_shape) section["joints"] = json::array();
    while (static_cast<int>(section["joints"].size()) < joints) section["joints"].push_back(json::object());
  } else {
    if (!missing.empty())
      throw Error("the profile has no friction section; fitting only some joints would leave joints " + missing +
                  " without friction: fit every joint");
    friction::FrictionModel fresh;
    fresh.kind = kind;
    fresh.options = options;
    section = friction::to_json(fresh);
    section["joints"] = json::array();
    for (int j = 0; j < joints; ++j) section["joints"].push_back(json::object());
  }
  section["model"] = friction::kind_name(kind);
  if (friction::has_state(kind) && !section.contains("update"))
    section["update"] = friction::update_name(options.update);
  for (const auto& f : fits) {
    json& entry = section["joints"][static_cast<std::size_t>(f.joint - 1)];
    if (!entry.is_object()) entry = json::object();
    for (const char* name : friction::kParameterNames) entry.erase(name);
    entry.erase("covariance");
    double x[kParameterCount];
    f.model.parameters.to_array(x);
    for (int i : model_parameters(kind, f.model.asymmetric)) entry[friction::kParameterNames[i]] = x[i];
    if (const auto covariance = steady_covariance(f.model)) entry["covariance"] = friction::covariance_to_json(*covariance);
  }
  // The result must read back (catches a merge that left a joint incomplete).
  (void)friction::friction_from_json(section);
  return section;
}

std::vector<int> worse_than_current(const FitReport& r) {
  std::vector<int> worse;
  for (const auto& j : r.joints)
    if (j.current && j.fit.model.metrics.rms > j.current->rms * (1 + 1e-9)) worse.push_back(j.fit.joint);
  return worse;
}

json provenance_details(const FitReport& r, const std::string& window) {
  json d;
  d["logs"] = r.inputs;
  d["model"] = friction::kind_name(r.options.kind);
  const auto& g = r.options.global;
  d["method"] = std::string(method_name(g.method)) + (r.options.polish.enabled ? "+ceres" : "");
  d["seed"] = g.genetic.seed;
  if (!window.empty()) d["window"] = window;
  json metrics = json::array();
  for (const auto& j : r.joints)
    metrics.push_back({{"joint", j.fit.joint},
                       {"rms", model::json_number(j.fit.model.metrics.rms)},
                       {"max_abs", model::json_number(j.fit.model.metrics.max_abs)},
                       {"r_squared", model::json_number(j.fit.model.metrics.r_squared)},
                       {"samples", j.fit.model.metrics.samples}});
  d["joints"] = metrics;
  return d;
}

}  // namespace momentum::friction_fit
