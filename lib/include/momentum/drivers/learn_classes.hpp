#pragma once
// mo-calibrate --classes, as a library driver: the contact/collision rule (contact/classify.hpp)
// learnt from mo-detect's events of a labelled campaign against its truth, stored in the profile
// beside the thresholds of the signal it classifies, which stay as they are; and from the same
// events the temperature of the link probabilities (eval::learn_link_temperature).

#include <string>

#include "momentum/contact/classify.hpp"
#include "momentum/eval/classes.hpp"

namespace momentum::drivers {

struct LearnClassesOptions {
  std::string events_path;   // mo-detect's events of the campaign, with the contact columns
  std::string truth_path;    // the campaign's truth (mo-sim --truth)
  std::string profile_path;  // the profile to update, with thresholds for `signal`
  // Where the updated profile goes ("": the profile itself, "-": standard output, else a new
  // file); dry_run: learn and report only.
  std::string output;
  bool dry_run = false;
  std::string signal = "mu";  // the thresholds the rule goes beside (thresholds/<signal>)
  bool strict = false;        // a bad event row is an error, not skipped (read_detections)
  // False, with the reason in `why`, without events, truth or profile.
  bool IsValid(std::string* why) const;
};

struct LearnClassesResult {
  contact::ClassRule rule;
  eval::LinkTemperature temperature;  // events 0: no contact to learn it from
};

// Learns the rule from the detected contacts (class_examples, default scoring window) and,
// unless dry_run, stores it as thresholds/<signal>/classify with a provenance entry, and the
// link temperature as thresholds/<signal>/identify. Throws momentum::Error when no event with
// a pulse width matches a contact, without an example of each class, when the profile has no
// thresholds for the signal or has them for another joint count than the events, and what
// reading the files and writing the profile throw; for invalid options.
LearnClassesResult learn_classes(const LearnClassesOptions& options);

// What was learnt, as mo-calibrate reports it: a line on the rule ("classes: ..."), and one on
// the link temperature when there was a contact to learn it from ("links: ...").
std::string format_learn_classes(const LearnClassesResult& result);

}  // namespace momentum::drivers
