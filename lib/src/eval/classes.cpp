#include "momentum/eval/classes.hpp"

#include <cstdio>

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
  model::append_provenance(document, "mo-calibrate",
                           {{"classes", events}, {"truth", options.truth_path}, {"examples", examples.size()}});
  detect::write_updated_profile(document, profile, options.output);
  return learnt;
}

}  // namespace momentum::eval
