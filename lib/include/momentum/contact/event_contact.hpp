#pragma once
// The stream driver of identification and classification beside the detector (mo-detect): it
// sees every row, keeps the rows of the open event (ContactWindow), and fills each event row the
// detector writes with the contact's link, point, force and class (detect::Event::contact).
//
//   onset row:      no fit (it goes out at once); its class when already known (a joint over
//                   its collision level, or the rise time already decided);
//   identified row: the onset fitted on the rows from the estimated onset to detection;
//   end row:        fitted on the whole event (peak force, impulse), classified on its full rise.
//
// The link of the identified and end rows becomes the identified one (Locator::locate): at onset the best fit
// among the fired signature's link and those beyond it; at the end the most probable of them
// (LinkChoice::most_probable), so that the link named is the one its own probabilities favour.
//
// Between them the class is decided live, as early as the rule allows: at the first row over
// a joint's collision level (a collision), when the pulse is over (below half its peak: its
// width decides), or once it has been above half its peak for the rule's width (a contact).
// decide() reports that moment once per event, for the hooks.

#include <optional>

#include "momentum/contact/classify.hpp"
#include "momentum/contact/locate.hpp"
#include "momentum/contact/window.hpp"
#include "momentum/detect/events.hpp"
#include "momentum/detect/friction_band.hpp"
#include "momentum/detect/annotator.hpp"
#include "momentum/detect/thresholds.hpp"
#include "momentum/model/model.hpp"

namespace momentum::contact {

// The residual noise scale of each joint from its calibrated thresholds (Nm): the moving
// band (the 99th percentile of collision-free motion) over 2.58, else the threshold over 4;
// `slow`: the larger of that and the same of the slow state's band.
Eigen::VectorXd noise_scale(const detect::Thresholds& thresholds, bool slow = false);

// drivers::StreamDetector's annotator (mo-detect): contact/ builds on detect/, which sees it
// through that interface only.
class EventContact final : public detect::EventAnnotator {
 public:
  // `model` must outlive this; its nq must equal the thresholds' joints (momentum::Error
  // otherwise). `rule`: the calibrated class rule, none: events are not classified.
  // `friction_band`: the band the thresholds were calibrated with (detect/friction_band.hpp);
  // a moving joint's noise scale grows by it at the row's speed (one standard deviation of the
  // friction model's steady state added in quadrature).
  EventContact(const model::Model& model, const detect::Thresholds& thresholds, std::optional<ClassRule> rule,
               LocatorOptions options = {}, detect::FrictionBand friction_band = {});

  // Every row, before the detector's step on it: t (s), q (nq), residual x (nq, the detector's
  // signal), velocities dq (nq, rad/s, or null). A joint that is slow (under the rest velocity,
  // and for the hangover after it) is weighted by its calibrated slow band, not its moving
  // band: friction flips there, and its compensation is least sure.
  void add(double t, const double* q, const double* x, const double* dq) override;
  // Fills `event` (a row the detector produced on the last row added) and moves the window:
  // an onset opens it (and gets its class when already decided; no fit), an end is fitted over
  // the whole event and closes it.
  void annotate(detect::Event& event) override;
  // Fits the open event on its rows up to detection: link, point, force (the onset row's
  // identification, written as its identified row). Call after annotate() on the onset row and
  // before the next add().
  void identify(detect::Event& event) override;
  // Once per event, on the row where its class is decided: the class; nullopt on other rows,
  // without a rule, or with no event open.
  std::optional<EventClass> decide_class();
  // decide_class() by name (class_name), for the stream detector's hooks.
  std::optional<std::string_view> decide() override;

  bool classifies() const override { return rule_.has_value(); }

 private:
  void fill(detect::Event& event, bool whole);
  std::optional<ClassRule> rule_;
  Eigen::VectorXd weight_, slow_weight_;  // 1 / noise scale, moving and slow
  detect::FrictionBand friction_band_;
  detect::RestRule rest_rule_;
  Locator locator_;
  LocatorOptions options_;
  ContactWindow window_;
  std::size_t n_;
  double t_last_ = 0;
  int first_link_ = 1;  // the signature's link at the open event's detection
  std::vector<double> x_last_;
  std::vector<double> last_slow_;  // per joint, the last time |dq| was under the rest velocity
  std::vector<double> row_weight_;
  EventClass decided_ = EventClass::unknown;
  bool decision_reported_ = true;
};

// thresholds.<signal>.identify.link_temperature of a profile document (LocatorOptions::
// link_temperature, learnt by mo-calibrate --classes); nullopt when the entry is absent. Throws
// momentum::Error `where: key: message` when it is not a positive number.
std::optional<double> link_temperature_from_profile(const nlohmann::json& document, std::string_view signal,
                                                    const std::string& where);

// The stream detector's annotator factory: an EventContact with `options` for each stream, its
// class rule read from the profile's thresholds (rule_from_profile; messages name
// `profile_path`).
detect::AnnotatorFactory annotator_factory(LocatorOptions options, std::string profile_path);

}  // namespace momentum::contact
