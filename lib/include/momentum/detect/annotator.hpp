#pragma once
// The detector's view of what identifies and classifies its events (contact::EventContact):
// lib/src/contact builds on detect, so detect knows only this interface, and the stream driver
// (drivers/stream_detector.hpp) runs it beside the detector.

#include <functional>
#include <memory>
#include <optional>
#include <string_view>

#include "momentum/detect/events.hpp"
#include "momentum/detect/friction_band.hpp"
#include "momentum/detect/thresholds.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"

namespace momentum::detect {

// Contact identification and classification beside the detector: the stream driver's view of
// contact::EventContact.
class EventAnnotator {
 public:
  virtual ~EventAnnotator();
  // Every row, before the detector's step on it: t (s), q, the residual x and the velocities dq
  // (n each; dq null when the stream has none).
  virtual void add(double t, const double* q, const double* x, const double* dq) = 0;
  // Fills what needs no fit in an event row the detector produced on the last row added: an
  // onset row opens the event and gets its class when already decided at detection (a joint
  // over its collision level); an end row gets everything, fitted over the whole event.
  virtual void annotate(Event& event) = 0;
  // For an onset row already annotated and written: the identification at detection (the
  // identified link, contact point, force; the class when decided), which the driver writes
  // as the event's `identified` row. The costly part (a fit over the candidate links, up to
  // tens of milliseconds), so that the onset row and its hook do not wait for it.
  virtual void identify(Event& event) = 0;
  // Once per event, on the row where its class is decided: the class name ("collision",
  // "contact", or "" when undecidable); nullopt on other rows.
  virtual std::optional<std::string_view> decide() = 0;
  // Whether events are classified at all (the profile holds a class rule).
  virtual bool classifies() const = 0;
};

// Builds the annotator for a stream of `thresholds.joints.size()` joints from the profile's
// chain (chain.nq equals that count), the profile, and the friction band the detector judges
// with (friction_band.hpp; empty: none). Throws momentum::Error for a bad class rule in the
// profile.
using AnnotatorFactory = std::function<std::unique_ptr<EventAnnotator>(
    const model::Model& chain, const model::Profile& profile, const Thresholds& thresholds,
    const FrictionBand& friction_band)>;

}  // namespace momentum::detect
