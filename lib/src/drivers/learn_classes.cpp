#include "momentum/drivers/learn_classes.hpp"

#include <cstdio>

#include "momentum/contact/event_contact.hpp"
#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/drivers/calibrate_streams.hpp"
#include "momentum/model/profile.hpp"

namespace momentum::drivers {

bool LearnClassesOptions::IsValid(std::string* why) const {
  if (events_path.empty() || truth_path.empty()) return invalid(why, "the events and their truth are needed");
  if (profile_path.empty()) return invalid(why, "--classes needs a profile (-p) to update");
  return true;
}

LearnClassesResult learn_classes(const LearnClassesOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw Error(why);
  const std::string& events = options.events_path;
  const model::Profile profile = model::load_profile(options.profile_path);
  const auto detections = eval::read_detections(events, options.strict);
  const auto examples = eval::class_examples(eval::read_truth(options.truth_path), detections, {});
  if (examples.empty())
    throw Error(events + ": no event with a pulse width matches a contact of " + options.truth_path +
                " (run mo-detect with a profile that has a URDF, on a stream with q)");
  const std::size_t joints = examples.front().peaks.size();
  const contact::ClassRule learnt = contact::learn_rule(examples, joints);
  // The link temperature, relative to the one the events were written with: the profile's
  // own (the events are taken to come from mo-detect with this profile).
  const std::string signal_name = options.signal;
  const double written = contact::link_temperature_from_profile(profile.document, signal_name, options.profile_path)
                             .value_or(1.0);
  const eval::LinkTemperature temperature =
      eval::learn_link_temperature(eval::read_truth(options.truth_path), detections, written);
  const LearnClassesResult result{learnt, temperature};
  if (options.dry_run) return result;
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
  model::write_updated_profile(document, profile, options.output);
  return result;
}

std::string format_learn_classes(const LearnClassesResult& result) {
  const contact::ClassRule& rule = result.rule;
  std::string cut = "a pulse narrower than " + core::fixed(rule.width, 3) + " s";
  if (rule.rise_exponent > 0)
    cut += " x (" + core::fixed(rule.rise_reference, 3) + " s / its rise)^" + core::fixed(rule.rise_exponent, 2);
  char line[512];
  std::snprintf(line, sizeof line, "classes: %d contacts, %d collisions; %s is a collision; %.1f%% right on these examples\n",
                rule.contacts, rule.collisions, cut.c_str(), 100 * rule.accuracy);
  std::string text = line;
  const eval::LinkTemperature& t = result.temperature;
  if (t.events > 0) {
    std::snprintf(line, sizeof line,
                  "links: temperature %.3g from %d contacts with the true link among the candidates (log-loss %.3f "
                  "as written, %.3f now)\n",
                  t.temperature, t.events, t.log_loss_written, t.log_loss);
    text += line;
  }
  return text;
}

}  // namespace momentum::drivers
