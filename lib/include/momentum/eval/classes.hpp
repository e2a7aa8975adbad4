#pragma once
// What a labelled campaign teaches identification beyond the class rule (contact/classify.hpp):
// the temperature of the link probabilities (learn_link_temperature). mo-calibrate --classes
// (drivers/learn_classes.hpp) stores both in the profile.

#include <string>

#include "momentum/eval/score.hpp"

namespace momentum::eval {

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
LinkTemperature learn_link_temperature(const eval::Truth& truth, const std::vector<Detection>& detections,
                                       double written = 1);

}  // namespace momentum::eval
