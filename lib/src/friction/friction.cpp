#include "momentum/friction/friction.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <string>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"

namespace momentum::friction {
namespace {

[[noreturn]] void error(const std::string& message) { throw Error("friction: " + message); }

}  // namespace

bool Options::IsValid(std::string* why) const {
  if (!std::isfinite(velocity_deadband) || velocity_deadband < 0)
    return invalid(why, "velocity_deadband = " + core::significant(velocity_deadband, 17) + " is not a finite value >= 0");
  if (!std::isfinite(velocity_cutoff_hz) || velocity_cutoff_hz < 0)
    return invalid(why, "velocity_cutoff_hz = " + core::significant(velocity_cutoff_hz, 17) + " is not a finite value >= 0");
  return true;
}

bool FrictionModel::IsValid(std::string* why) const {
  if (!options.IsValid(why)) return false;
  if (!covariance.empty() && covariance.size() != joints.size())
    return invalid(why, std::to_string(covariance.size()) + " covariances for " + std::to_string(joints.size()) + " joints");
  for (std::size_t j = 0; j < joints.size(); ++j) {
    std::string reason;
    if (!friction::IsValid(kind, joints[j], &reason))
      return invalid(why, "joint " + std::to_string(j + 1) + ": " + reason);
  }
  return true;
}

namespace {

SteadyCovariance covariance_from_json(const nlohmann::json& entry, const std::string& where) {
  if (!entry.is_object() || !entry.contains("parameters") || !entry.contains("matrix"))
    error(where + "not {\"parameters\": [names], \"matrix\": [[...]]}");
  const auto& names = entry["parameters"];
  const auto& rows = entry["matrix"];
  if (!names.is_array() || !rows.is_array() || rows.size() != names.size())
    error(where + "'parameters' and the rows of 'matrix' must be arrays of one size");
  SteadyCovariance c;
  for (const auto& name : names) {
    int index = -1;
    for (int i = 2; i < Parameters<double>::kSize; ++i)
      if (name.is_string() && name.get<std::string>() == kParameterNames[i]) index = i;
    if (index < 0) error(where + name.dump() + " is not one of sigma2, tau_c, tau_s, w_s, delta_c, delta_s");
    if (std::find(c.parameters.begin(), c.parameters.end(), index) != c.parameters.end())
      error(where + name.dump() + " is given twice");
    c.parameters.push_back(index);
  }
  const std::size_t n = c.parameters.size();
  for (std::size_t a = 0; a < n; ++a) {
    if (!rows[a].is_array() || rows[a].size() != n) error(where + "'matrix' is not " + std::to_string(n) + " x " + std::to_string(n));
    for (std::size_t b = 0; b < n; ++b) {
      if (!rows[a][b].is_number() || !std::isfinite(rows[a][b].get<double>())) error(where + "'matrix' holds a value that is not a finite number");
      c.matrix.push_back(rows[a][b].get<double>());
    }
  }
  for (std::size_t a = 0; a < n; ++a) {
    if (c.matrix[a * n + a] < 0) error(where + "a variance is negative");
    for (std::size_t b = 0; b < a; ++b) {
      // To 1e-9 of the scale of the two variances: a covariance near zero written by hand or
      // rounded need not agree in its leading digit with its mirror.
      const double x = c.matrix[a * n + b], y = c.matrix[b * n + a];
      const double scale = std::sqrt(c.matrix[a * n + a] * c.matrix[b * n + b]);
      if (std::abs(x - y) > 1e-9 * std::max({std::abs(x), std::abs(y), scale}))
        error(where + "'matrix' is not symmetric");
    }
  }
  return c;
}

}  // namespace

double steady_friction_sd(Kind kind, const Parameters<double>& p, const SteadyCovariance& covariance, double w) {
  double gradient[Parameters<double>::kSize];
  steady_gradient(kind, p, w, gradient);
  const std::size_t n = covariance.parameters.size();
  double variance = 0;
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = 0; b < n; ++b)
      variance += gradient[covariance.parameters[a]] * covariance.matrix[a * n + b] * gradient[covariance.parameters[b]];
  return std::sqrt(std::max(0.0, variance));
}

FrictionModel friction_from_json(const nlohmann::json& section, std::vector<std::string>* warnings) {
  if (!section.is_object()) error("the section is not an object");
  FrictionModel model;
  static const std::set<std::string> known = {"model", "update", "velocity_deadband",
                                              "velocity_cutoff_hz", "joints"};
  for (const auto& item : section.items()) {
    if (!known.count(item.key()) && warnings) warnings->push_back("friction: unknown key '" + item.key() + "'");
  }
  const auto model_it = section.find("model");
  if (model_it == section.end()) error("missing 'model'");
  if (!model_it->is_string() || !parse_kind(model_it->get<std::string>(), &model.kind))
    error("unknown model " + model_it->dump() + " (expected " + kind_names_text() + ")");
  if (const auto it = section.find("update"); it != section.end()) {
    if (!it->is_string() || !parse_update(it->get<std::string>(), &model.options.update))
      error("unknown update " + it->dump() + " (expected exact or semi-implicit)");
  }
  auto read_number = [&](const nlohmann::json& object, const char* key, double* value,
                         const std::string& where) {
    const auto it = object.find(key);
    if (it == object.end()) return false;
    if (!it->is_number() || !std::isfinite(it->get<double>()))
      error(where + "'" + key + "' is not a finite number");
    *value = it->get<double>();
    return true;
  };
  read_number(section, "velocity_deadband", &model.options.velocity_deadband, "");
  read_number(section, "velocity_cutoff_hz", &model.options.velocity_cutoff_hz, "");
  const auto joints = section.find("joints");
  if (joints == section.end()) error("missing 'joints'");
  if (!joints->is_array()) error("'joints' is not an array");
  const std::vector<int> used = used_parameters(model.kind, false);
  for (std::size_t j = 0; j < joints->size(); ++j) {
    const auto& entry = (*joints)[j];
    const std::string where = "joint " + std::to_string(j + 1) + ": ";
    if (!entry.is_object()) error(where + "not an object");
    double x[Parameters<double>::kSize];
    Parameters<double>().to_array(x);
    for (int i : used) {
      if (!read_number(entry, kParameterNames[i], &x[i], where))
        error(where + "missing '" + kParameterNames[i] + "' (needed by the " + kind_name(model.kind) + " model)");
    }
    for (int i : asymmetry_parameters(model.kind)) read_number(entry, kParameterNames[i], &x[i], where);
    for (const auto& item : entry.items()) {
      bool is_parameter = item.key() == "covariance";
      for (const char* name : kParameterNames) is_parameter = is_parameter || item.key() == name;
      if (!is_parameter && warnings) warnings->push_back("friction: " + where + "unknown key '" + item.key() + "'");
    }
    model.joints.push_back(Parameters<double>::from_array(x));
    model.covariance.push_back(std::nullopt);
    if (const auto c = entry.find("covariance"); c != entry.end() && !c->is_null())
      model.covariance.back() = covariance_from_json(*c, where + "covariance: ");
  }
  bool any_covariance = false;
  for (const auto& c : model.covariance) any_covariance = any_covariance || c.has_value();
  if (!any_covariance) model.covariance.clear();
  std::string why;
  if (!model.IsValid(&why)) error(why);
  return model;
}

nlohmann::json covariance_to_json(const SteadyCovariance& covariance) {
  nlohmann::json names = nlohmann::json::array(), rows = nlohmann::json::array();
  const std::size_t n = covariance.parameters.size();
  for (std::size_t a = 0; a < n; ++a) {
    names.push_back(kParameterNames[covariance.parameters[a]]);
    nlohmann::json row = nlohmann::json::array();
    for (std::size_t b = 0; b < n; ++b) row.push_back(covariance.matrix[a * n + b]);
    rows.push_back(std::move(row));
  }
  return {{"parameters", std::move(names)}, {"matrix", std::move(rows)}};
}

nlohmann::json to_json(const FrictionModel& model) {
  nlohmann::json section = nlohmann::json::object();
  section["model"] = kind_name(model.kind);
  if (has_state(model.kind)) section["update"] = update_name(model.options.update);
  if (model.options.velocity_deadband != 0) section["velocity_deadband"] = model.options.velocity_deadband;
  if (model.options.velocity_cutoff_hz != 0) section["velocity_cutoff_hz"] = model.options.velocity_cutoff_hz;
  nlohmann::json joints = nlohmann::json::array();
  const std::vector<int> used = used_parameters(model.kind, false);
  for (const auto& p : model.joints) {
    double x[Parameters<double>::kSize];
    p.to_array(x);
    nlohmann::json entry = nlohmann::json::object();
    for (int i : used) entry[kParameterNames[i]] = x[i];
    for (int i : asymmetry_parameters(model.kind))
      if (x[i] != 0) entry[kParameterNames[i]] = x[i];
    const std::size_t j = joints.size();
    if (j < model.covariance.size() && model.covariance[j]) entry["covariance"] = covariance_to_json(*model.covariance[j]);
    joints.push_back(std::move(entry));
  }
  section["joints"] = std::move(joints);
  return section;
}

std::vector<JointFriction<double>> make_joint_frictions(const FrictionModel& model) {
  std::vector<JointFriction<double>> out;
  out.reserve(model.joints.size());
  for (const auto& p : model.joints) out.emplace_back(model.kind, p, model.options);
  return out;
}

}  // namespace momentum::friction
