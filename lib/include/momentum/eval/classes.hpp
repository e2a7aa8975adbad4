#pragma once
// mo-calibrate --classes, as a library function: the contact/collision rule (contact/classify.hpp)
// learnt from mo-detect's events of a labelled campaign against its truth, stored in the profile
// beside the thresholds of the signal it classifies, which stay as they are.

#include <string>

#include "momentum/contact/classify.hpp"

namespace momentum::eval {

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

// Learns the rule from the detected contacts (class_examples, default scoring window), prints
// one line about it (to standard error when the profile goes to standard output, else to
// standard output) and, unless dry_run, stores it as thresholds/<signal>/classify with a
// provenance entry. Returns the rule. Throws momentum::Error when no event with a pulse width
// matches a contact, without an example of each class, when the profile has no thresholds for
// the signal or has them for another joint count than the events, and what reading the files
// and writing the profile throw; for invalid options.
contact::ClassRule learn_classes(const LearnClassesOptions& options);

}  // namespace momentum::eval
