#include "momentum/contact/event_contact.hpp"

#include <algorithm>
#include <cmath>
#include <memory>

#include "momentum/core/error.hpp"
#include "momentum/detect/thresholds.hpp"
#include "momentum/observer/observer.hpp"

namespace momentum::contact {

namespace {

// The 99th percentile of a normal variable in standard deviations.
constexpr double kBandSigmas = 2.576;

}  // namespace

Eigen::VectorXd noise_scale(const detect::Thresholds& thresholds, bool slow) {
  Eigen::VectorXd sigma(static_cast<Eigen::Index>(thresholds.joints.size()));
  for (std::size_t j = 0; j < thresholds.joints.size(); ++j) {
    const auto& J = thresholds.joints[j];
    double& s = sigma[static_cast<Eigen::Index>(j)];
    s = J.band > 0 ? J.band / kBandSigmas : J.moving / 4.0;
    if (slow && J.slow) s = std::max(s, J.slow_band > 0 ? J.slow_band / kBandSigmas : *J.slow / 4.0);
  }
  return sigma;
}

EventContact::EventContact(const model::Model& model, const detect::Thresholds& thresholds,
                           std::optional<ClassRule> rule, LocatorOptions options, detect::FrictionBand friction_band)
    : rule_(std::move(rule)),
      weight_(noise_scale(thresholds).cwiseInverse()),
      slow_weight_(noise_scale(thresholds, true).cwiseInverse()),
      friction_band_(std::move(friction_band)),
      rest_rule_(thresholds.rest_rule),
      locator_(model, noise_scale(thresholds), options),
      options_(options),
      window_(static_cast<std::size_t>(model.nq)),
      n_(static_cast<std::size_t>(model.nq)),
      x_last_(n_, 0.0),
      last_slow_(n_, -INFINITY),
      row_weight_(n_, 0.0) {
  if (thresholds.joints.size() != n_)
    throw Error("thresholds for " + std::to_string(thresholds.joints.size()) + " joints, the model has " +
                std::to_string(n_));
  if (!options.observer_k1.empty()) {
    const auto& k = options.observer_k1;
    if (k.size() != 1 && k.size() != n_)
      throw Error(std::to_string(k.size()) + " observer gains for " + std::to_string(n_) + " joints");
    window_.undo_first_order_lag(k.size() == 1 ? std::vector<double>(n_, k[0]) : k);
  }
}

void EventContact::add(double t, const double* q, const double* x, const double* dq) {
  for (std::size_t j = 0; j < n_; ++j) {
    if (dq && std::abs(dq[j]) < rest_rule_.velocity) last_slow_[j] = t;
    const bool slow = t - last_slow_[j] <= rest_rule_.hangover;
    row_weight_[j] = (slow ? slow_weight_ : weight_)[static_cast<Eigen::Index>(j)];
    if (!slow && dq && friction_band_.sigmas() > 0) {
      const double model_sd = friction_band_.width(j, dq[j]) / friction_band_.sigmas();
      const double scale = 1 / row_weight_[j];
      row_weight_[j] = 1 / std::sqrt(scale * scale + model_sd * model_sd);
    }
  }
  window_.add(t, q, x, row_weight_.data());
  t_last_ = t;
  std::copy(x, x + n_, x_last_.begin());
}

void EventContact::fill(detect::Event& event, bool whole) {
  const auto samples = window_.samples();
  const Location loc = locator_.locate(samples, std::min(first_link_, event.link), event.link,
                                       whole ? LinkChoice::most_probable : LinkChoice::best_fit);
  auto& c = event.contact;
  if (loc.link > 0) {
    event.link = loc.link;
    c.force = loc.force_norm;
    c.force_sd = loc.force_sd;
    c.fx = loc.force.x(), c.fy = loc.force.y(), c.fz = loc.force.z();
    c.px = loc.point.x(), c.py = loc.point.y(), c.pz = loc.point.z();
    c.point_sd = loc.point_sd;
    c.peak_force = loc.peak_force;
    c.peak_force_sd = loc.peak_force_sd;
    c.impulse = loc.impulse;
    c.fit = loc.chi2;
    c.seen = loc.point_determined ? "point" : loc.force_determined ? "force" : "partial";
    c.link_probabilities.clear();
    for (const CandidateFit& candidate : loc.candidates)
      c.link_probabilities.emplace_back(candidate.link, candidate.probability);
    std::stable_sort(c.link_probabilities.begin(), c.link_probabilities.end(),
                     [](const auto& a, const auto& b) { return a.second > b.second; });
    const LinkSet set = link_set(loc.candidates, options_.link_confidence, loc.link);
    c.link_set = set.links;
    c.set_probability = set.probability;
  }
  if (whole) {
    const PulseShape shape = pulse_shape(samples, window_.t_onset_estimate(), weight_);
    c.rise = shape.rise;
    c.width = shape.width;
    if (rule_) {
      c.event_class = std::string(class_name(classify(*rule_, c.width, c.rise, event.peaks)));
      c.collision_probability = collision_probability(*rule_, c.width, c.rise, event.peaks);
    }
  } else if (decided_ != EventClass::unknown) {
    c.event_class = std::string(class_name(decided_));
    // As decided: over a level, or on the pulse's shape so far (a contact decided before the
    // pulse is over is wider still: its probability of a collision is at most this).
    const PulseShape shape = pulse_shape(samples, window_.t_onset_estimate(), weight_);
    const double width = shape.over ? shape.width : t_last_ - shape.t_first_half;
    c.collision_probability = collision_probability(*rule_, width, shape.rise, event.peaks);
  }
}

void EventContact::annotate(detect::Event& event) {
  if (event.kind == detect::EventKind::onset) {
    window_.open(event.t_onset_estimate);
    decided_ = EventClass::unknown;
    decision_reported_ = false;
    // Already over a collision level, or the pulse already over or wider than the rule's width,
    // at detection: the onset row says so, and decide() still reports it once for the hooks.
    if (decide_class()) decision_reported_ = false;
    // Candidates from the signature at detection on: joints that fire later may be the arm's
    // reaction (a stop, a back-off) seen through the model's errors, not the contact.
    first_link_ = event.link;
    if (decided_ != EventClass::unknown) event.contact.event_class = std::string(class_name(decided_));
  } else {
    fill(event, true);
    window_.close();
  }
}

void EventContact::identify(detect::Event& event) {
  if (window_.is_open()) fill(event, false);
}

std::optional<EventClass> EventContact::decide_class() {
  if (!rule_ || !window_.is_open() || decision_reported_) return std::nullopt;
  if (decided_ == EventClass::unknown) {
    for (std::size_t j = 0; j < std::min(n_, rule_->collision_level.size()); ++j)
      if (std::abs(x_last_[j]) > rule_->collision_level[j]) decided_ = EventClass::collision;
    if (decided_ == EventClass::unknown) {
      // The pulse is over (its width is known), or already wider than the rule's width.
      const PulseShape shape = pulse_shape(window_.samples(), window_.t_onset_estimate(), weight_);
      // Before the pulse is over its width so far and its rise so far (the 90% mark only moves
      // later as the peak grows) are both lower bounds.
      if (shape.over) decided_ = classify(*rule_, shape.width, shape.rise, {});
      else if (rise_weighted_width(*rule_, t_last_ - shape.t_first_half, shape.rise) >= rule_->width)
        decided_ = EventClass::contact;
    }
  }
  if (decided_ == EventClass::unknown) return std::nullopt;
  decision_reported_ = true;
  return decided_;
}

std::optional<std::string_view> EventContact::decide() {
  const auto decided = decide_class();
  return decided ? std::optional(class_name(*decided)) : std::nullopt;
}

std::optional<double> link_temperature_from_profile(const nlohmann::json& document, std::string_view signal,
                                                    const std::string& where) {
  const nlohmann::json* identify = detect::thresholds_section(document, signal, "identify");
  if (!identify) return std::nullopt;
  const std::string key = "thresholds." + std::string(signal) + ".identify.link_temperature";
  const auto value = identify->is_object() ? identify->find("link_temperature") : identify->end();
  if (!identify->is_object() || value == identify->end() || !value->is_number())
    throw Error(where + ": " + key + ": missing or not a number");
  const double t = value->get<double>();
  if (!(t > 0) || !std::isfinite(t)) throw Error(where + ": " + key + ": must be positive");
  return t;
}

detect::AnnotatorFactory annotator_factory(LocatorOptions options, std::string profile_path) {
  return [options, profile_path = std::move(profile_path)](const model::Model& chain, const model::Profile& profile,
                                                            const detect::Thresholds& thresholds,
                                                            const detect::FrictionBand& band)
             -> std::unique_ptr<detect::EventAnnotator> {
    const std::string_view signal = detect::signal_name(thresholds.signal);
    auto rule = rule_from_profile(profile.document, signal, thresholds.joints.size(), profile_path);
    LocatorOptions located = options;
    if (const auto temperature = link_temperature_from_profile(profile.document, signal, profile_path))
      located.link_temperature = *temperature;
    // The residuals come from mo-observe with the same profile: its observer's lag is undone
    // when it is of the first order (its default), whose recursion the window inverts.
    observer::ObserverOptions observer;
    if (const auto section = profile.document.find("observer"); section != profile.document.end())
      observer = observer::observer_options_from_json(*section, nullptr);
    located.observer_k1.clear();
    if (observer.order == 1)
      for (const observer::Gains& g : observer.joint_gains(static_cast<int>(thresholds.joints.size())))
        located.observer_k1.push_back(g.k1);
    return std::make_unique<EventContact>(chain, thresholds, std::move(rule), located, band);
  };
}

}  // namespace momentum::contact
