#include "momentum/eval/classes.hpp"

#include <cmath>
#include <cstdio>

#include "momentum/contact/event_contact.hpp"
#include "momentum/detect/calibrate_streams.hpp"
#include "momentum/eval/score.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"

namespace momentum::eval {

bool LearnClassesOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  if (events_path.empty() || truth_path.empty()) return fail("the events and their truth are needed");
  if (profile_path.empty()) return fail("--classes needs a profile (-p) to update");
  return true;
}

LinkTemperature learn_link_temperature(const detect::TruthTable& truth, const std::vector<Detection>& detections,
                                       double written) {
  LinkTemperature out;
  out.temperature = written;
  // Per contact: ln p of each candidate as written, and the true one's index.
  std::vector<std::pair<std::vector<double>, std::size_t>> cases;
  for (const auto& o : score(truth, detections, {}).outcomes) {
    if (o.detection < 0) continue;
    const Detection& d = detections[static_cast<std::size_t>(o.detection)];
    std::vector<double> logs;
    std::size_t truth_index = d.link_probabilities.size();
    for (std::size_t i = 0; i < d.link_probabilities.size(); ++i) {
      logs.push_back(std::log(std::max(d.link_probabilities[i].second, 1e-300)));
      if (d.link_probabilities[i].first == o.contact.link) truth_index = i;
    }
    if (truth_index < logs.size()) cases.emplace_back(std::move(logs), truth_index);
  }
  out.events = static_cast<int>(cases.size());
  if (cases.empty()) return out;
  // Mean -ln p(true) at inverse temperature beta relative to the written one.
  auto loss = [&](double beta) {
    double sum = 0;
    for (const auto& [logs, k] : cases) {
      double top = -INFINITY;
      for (double l : logs) top = std::max(top, beta * l);
      double z = 0;
      for (double l : logs) z += std::exp(beta * l - top);
      sum -= beta * logs[k] - top - std::log(z);
    }
    return sum / static_cast<double>(cases.size());
  };
  // Golden section on ln beta (the loss is convex in beta, so unimodal on its logarithm).
  double lo = std::log(written / 1e5), hi = std::log(written / 1.0);
  if (!(lo < hi)) lo = hi;
  const double golden = (std::sqrt(5.0) - 1) / 2;
  for (int i = 0; i < 200 && hi - lo > 1e-9; ++i) {
    const double a = hi - golden * (hi - lo), b = lo + golden * (hi - lo);
    if (loss(std::exp(a)) < loss(std::exp(b))) hi = b;
    else lo = a;
  }
  const double beta = std::exp(0.5 * (lo + hi));
  out.temperature = written / beta;
  out.log_loss_written = loss(1.0);
  out.log_loss = loss(beta);
  return out;
}

contact::ClassRule learn_classes(const LearnClassesOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw Error(why);
  const std::string& events = options.events_path;
  const model::Profile profile = model::load_profile(options.profile_path);
  const auto detections = read_detections(events, options.strict);
  const auto examples = class_examples(read_truth(options.truth_path), detections, {});
  if (examples.empty())
    throw Error(events + ": no event with a pulse width matches a contact of " + options.truth_path +
                " (run mo-detect with a profile that has a URDF, on a stream with q)");
  const std::size_t joints = examples.front().peaks.size();
  const contact::ClassRule learnt = contact::learn_rule(examples, joints);
  std::string cut = "a pulse narrower than " + core::fixed(learnt.width, 3) + " s";
  if (learnt.rise_exponent > 0)
    cut += " x (" + core::fixed(learnt.rise_reference, 3) + " s / its rise)^" + core::fixed(learnt.rise_exponent, 2);
  std::fprintf(options.output == "-" ? stderr : stdout,
               "classes: %d contacts, %d collisions; %s is a collision; %.1f%% right on these examples\n",
               learnt.contacts, learnt.collisions, cut.c_str(), 100 * learnt.accuracy);
  // The link temperature, relative to the one the events were written with: the profile's
  // own (the events are taken to come from mo-detect with this profile).
  const std::string signal_name = options.signal;
  const double written = contact::link_temperature_from_profile(profile.document, signal_name, options.profile_path)
                             .value_or(1.0);
  const LinkTemperature temperature = learn_link_temperature(read_truth(options.truth_path), detections, written);
  if (temperature.events > 0)
    std::fprintf(options.output == "-" ? stderr : stdout,
                 "links: temperature %.3g from %d contacts with the true link among the candidates (log-loss %.3f "
                 "as written, %.3f now)\n",
                 temperature.temperature, temperature.events, temperature.log_loss_written, temperature.log_loss);
  if (options.dry_run) return learnt;
  nlohmann::json document = profile.document;
  const std::string& signal = options.signal;
  if (!document.contains("thresholds") || !document["thresholds"].contains(signal))
    throw Error(options.profile_path + ": no thresholds for " + signal + " to classify with (calibrate them first)");
  const auto& thresholds = document["thresholds"][signal]["joints"];
  if (thresholds.is_array() && thresholds.size() != joints)
    throw Error(events + ": events of " + std::to_string(joints) + " joints, the profile's " + signal +
                " thresholds are for " + std::to_string(thresholds.size()));
  document["thresholds"][signal]["classify"] = contact::rule_to_json(learnt);
  if (temperature.events > 0)
    document["thresholds"][signal]["identify"] = {{"link_temperature", temperature.temperature},
                                                  {"events", temperature.events}};
  model::append_provenance(document, "mo-calibrate",
                           {{"classes", events}, {"truth", options.truth_path}, {"examples", examples.size()}});
  detect::write_updated_profile(document, profile, options.output);
  return learnt;
}

}  // namespace momentum::eval
