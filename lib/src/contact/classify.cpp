#include "momentum/contact/classify.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>

#include <Eigen/Cholesky>

#include "momentum/core/error.hpp"
#include "momentum/detect/thresholds.hpp"

namespace momentum::contact {

std::string_view class_name(EventClass c) {
  switch (c) {
    case EventClass::contact: return "contact";
    case EventClass::collision: return "collision";
    case EventClass::unknown: break;
  }
  return "";
}

std::optional<EventClass> parse_class(std::string_view text) {
  if (text == "contact") return EventClass::contact;
  if (text == "collision") return EventClass::collision;
  return std::nullopt;
}

PulseShape pulse_shape(std::span<const ResidualSample> samples, double t_onset, const Eigen::VectorXd& weight) {
  // Called on every row of an undecided event (EventContact::decide): no allocation, the
  // strengths are computed again in the later passes instead of kept.
  //
  // The width is that of the lobe around the peak: from where the strength last rose through
  // half the peak before it to where it first fell back below after it. What comes after
  // (the arm stopping or backing off, a bounce, seen through the model's errors) is the arm's
  // reaction, not the contact, and it differs with the controller and the rate.
  //
  // The crossings of 90% and half the peak are placed between the two samples around them, by
  // linear interpolation, not at the first sample beyond: a width counted in whole samples is
  // short by up to a sample period (8 ms at 125 Hz, 1 ms at 1 kHz), and so is a rise long by
  // up to one, and a rule learnt at one rate would cut elsewhere at another.
  PulseShape shape;
  if (samples.empty()) return shape;
  auto strength = [&](const ResidualSample& s) { return weight.cwiseProduct(s.r).norm(); };
  double peak = 0;
  std::size_t at_peak = 0;
  for (std::size_t i = 0; i < samples.size(); ++i)
    if (const double v = strength(samples[i]); v > peak) peak = v, at_peak = i;
  // The time at which the strength crosses `level` between (t0, a) and (t1, b).
  auto crossing = [](double t0, double a, double t1, double b, double level) {
    return b != a ? t0 + (t1 - t0) * std::clamp((level - a) / (b - a), 0.0, 1.0) : t1;
  };
  const double half = 0.5 * peak;
  // The lobe's start: back from the peak to the last sample below half.
  std::size_t first = at_peak;
  double below = NAN;
  while (first > 0) {
    const double v = strength(samples[first - 1]);
    if (v < half) {
      below = v;
      break;
    }
    --first;
  }
  const double at_first = strength(samples[first]);
  shape.t_first_half = first > 0 ? crossing(samples[first - 1].t, below, samples[first].t, at_first, half)
                                  : samples[first].t;
  // The rise: to the first crossing of 90% of the peak.
  double previous = 0;
  for (std::size_t i = 0; i <= at_peak; ++i) {
    const double v = strength(samples[i]);
    if (v >= 0.9 * peak) {
      shape.rise = std::max(0.0, (i > 0 ? crossing(samples[i - 1].t, previous, samples[i].t, v, 0.9 * peak)
                                         : samples[i].t) -
                                     t_onset);
      break;
    }
    previous = v;
  }
  // The lobe's end: on from the peak to the first sample below half.
  double t_last_half = samples.back().t;
  previous = peak;
  for (std::size_t i = at_peak + 1; i < samples.size(); ++i) {
    const double v = strength(samples[i]);
    if (v < half) {
      t_last_half = crossing(samples[i - 1].t, previous, samples[i].t, v, half);
      shape.over = true;
      break;
    }
    previous = v;
  }
  shape.width = t_last_half - shape.t_first_half;
  return shape;
}

bool ClassRule::IsValid(std::string* why) const {
  if (!(width > 0) || !std::isfinite(width)) return invalid(why, "width must be a positive number of seconds");
  if (!(rise_exponent >= 0) || !std::isfinite(rise_exponent)) return invalid(why, "rise_exponent must be 0 or more");
  if (rise_exponent > 0 && (!(rise_reference > 0) || !std::isfinite(rise_reference)))
    return invalid(why, "rise_reference must be a positive number of seconds");
  for (std::size_t j = 0; j < collision_level.size(); ++j)
    if (!(collision_level[j] > 0)) return invalid(why, "collision level of joint " + std::to_string(j + 1) + " must be positive");
  if (!(slope >= 0) || !std::isfinite(slope)) return invalid(why, "slope must be 0 or more");
  if (!(level_probability > 0 && level_probability <= 1)) return invalid(why, "level_probability must be in (0, 1]");
  return true;
}

double rise_weighted_width(const ClassRule& rule, double width, double rise) {
  if (rule.rise_exponent == 0) return width;
  return width * std::pow(std::max(rise, kShortestRise) / rule.rise_reference, rule.rise_exponent);
}

EventClass classify(const ClassRule& rule, double width, double rise, std::span<const double> peaks) {
  for (std::size_t j = 0; j < std::min(peaks.size(), rule.collision_level.size()); ++j)
    if (std::abs(peaks[j]) > rule.collision_level[j]) return EventClass::collision;
  const double weighted = rise_weighted_width(rule, width, rise);
  if (std::isnan(weighted)) return EventClass::unknown;
  return weighted < rule.width ? EventClass::collision : EventClass::contact;
}

double collision_probability(const ClassRule& rule, double width, double rise, std::span<const double> peaks) {
  if (!(rule.slope > 0)) return NAN;
  for (std::size_t j = 0; j < std::min(peaks.size(), rule.collision_level.size()); ++j)
    if (std::abs(peaks[j]) > rule.collision_level[j]) return rule.level_probability;
  const double weighted = rise_weighted_width(rule, width, rise);
  if (std::isnan(weighted)) return NAN;
  return 1 / (1 + std::pow(std::max(weighted, 1e-12) / rule.width, rule.slope));
}

namespace {

// The slope b of P(collision) = 1 / (1 + exp(b z)) over z = ln(rise-weighted width / cut):
// Newton's method on the standardised z (divided by its root mean square) with a unit normal
// prior on the slope, as the rise's weight. 0 with fewer than 2 examples.
double learn_slope(const std::vector<std::pair<double, bool>>& widths, double cut) {
  std::vector<double> z;
  for (const auto& [w, collision] : widths) z.push_back(std::log(w / cut));
  if (z.size() < 2) return 0;
  double rms = 0;
  for (double v : z) rms += v * v / static_cast<double>(z.size());
  rms = std::sqrt(rms);
  if (!(rms > 0)) return 0;
  double b = 0;  // of the standardised z, for P(collision) = 1 / (1 + exp(b z))
  for (int iteration = 0; iteration < 100; ++iteration) {
    double gradient = -b, hessian = 1;
    for (std::size_t i = 0; i < z.size(); ++i) {
      const double x = -z[i] / rms;  // P(collision) = sigma(b x)
      const double p = 1 / (1 + std::exp(-b * x));
      gradient += ((widths[i].second ? 1.0 : 0.0) - p) * x;
      hessian += p * (1 - p) * x * x;
    }
    const double step = gradient / hessian;
    b += step;
    if (std::abs(step) < 1e-12) break;
  }
  return std::max(0.0, b / rms);
}

// The rise's weight against the width's in a logistic regression of the class (collision 1)
// on (log width, log rise), standardised, with a unit normal prior on the two slopes (Newton's
// method; the prior keeps the fit finite when the classes are separable). 0 when the rise
// points the wrong way. Also the geometric mean rise (s), the reference.
std::pair<double, double> learn_rise_weight(std::span<const ClassExample> examples) {
  std::vector<Eigen::Vector3d> x;
  std::vector<double> y;
  for (const auto& e : examples) {
    if (!std::isfinite(e.width)) continue;
    if (!std::isfinite(e.rise)) return {0.0, 0.0};
    x.emplace_back(1.0, std::log(std::max(e.width, 1e-4)), std::log(std::max(e.rise, kShortestRise)));
    y.push_back(e.collision ? 1.0 : 0.0);
  }
  if (x.size() < 2) return {0.0, 0.0};
  const auto n = static_cast<double>(x.size());
  Eigen::Vector3d mean = Eigen::Vector3d::Zero(), sd = Eigen::Vector3d::Zero();
  for (const auto& v : x) mean += v / n;
  for (const auto& v : x) sd += (v - mean).cwiseAbs2() / n;
  sd = sd.cwiseSqrt();
  if (!(sd[1] > 0) || !(sd[2] > 0)) return {0.0, std::exp(mean[2])};
  for (auto& v : x) v = Eigen::Vector3d(1.0, (v[1] - mean[1]) / sd[1], (v[2] - mean[2]) / sd[2]);
  const Eigen::Vector3d prior(0.0, 1.0, 1.0);  // precision of each coefficient's prior
  Eigen::Vector3d beta = Eigen::Vector3d::Zero();
  for (int iteration = 0; iteration < 50; ++iteration) {
    Eigen::Vector3d gradient = -prior.cwiseProduct(beta);
    Eigen::Matrix3d hessian = prior.asDiagonal();
    for (std::size_t i = 0; i < x.size(); ++i) {
      const double p = 1 / (1 + std::exp(-beta.dot(x[i])));
      gradient += (y[i] - p) * x[i];
      hessian += p * (1 - p) * x[i] * x[i].transpose();
    }
    const Eigen::Vector3d step = hessian.ldlt().solve(gradient);
    beta += step;
    if (step.norm() < 1e-10) break;
  }
  // Both slopes negative (a wider pulse and a slower rise: less often a collision).
  if (!(beta[1] < 0) || !(beta[2] < 0)) return {0.0, std::exp(mean[2])};
  return {(beta[2] / sd[2]) / (beta[1] / sd[1]), std::exp(mean[2])};
}

// The share of the examples the rule classifies right.
double accuracy(const ClassRule& rule, std::span<const ClassExample> examples) {
  int right = 0;
  for (const auto& e : examples) right += (classify(rule, e.width, e.rise, e.peaks) == EventClass::collision) == e.collision;
  return static_cast<double>(right) / static_cast<double>(examples.size());
}

// The rule without levels (rise weight, cut, slope, accuracy) and, per joint, the largest peak
// a contact among the examples reached (the candidate levels).
std::pair<ClassRule, std::vector<double>> learn_cut(std::span<const ClassExample> examples, std::size_t joints) {
  ClassRule rule;
  std::tie(rule.rise_exponent, rule.rise_reference) = learn_rise_weight(examples);
  if (rule.rise_exponent == 0) rule.rise_reference = 0;
  std::vector<std::pair<double, bool>> widths;
  for (const auto& e : examples) {
    (e.collision ? rule.collisions : rule.contacts)++;
    if (std::isfinite(e.width))
      widths.emplace_back(rise_weighted_width(rule, std::max(e.width, 1e-4), e.rise), e.collision);
  }
  if (rule.contacts == 0 || rule.collisions == 0)
    throw Error("learning contact and collision needs examples of both (" + std::to_string(rule.contacts) +
                " contacts, " + std::to_string(rule.collisions) + " collisions)");
  std::sort(widths.begin(), widths.end());
  // Cut between widths[k-1] and widths[k]: collisions below, contacts above.
  int best_correct = -1;
  double best_gap = -1;
  int correct = 0;
  for (const auto& r : widths) correct += r.second ? 0 : 1;  // cut below everything: all contacts
  for (std::size_t k = 0; k <= widths.size(); ++k) {
    if (k > 0) correct += widths[k - 1].second ? 1 : -1;
    if (k == 0 || k == widths.size()) continue;
    if (widths[k].first == widths[k - 1].first) continue;
    const double gap = std::log(widths[k].first / widths[k - 1].first);
    if (correct > best_correct || (correct == best_correct && gap > best_gap)) {
      best_correct = correct, best_gap = gap;
      rule.width = std::sqrt(widths[k].first * widths[k - 1].first);
    }
  }
  if (best_correct < 0) throw Error("learning contact and collision needs examples with different widths");
  std::vector<double> level(joints, 0.0);
  for (const auto& e : examples)
    if (!e.collision)
      for (std::size_t j = 0; j < std::min(joints, e.peaks.size()); ++j)
        level[j] = std::max(level[j], std::abs(e.peaks[j]));
  rule.accuracy = accuracy(rule, examples);
  rule.slope = learn_slope(widths, rule.width);
  return {rule, level};
}

}  // namespace

ClassRule learn_rule(std::span<const ClassExample> examples, std::size_t joints) {
  auto [rule, level] = learn_cut(examples, joints);
  auto usable = [](const std::vector<double>& l) { return std::all_of(l.begin(), l.end(), [](double v) { return v > 0; }); };
  if (!usable(level)) return rule;
  // The levels only where they classify examples they were not learnt from better than the
  // cut alone, each example left out in turn (both rules learnt anew without it). In the
  // examples themselves a level can only help: no contact is over the largest contact's peak.
  // Left out, every contact that alone set a joint's level is over the level of the others,
  // as a new campaign's firmest push will be over this one's: a level that rescues fewer
  // collisions than that calls pushes collisions elsewhere (two pushes of the MuJoCo UR5's
  // second campaign over the first campaign's wrist levels).
  int right_by_cut = 0, right_with_levels = 0;
  std::vector<ClassExample> others;
  for (std::size_t i = 0; i < examples.size(); ++i) {
    others.assign(examples.begin(), examples.end());
    others.erase(others.begin() + static_cast<std::ptrdiff_t>(i));
    std::pair<ClassRule, std::vector<double>> without;
    try {
      without = learn_cut(others, joints);
    } catch (const Error&) {
      continue;  // its class alone, or no two widths left: this example cannot be tested
    }
    const ClassExample& e = examples[i];
    right_by_cut += (classify(without.first, e.width, e.rise, e.peaks) == EventClass::collision) == e.collision;
    if (usable(without.second)) without.first.collision_level = without.second;
    right_with_levels += (classify(without.first, e.width, e.rise, e.peaks) == EventClass::collision) == e.collision;
  }
  if (right_with_levels <= right_by_cut) return rule;
  rule.collision_level = level;
  rule.accuracy = accuracy(rule, examples);
  int over = 0, over_collisions = 0;
  for (const auto& e : examples)
    for (std::size_t j = 0; j < std::min(joints, e.peaks.size()); ++j)
      if (std::abs(e.peaks[j]) > level[j]) {
        ++over, over_collisions += e.collision ? 1 : 0;
        break;
      }
  rule.level_probability = (over_collisions + 1.0) / (over + 2.0);
  return rule;
}

std::optional<ClassRule> rule_from_profile(const nlohmann::json& document, std::string_view signal,
                                           std::size_t joints, const std::string& where) {
  const nlohmann::json* found = detect::thresholds_section(document, signal, "classify");
  if (!found) return std::nullopt;
  const std::string key = "thresholds." + std::string(signal) + ".classify";
  try {
    ClassRule rule;
    rule.width = found->at("width").get<double>();
    rule.rise_exponent = found->value("rise_exponent", 0.0);
    rule.rise_reference = found->value("rise_reference", 0.0);
    if (found->contains("collision")) rule.collision_level = found->at("collision").get<std::vector<double>>();
    rule.contacts = found->value("contacts", 0);
    rule.collisions = found->value("collisions", 0);
    rule.accuracy = found->value("accuracy", 0.0);
    rule.slope = found->value("slope", 0.0);
    rule.level_probability = found->value("level_probability", 1.0);
    std::string why;
    if (!rule.IsValid(&why)) throw Error(why);
    if (!rule.collision_level.empty() && rule.collision_level.size() != joints)
      throw Error("collision levels for " + std::to_string(rule.collision_level.size()) + " joints, the stream has " +
                  std::to_string(joints));
    return rule;
  } catch (const nlohmann::json::exception& e) {
    throw Error(where + ": " + key + ": " + e.what());
  } catch (const Error& e) {
    throw Error(where + ": " + key + ": " + e.what());
  }
}

nlohmann::json rule_to_json(const ClassRule& rule) {
  nlohmann::json j = {{"width", rule.width},
                      {"contacts", rule.contacts},
                      {"collisions", rule.collisions},
                      {"accuracy", rule.accuracy}};
  if (rule.rise_exponent > 0) {
    j["rise_exponent"] = rule.rise_exponent;
    j["rise_reference"] = rule.rise_reference;
  }
  if (!rule.collision_level.empty()) {
    j["collision"] = rule.collision_level;
    j["level_probability"] = rule.level_probability;
  }
  if (rule.slope > 0) j["slope"] = rule.slope;
  return j;
}

}  // namespace momentum::contact
