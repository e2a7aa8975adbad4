#include "momentum/inertia/report.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/inertia/regressor.hpp"
#include "momentum/model/json_number.hpp"
#include "momentum/stream/non_finite.hpp"
#include "momentum/stream/reader.hpp"

namespace momentum::inertia {

namespace {

nlohmann::json vector_json(const Eigen::VectorXd& v) {
  nlohmann::json out = nlohmann::json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) out.push_back(model::json_number(v[i]));
  return out;
}

const char* excitation(const ParameterEstimate& p) {
  if (!p.fitted) return "not fitted";
  if (p.identifiability > 0.99) return "identified";
  if (p.identifiability < 0.01) return "not excited";
  return "combination";
}

// "1 m3 + 0.43 mz2 - 0.1 izz1": the terms of a combination, largest first (at most 6).
std::string combination_text(const BaseParameter& base, const std::vector<std::string>& bodies) {
  std::vector<std::pair<double, int>> terms;
  for (Eigen::Index c = 0; c < base.direction.size(); ++c) {
    if (std::abs(base.direction[c]) > 1e-3) terms.emplace_back(base.direction[c], static_cast<int>(c));
  }
  std::sort(terms.begin(), terms.end(), [](const auto& a, const auto& b) {
    return std::abs(a.first) > std::abs(b.first);
  });
  std::string text;
  for (std::size_t t = 0; t < terms.size() && t < 6; ++t) {
    const double w = terms[t].first;
    const int c = terms[t].second;
    const std::string name = std::string(parameter_names()[static_cast<std::size_t>(c % kBodyParameters)]) + "(" +
                             bodies[static_cast<std::size_t>(c / kBodyParameters)] + ")";
    if (t == 0) {
      text += core::significant(w, 3) + " " + name;
    } else {
      text += (w < 0 ? " - " : " + ") + core::significant(std::abs(w), 3) + " " + name;
    }
  }
  if (terms.size() > 6) text += " + ...";
  return text;
}

}  // namespace

std::uint64_t add_log(stream::Reader& in, const model::Model& model, Identifier& identifier) {
  const int n = model.nq;
  if (in.find("q" + std::to_string(n + 1))) {
    throw Error(in.name() + ": column q" + std::to_string(n + 1) + ": the log has more joints than the robot (" +
                std::to_string(n) + ")");
  }
  const std::size_t t_col = in.require("t");
  std::vector<std::size_t> q_col, dq_col, tau_col;
  std::vector<double> tau_scale;
  for (int j = 1; j <= n; ++j) {
    const std::string index = std::to_string(j);
    q_col.push_back(in.require("q" + index));
    dq_col.push_back(in.require("dq" + index));
    if (const auto tau = in.find("tau_m" + index)) {
      tau_col.push_back(*tau);
      tau_scale.push_back(1.0);
    } else if (const auto current = in.find("i" + index)) {
      tau_col.push_back(*current);
      tau_scale.push_back(model.k_i[j - 1]);
    } else {
      throw Error(in.name() + ": missing column 'tau_m" + index + "' (or motor current 'i" + index + "')");
    }
  }
  identifier.restart();
  Eigen::VectorXd q(n), dq(n), tau(n);
  double t_last = -std::numeric_limits<double>::infinity();
  std::uint64_t rows = 0;
  stream::NonFiniteRows non_finite;
  while (const double* row = in.next()) {
    const double t = row[t_col];
    if (in.time_mark() == stream::TimeMark::clock_step) {
      // The stream's time policy kept this row as the start of a new time line.
      in.warn_clock_step("the rows from here are identified as a log of their own");
      identifier.restart();
      t_last = -std::numeric_limits<double>::infinity();
    }
    if (!in.follows_in_time(t, t_last)) continue;
    t_last = t;
    for (int j = 0; j < n; ++j) {
      q[j] = row[q_col[static_cast<std::size_t>(j)]];
      dq[j] = row[dq_col[static_cast<std::size_t>(j)]];
      tau[j] = tau_scale[static_cast<std::size_t>(j)] * row[tau_col[static_cast<std::size_t>(j)]];
    }
    if (!std::isfinite(t) || !q.allFinite() || !dq.allFinite() || !tau.allFinite()) non_finite.note(in, t);
    identifier.add(t, q, dq, tau);
    ++rows;
  }
  if (non_finite.count() > 0) warn(in.name() + ": " + non_finite.summary());
  return rows;
}

std::uint64_t count_log(stream::Reader& in) {
  const std::size_t t_col = in.require("t");
  double t_last = -std::numeric_limits<double>::infinity();
  std::uint64_t rows = 0;
  while (const double* row = in.next()) {
    const double t = row[t_col];
    if (in.time_mark() == stream::TimeMark::clock_step) t_last = -std::numeric_limits<double>::infinity();
    if (!in.follows_in_time(t, t_last)) continue;
    t_last = t;
    ++rows;
  }
  return rows;
}

bool worse_than_current(const IdentifySummary& s) {
  if (s.rms_current.size() != s.rms_after.size() || s.rms_after.size() == 0) return false;
  return s.rms_after.squaredNorm() > s.rms_current.squaredNorm() * (1 + 1e-9);
}

bool FitLimits::IsValid(std::string* why) const {
  if (max_projection_shift > 0 && max_negative_friction > 0) return true;
  if (why) *why = "fit limits must be > 0";
  return false;
}

std::vector<std::string> fit_failures(const IdentifySummary& s, const FitLimits& limits) {
  std::vector<std::string> out;
  char buffer[256];
  if (s.projection_shift > limits.max_projection_shift) {
    std::snprintf(buffer, sizeof buffer,
                  "physical consistency moved identified combinations by %.3g standard errors (limit %g): "
                  "the data ask for bodies no physics allows",
                  s.projection_shift, limits.max_projection_shift);
    out.push_back(buffer);
  }
  if (s.bodies_reset > 0)
    out.push_back(std::to_string(s.bodies_reset) + " bodies identified with a mass that is not positive");
  for (int j = 0; j < s.coulomb.size(); ++j) {
    const std::string name = "friction joint " + std::to_string(j + 1);
    auto negative = [&](double value, double se, const char* what, const char* unit) {
      if (!(value < -limits.max_negative_friction * se)) return;
      std::snprintf(buffer, sizeof buffer, "%s: %s %.4g %s is negative (%.3g standard errors)", name.c_str(),
                    what, value, unit, se > 0 ? -value / se : INFINITY);
      out.push_back(buffer);
    };
    if (s.fit_friction) {
      negative(s.coulomb[j], s.coulomb_se[j], "Coulomb", "Nm");
      negative(s.viscous[j], s.viscous_se[j], "viscous", "Nm s/rad");
    }
  }
  if (s.rms_after.size() > 0 && s.rms_after.size() == s.rms_before.size() &&
      s.rms_after.squaredNorm() > s.rms_before.squaredNorm() * (1 + 1e-9)) {
    std::snprintf(buffer, sizeof buffer, "the corrected model explains the %s data worse than the nominal one",
                  s.held_out ? "held-out" : "fitting");
    out.push_back(buffer);
  }
  return out;
}

std::string report_text(const Report& report) {
  const IdentifySummary& s = report.summary;
  std::string out;
  auto line = [&](const std::string& text) { out += "mo-dynfit: " + text + "\n"; };
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, "%d joints, %d inertial parameters fitted%s; friction: %s; filter K = %g 1/s",
                s.nq, s.columns, s.gravity_only ? " (gravity only: m, m c)" : "",
                s.fit_friction ? "Coulomb + viscous per joint, fitted jointly" : "not fitted (inputs compensated)",
                report.options.filter_gain);
  line(buffer);
  std::snprintf(buffer, sizeof buffer,
                "data: %.1f s fitted (%llu samples), %.1f s held out (%llu samples), %llu skipped, %d filter start%s, %d covariance blocks",
                s.seconds_fit, static_cast<unsigned long long>(s.samples_fit), s.seconds_held_out,
                static_cast<unsigned long long>(s.samples_held_out), static_cast<unsigned long long>(s.samples_skipped),
                s.restarts, s.restarts == 1 ? "" : "s", s.blocks);
  line(buffer);
  if (s.thinned) {
    std::snprintf(buffer, sizeof buffer,
                  "samples: %llu of %llu taken (budget %llu): %d stretches of %g s spread evenly over the logs, "
                  "the filters restarting at each",
                  static_cast<unsigned long long>(s.samples_taken), static_cast<unsigned long long>(s.samples_read),
                  static_cast<unsigned long long>(report.options.max_samples), s.stretches_kept, s.stretch_seconds);
  } else if (!report.budget_not_applied.empty()) {
    std::snprintf(buffer, sizeof buffer, "samples: all %llu taken; budget %llu not applied: %s",
                  static_cast<unsigned long long>(s.samples_read),
                  static_cast<unsigned long long>(report.options.max_samples), report.budget_not_applied.c_str());
  } else {
    std::snprintf(buffer, sizeof buffer, "samples: all %llu taken (budget %s)",
                  static_cast<unsigned long long>(s.samples_read),
                  report.options.max_samples > 0 ? std::to_string(report.options.max_samples).c_str() : "none");
  }
  line(buffer);
  std::snprintf(buffer, sizeof buffer,
                "regressor: %d identifiable combinations of %d (rank tolerance %g), condition number %.4g (column-scaled), smallest singular value %.3g",
                s.rank, s.columns, report.options.rank_tolerance, s.condition_number, s.smallest_singular_value);
  line(buffer);
  line(std::string("residual RMS per joint, Nm, on ") + (s.held_out ? "held-out data" : "the fitted data (nothing held out)") +
       ": before (nominal URDF) -> after" + (report.has_current ? " (current profile)" : ""));
  for (int j = 0; j < s.nq; ++j) {
    std::snprintf(buffer, sizeof buffer, "  joint %d %-12s %9.4f -> %9.4f", j + 1,
                  report.joint_names[static_cast<std::size_t>(j)].c_str(), s.rms_before[j], s.rms_after[j]);
    std::string text = buffer;
    if (report.has_current && s.rms_current.size() == s.nq) text += "   (" + core::fixed(s.rms_current[j], 4) + ")";
    if (!s.projections.empty()) text += "   [" + core::fixed(s.rms_unprojected[j], 4) + " before the projection]";
    line(text);
  }
  if (s.velocity_noise_draws > 0) {
    std::string levels;
    for (int j = 0; j < s.nq; ++j) levels += " " + core::significant(s.velocity_noise[j], 2);
    line("velocity noise (rad/s per joint):" + levels + "; its bias is estimated from " +
         std::to_string(s.velocity_noise_draws) + " fit" + (s.velocity_noise_draws == 1 ? "" : "s") +
         " with it doubled");
  } else {
    line("velocity noise: not estimated (none measured, or --velocity-noise-draws 0)");
  }
  if (s.friction_probe_min_speed > 0)
    line("friction-model term: the shift when --min-speed rises to " + core::significant(s.friction_probe_min_speed, 6) +
         " rad/s");
  line("base parameters (identified combinations), nominal -> value +- uncertainty (standard error, velocity-noise "
       "shift, friction-model shift):");
  for (std::size_t r = 0; r < s.base.size(); ++r) {
    const BaseParameter& b = s.base[r];
    std::snprintf(buffer, sizeof buffer, "  b%-2zu %11.5g -> %11.5g +- %-9.3g (%.2g, %.2g, %.2g) sv %.2g  ", r + 1,
                  b.nominal, b.value, b.uncertainty, b.standard_error, b.velocity_noise_shift, b.friction_shift,
                  b.singular_value);
    line(buffer + combination_text(b, report.body_names));
  }
  line("parameters (body frame, about the body origin), nominal -> value +- uncertainty:");
  for (const ParameterEstimate& p : s.parameters) {
    std::snprintf(buffer, sizeof buffer, "  %-12s %-4s %11.5g -> %11.5g +- %-9.3g %s",
                  report.body_names[static_cast<std::size_t>(p.body)].c_str(),
                  parameter_names()[static_cast<std::size_t>(p.index)], p.nominal, p.value, p.uncertainty,
                  excitation(p));
    line(buffer);
  }
  if (s.fit_friction) {
    for (int j = 0; j < s.nq; ++j) {
      const bool combined = s.coulomb_uncertainty.size() == s.nq && s.viscous_uncertainty.size() == s.nq;
      std::snprintf(buffer, sizeof buffer, "friction joint %d: Coulomb %.4g +- %.2g Nm, viscous %.4g +- %.2g Nm s/rad", j + 1,
                    s.coulomb[j], combined ? s.coulomb_uncertainty[j] : s.coulomb_se[j], s.viscous[j],
                    combined ? s.viscous_uncertainty[j] : s.viscous_se[j]);
      line(buffer);
    }
  }
  for (const auto& note : s.projections) line("physical consistency: " + note);
  std::snprintf(buffer, sizeof buffer, "%.2f s", report.seconds);
  line("fit time " + std::string(buffer) + "; " + report.outcome);
  return out;
}

nlohmann::json fit_details(const Report& report) {
  const IdentifySummary& s = report.summary;
  return {{"gravity_only", s.gravity_only},
          {"rank", s.rank},
          {"columns", s.columns},
          {"condition_number", model::json_number(s.condition_number)},
          {"held_out", s.held_out},
          {"rms_before", vector_json(s.rms_before)},
          {"rms_after", vector_json(s.rms_after)},
          {"seconds_fitted", s.seconds_fit},
          {"seconds_held_out", s.seconds_held_out},
          {"logs", report.inputs}};
}

nlohmann::json report_json(const Report& report) {
  const IdentifySummary& s = report.summary;
  nlohmann::json j;
  j["inputs"] = report.inputs;
  j["profile"] = report.profile;
  j["options"] = {{"filter_gain", report.options.filter_gain},
                  {"gravity_only", report.options.gravity_only},
                  {"fit_friction", report.options.fit_friction},
                  {"coulomb_speed", report.options.coulomb_speed},
                  {"rank_tolerance", report.options.rank_tolerance},
                  {"holdout_segment", report.options.holdout_segment},
                  {"holdout_every", report.options.holdout_every}};
  j["data"] = {{"samples_fitted", s.samples_fit},   {"samples_held_out", s.samples_held_out},
               {"samples_skipped", s.samples_skipped}, {"seconds_fitted", s.seconds_fit},
               {"seconds_held_out", s.seconds_held_out}, {"filter_starts", s.restarts},
               {"covariance_blocks", s.blocks},
               {"samples_read", s.samples_read},   {"samples_taken", s.samples_taken},
               {"max_samples", report.options.max_samples}, {"thinned", s.thinned},
               {"stretches_kept", s.stretches_kept}, {"stretch_seconds", s.stretch_seconds}};
  if (!report.budget_not_applied.empty()) j["data"]["budget_not_applied"] = report.budget_not_applied;
  j["velocity_noise"] = {{"per_joint", vector_json(s.velocity_noise)}, {"draws", s.velocity_noise_draws}};
  j["friction_probe_min_speed"] = s.friction_probe_min_speed;
  j["rank"] = s.rank;
  j["columns"] = s.columns;
  j["condition_number"] = model::json_number(s.condition_number);
  j["smallest_singular_value"] = model::json_number(s.smallest_singular_value);
  j["held_out"] = s.held_out;
  j["rms_before"] = vector_json(s.rms_before);
  j["rms_after"] = vector_json(s.rms_after);
  j["rms_unprojected"] = vector_json(s.rms_unprojected);
  if (report.has_current) j["rms_current"] = vector_json(s.rms_current);
  j["base"] = nlohmann::json::array();
  for (const BaseParameter& b : s.base) {
    nlohmann::json direction = nlohmann::json::object();
    for (Eigen::Index c = 0; c < b.direction.size(); ++c) {
      if (b.direction[c] != 0.0) {
        direction[report.body_names[static_cast<std::size_t>(c / kBodyParameters)] + "." +
                  parameter_names()[static_cast<std::size_t>(c % kBodyParameters)]] = b.direction[c];
      }
    }
    j["base"].push_back({{"direction", direction},
                         {"nominal", model::json_number(b.nominal)},
                         {"value", model::json_number(b.value)},
                         {"standard_error", model::json_number(b.standard_error)},
                         {"velocity_noise_shift", model::json_number(b.velocity_noise_shift)},
                         {"friction_shift", model::json_number(b.friction_shift)},
                         {"uncertainty", model::json_number(b.uncertainty)},
                         {"singular_value", model::json_number(b.singular_value)},
                         {"text", combination_text(b, report.body_names)}});
  }
  j["parameters"] = nlohmann::json::array();
  for (const ParameterEstimate& p : s.parameters) {
    j["parameters"].push_back({{"body", report.body_names[static_cast<std::size_t>(p.body)]},
                               {"name", parameter_names()[static_cast<std::size_t>(p.index)]},
                               {"nominal", model::json_number(p.nominal)},
                               {"value", model::json_number(p.value)},
                               {"standard_error", model::json_number(p.standard_error)},
                               {"velocity_noise_shift", model::json_number(p.velocity_noise_shift)},
                               {"friction_shift", model::json_number(p.friction_shift)},
                               {"uncertainty", model::json_number(p.uncertainty)},
                               {"identifiability", model::json_number(p.identifiability)},
                               {"excitation", excitation(p)}});
  }
  if (s.fit_friction) {
    j["friction"] = {{"coulomb", vector_json(s.coulomb)}, {"coulomb_se", vector_json(s.coulomb_se)},
                     {"coulomb_uncertainty", vector_json(s.coulomb_uncertainty)},
                     {"viscous", vector_json(s.viscous)}, {"viscous_se", vector_json(s.viscous_se)},
                     {"viscous_uncertainty", vector_json(s.viscous_uncertainty)}};
  }
  j["delta"] = vector_json(s.delta);
  j["projections"] = s.projections;
  j["seconds"] = report.seconds;
  j["outcome"] = report.outcome;
  return j;
}

}  // namespace momentum::inertia
