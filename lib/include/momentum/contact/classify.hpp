#pragma once
// Contact or collision: what the residuals show of how a contact began.
//
// A collision is an impact: a short, broadband pulse of force (a stiff obstacle met at speed,
// gone as the arm stops or bounces off). A contact is a push or a guiding hand: the force rises
// and is held for a good part of a second. The features are the pulse's width, the time the
// contact's residual (weighted over the joints) stays above half its peak around it (the
// inverse of its bandwidth, read in the time domain so that it is known as soon as the pulse
// is over), and its
// rise time, from the estimated onset to 90% of the peak (an arm pinned against an obstacle
// holds the force as long as a push does, but it rose as fast as an impact). And
// libfranka-style levels per joint: a joint over its collision level makes the event a
// collision whatever its shape (between the detection threshold and that level: a contact).
//
// The rule: a collision when width * (rise / rise_reference)^rise_exponent is under `width`
// (rise_exponent 0: the width alone). Its parameters come from calibration (mo-calibrate
// --classes): how much the rise counts, from a logistic regression of the class on the
// logarithms of width and rise over a labelled campaign; the cut on that combination that
// separates its collisions from its contacts best; and per joint the largest residual that a
// contact of that campaign reached (when these levels classify examples they were not learnt
// from better than the cut alone, each left out in turn). Profile entry, beside the
// thresholds of the signal it was calibrated on:
//
//   "thresholds": {"mu": {..., "classify": {"width": 0.15, "rise_exponent": 0.6,
//                                           "rise_reference": 0.09, "collision": [40, 35, 12],
//                                           "contacts": 12, "collisions": 18, "accuracy": 0.93}}}

#include <cmath>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "momentum/contact/locate.hpp"

namespace momentum::contact {

enum class EventClass { unknown, contact, collision };
// "", "contact", "collision".
std::string_view class_name(EventClass c);
// "contact", "collision"; nullopt otherwise (an empty field is unknown).
std::optional<EventClass> parse_class(std::string_view text);

// The shape of a contact's record (samples from the estimated onset, residual minus its level,
// weighted by `weight`, n), from the weighted norm of each sample: the lobe around its peak (what
// follows it is the arm's reaction), its crossings of 90% and half the peak interpolated
// linearly between the samples around them (so that the same pulse has the same width and rise
// at every sample rate). NaN without samples.
struct PulseShape {
  double rise = NAN;    // s, from t_onset to where the strength first reaches 90% of the peak
  double width = NAN;   // s, the lobe around the peak: from where the strength rose through half
                        // the peak before it to where it first fell below after it
  double t_first_half = NAN;  // s, where that lobe rose through half the peak
  bool over = false;    // the lobe has ended (a sample after the peak is below half of it)
};
PulseShape pulse_shape(std::span<const ResidualSample> samples, double t_onset, const Eigen::VectorXd& weight);

struct ClassRule {
  double width = 0;                     // s, > 0: a shorter pulse (at the reference rise) is a collision
  double rise_exponent = 0;             // >= 0: how much a slow rise widens the pulse; 0: width alone
  double rise_reference = 0;            // s, > 0 when rise_exponent > 0: the rise at which width counts as is
  std::vector<double> collision_level;  // Nm per joint, > 0; empty: no level
  // The class's probability (collision_probability): the logistic slope on ln(rise-weighted
  // width / width), >= 0 (0: the rule states no probability, as a profile from before it), and
  // the share of collisions among the learning examples over a collision level (Laplace's rule
  // of succession), in (0, 1].
  double slope = 0;
  double level_probability = 1;
  // What it was learnt from, for reports.
  int contacts = 0, collisions = 0;
  double accuracy = 0;  // on its own examples, 0..1
  bool IsValid(std::string* why) const;
};

// Rises under this count as this (s): a pulse at 90% of its peak on its first sample.
inline constexpr double kShortestRise = 1e-3;

// The pulse width as the rule weighs it (s): width * (max(rise, kShortestRise) /
// rise_reference)^rise_exponent. NaN when width is, or when the rule weighs a rise that is NaN.
double rise_weighted_width(const ClassRule& rule, double width, double rise);

// The class of a finished event: its pulse width and rise (s) and per-joint peaks (Nm).
EventClass classify(const ClassRule& rule, double width, double rise, std::span<const double> peaks);

// The probability that an event is a collision: level_probability when a joint is over its
// collision level, else 1 / (1 + (rise-weighted width / width)^slope) (0.5 at the cut). NaN when
// the rule has no slope or the width is NaN.
double collision_probability(const ClassRule& rule, double width, double rise, std::span<const double> peaks);

// One labelled example: a detected event's pulse width, peaks and rise, and whether the truth
// calls it a collision.
struct ClassExample {
  double width = 0;
  std::vector<double> peaks;
  bool collision = false;
  double rise = NAN;  // s; NaN: unknown (then no example's rise is weighed)
};

// Learns the rule from examples. How much the rise counts: the ratio of the rise's to the
// width's coefficient in a logistic regression of the class on log width and log rise
// (standardised, with a unit normal prior on the two slopes, so that classes that one feature
// separates keep a finite fit); 0 when the rise points the wrong way (a slower rise more
// often a collision) or an example has no rise. The cut: the rise-weighted width that
// classifies the examples best (the geometric middle between the two neighbouring values
// where the accuracy is highest; ties: the widest gap). Per joint the largest peak of a
// contact as its collision level, kept only when, each example left out in turn and both rules
// learnt again without it, the levels classify more of the examples left out right than the
// cut alone (in the examples themselves a level can only help). The slope: the maximum a
// posteriori of a logistic regression of the class on ln(rise-weighted width / width) through
// the cut (no intercept: the probability is 0.5 where the rule turns), the slope of the
// standardised feature with a unit normal prior as above. Throws momentum::Error without at least one example of each class.
ClassRule learn_rule(std::span<const ClassExample> examples, std::size_t joints);

// Reads thresholds/<signal>/classify of a profile document; nullopt when absent. Throws
// momentum::Error `where: message` when it is malformed or its levels are not for `joints`.
std::optional<ClassRule> rule_from_profile(const nlohmann::json& document, std::string_view signal,
                                           std::size_t joints, const std::string& where);
nlohmann::json rule_to_json(const ClassRule& rule);

}  // namespace momentum::contact
