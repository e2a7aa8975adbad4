#pragma once
// mo-calibrate --classes, as a library function: the contact/collision rule (contact/classify.hpp)
// learnt from mo-detect's events of a labelled campaign against its truth, stored in the profile
// beside the thresholds of the signal it classifies, which stay as they are; and from the same
// events the temperature of the link probabilities (learn_link_temperature).

#include <string>

#include "momentum/contact/classify.hpp"
#include "momentum/eval/score.hpp"

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

// The link temperature (contact::LocatorOptions::link_temperature) learnt from a labelled
// campaign: of the detected contacts whose event states its candidate links' probabilities
// (Detection::link_probabilities) and names the true link among them, the temperature T that
// maximises the summed log probability of the true links once the stated ones, written at
// temperature `written`, are tempered to T (p_i(T) proportional to p_i^(written / T)). The
// log-likelihood is concave in 1 / T, and T is kept within [1, 1e5]: the white-noise likelihood
// (T = 1) is the most its residuals can tell, never less. T = `written` and events 0 without
// such a contact.
struct LinkTemperature {
  double temperature = 1;
  int events = 0;                 // contacts it was learnt from
  double log_loss_written = NAN;  // mean -ln p(true link) as written
  double log_loss = NAN;          // ... at the learnt temperature
};
LinkTemperature learn_link_temperature(const detect::TruthTable& truth, const std::vector<Detection>& detections,
                                       double written = 1);

}  // namespace momentum::eval
