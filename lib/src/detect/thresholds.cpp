#include "momentum/detect/thresholds.hpp"

#include <cmath>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/core/text.hpp"

namespace momentum::detect {

namespace {

bool positive(double x) { return std::isfinite(x) && x > 0; }

}  // namespace

std::string_view signal_name(Signal signal) { return signal == Signal::mu ? "mu" : "r"; }

Signal parse_signal(std::string_view name) {
  if (name == "mu") return Signal::mu;
  if (name == "r") return Signal::r;
  throw Error("unknown signal '" + std::string(name) + "' (mu or r)");
}

std::vector<Signal> parse_signal_list(std::string_view comma_separated) {
  std::vector<Signal> signals;
  for (const auto& name : core::split(comma_separated)) signals.push_back(parse_signal(name));
  return signals;
}

bool RestRule::IsValid(std::string* why) const {
  if (!positive(velocity)) return invalid(why, "rest velocity must be > 0, not " + core::significant(velocity, 9));
  if (!(std::isfinite(time) && time >= 0)) return invalid(why, "rest time must be >= 0, not " + core::significant(time, 9));
  if (!(std::isfinite(hangover) && hangover >= 0)) return invalid(why, "hangover must be >= 0, not " + core::significant(hangover, 9));
  return true;
}

bool Thresholds::IsValid(std::string* why) const {
  if (!rest_rule.IsValid(why)) return false;
  if (!(friction_band >= 0 && std::isfinite(friction_band))) return invalid(why, "friction band must be >= 0 standard deviations, not " + core::significant(friction_band, 9));
  if (joints.empty()) return invalid(why, "no joints");
  for (std::size_t j = 0; j < joints.size(); ++j) {
    const auto& J = joints[j];
    const std::string name = "joint " + std::to_string(j + 1);
    auto bad = [&](const std::string& text) {
      if (why) *why = name + ": " + text;
      return false;
    };
    if (!positive(J.moving)) return bad("moving threshold must be > 0, not " + core::significant(J.moving, 9));
    if (!(J.band >= 0 && std::isfinite(J.band))) return bad("band must be >= 0");
    if (J.slow && !positive(*J.slow)) return bad("slow threshold must be > 0, not " + core::significant(*J.slow, 9));
    if (!(J.slow_band >= 0 && std::isfinite(J.slow_band))) return bad("slow band must be >= 0");
    if (J.rest && !positive(*J.rest)) return bad("rest threshold must be > 0, not " + core::significant(*J.rest, 9));
    if (!(J.rest_band >= 0 && std::isfinite(J.rest_band))) return bad("rest band must be >= 0");
    if (!(J.rest_drift >= 0 && !std::isnan(J.rest_drift))) return bad("rest drift time must be >= 0 s");
    if (J.envelope) {
      if (!positive(J.envelope->a)) return bad("envelope a must be > 0, not " + core::significant(J.envelope->a, 9));
      if (!(std::isfinite(J.envelope->b) && J.envelope->b >= 0))
        return bad("envelope b must be >= 0, not " + core::significant(J.envelope->b, 9));
    }
  }
  return true;
}

const nlohmann::json* thresholds_section(const nlohmann::json& document, std::string_view signal,
                                         std::string_view name) {
  if (!document.is_object()) return nullptr;
  const auto thresholds = document.find("thresholds");
  if (thresholds == document.end() || !thresholds->is_object()) return nullptr;
  const auto entry = thresholds->find(std::string(signal));
  if (entry == thresholds->end() || !entry->is_object()) return nullptr;
  const auto section = entry->find(std::string(name));
  return section == entry->end() ? nullptr : &*section;
}

std::optional<Thresholds> thresholds_from_profile(const nlohmann::json& document, Signal signal,
                                                  const std::string& where) {
  if (!document.is_object()) return std::nullopt;
  const auto section = document.find("thresholds");
  if (section == document.end()) return std::nullopt;
  auto fail = [&](const std::string& message) -> Error { return Error(where + ": " + message); };
  if (!section->is_object()) throw fail("\"thresholds\" must be an object, not " + std::string(section->type_name()));
  const std::string key(signal_name(signal));
  const auto entry = section->find(key);
  if (entry == section->end()) return std::nullopt;
  const std::string base = "thresholds." + key;
  if (!entry->is_object()) throw fail(base + " must be an object");
  auto number = [&](const nlohmann::json& value, const std::string& what) {
    if (!value.is_number()) throw fail(what + " must be a number, not " + std::string(value.type_name()));
    return value.get<double>();
  };
  Thresholds t;
  t.signal = signal;
  if (const auto rest = entry->find("rest"); rest != entry->end()) {
    if (!rest->is_object()) throw fail(base + ".rest must be an object");
    if (const auto v = rest->find("velocity"); v != rest->end()) t.rest_rule.velocity = number(*v, base + ".rest.velocity");
    if (const auto v = rest->find("time"); v != rest->end()) t.rest_rule.time = number(*v, base + ".rest.time");
    // Profiles written before the hangover existed mean none.
    t.rest_rule.hangover = 0;
    if (const auto v = rest->find("hangover"); v != rest->end()) t.rest_rule.hangover = number(*v, base + ".rest.hangover");
    if (const auto v = rest->find("signal"); v != rest->end()) {
      if (*v == "r") t.rest_raw = true;
      else if (*v != std::string(signal_name(signal))) throw fail(base + ".rest.signal must be \"r\" or \"" + std::string(signal_name(signal)) + "\"");
    }
  }
  if (const auto v = entry->find("friction_band"); v != entry->end()) t.friction_band = number(*v, base + ".friction_band");
  if (const auto margin = entry->find("margin"); margin != entry->end() && margin->is_object()) {
    if (const auto v = margin->find("nm"); v != margin->end()) t.margin_nm = number(*v, base + ".margin.nm");
    if (const auto v = margin->find("percent"); v != margin->end())
      t.margin_percent = number(*v, base + ".margin.percent");
  }
  const auto joints = entry->find("joints");
  if (joints == entry->end() || !joints->is_array()) throw fail(base + ".joints must be an array, one object per joint");
  for (std::size_t j = 0; j < joints->size(); ++j) {
    const auto& item = (*joints)[j];
    const std::string name = base + ".joints[" + std::to_string(j) + "]";
    if (!item.is_object()) throw fail(name + " must be an object");
    JointThreshold J;
    const auto moving = item.find("moving");
    if (moving == item.end()) throw fail(name + " has no \"moving\" threshold");
    J.moving = number(*moving, name + ".moving");
    if (const auto v = item.find("band"); v != item.end()) J.band = number(*v, name + ".band");
    if (const auto v = item.find("slow"); v != item.end() && !v->is_null()) J.slow = number(*v, name + ".slow");
    if (const auto v = item.find("slow_band"); v != item.end()) J.slow_band = number(*v, name + ".slow_band");
    if (const auto v = item.find("rest"); v != item.end() && !v->is_null()) J.rest = number(*v, name + ".rest");
    if (const auto v = item.find("rest_band"); v != item.end()) J.rest_band = number(*v, name + ".rest_band");
    if (const auto v = item.find("rest_drift"); v != item.end()) J.rest_drift = number(*v, name + ".rest_drift");
    if (const auto v = item.find("rest_statistic"); v != item.end()) {
      if (*v == "absolute") J.rest_absolute = true;
      else if (*v != "deviation") throw fail(name + ".rest_statistic must be \"deviation\" or \"absolute\"");
    }
    if (const auto v = item.find("envelope"); v != item.end() && !v->is_null()) {
      if (!v->is_object() || !v->contains("a") || !v->contains("b"))
        throw fail(name + ".envelope must be {\"a\": Nm, \"b\": Nm s/rad}");
      J.envelope = JointThreshold::Envelope{number((*v)["a"], name + ".envelope.a"), number((*v)["b"], name + ".envelope.b")};
    }
    t.joints.push_back(J);
  }
  std::string why;
  if (!t.IsValid(&why)) throw fail(base + ": " + why);
  return t;
}

nlohmann::json thresholds_to_json(const Thresholds& t) {
  nlohmann::json entry = nlohmann::json::object();
  entry["rest"] = {{"velocity", t.rest_rule.velocity}, {"time", t.rest_rule.time}, {"hangover", t.rest_rule.hangover}};
  if (t.rest_raw) entry["rest"]["signal"] = "r";
  if (t.friction_band > 0) entry["friction_band"] = t.friction_band;
  if (t.margin_nm) entry["margin"] = {{"nm", *t.margin_nm}};
  else if (t.margin_percent) entry["margin"] = {{"percent", *t.margin_percent}};
  nlohmann::json joints = nlohmann::json::array();
  for (const auto& J : t.joints) {
    nlohmann::json item = {{"moving", J.moving}, {"band", J.band}};
    if (J.slow) {
      item["slow"] = *J.slow;
      item["slow_band"] = J.slow_band;
    }
    if (J.rest) {
      item["rest"] = *J.rest;
      item["rest_band"] = J.rest_band;
      item["rest_statistic"] = J.rest_absolute ? "absolute" : "deviation";
      if (!J.rest_absolute && J.rest_drift > 0) item["rest_drift"] = J.rest_drift;
    }
    if (J.envelope) item["envelope"] = {{"a", J.envelope->a}, {"b", J.envelope->b}};
    joints.push_back(item);
  }
  entry["joints"] = joints;
  return entry;
}

void store_thresholds(nlohmann::json& document, const Thresholds& t) {
  auto& section = document["thresholds"];
  if (section.is_null()) section = nlohmann::json::object();
  if (!section.is_object())
    throw Error("profile: \"thresholds\" must be an object, not " + std::string(section.type_name()));
  auto& entry = section[std::string(signal_name(t.signal))];
  nlohmann::json updated = thresholds_to_json(t);
  // Keys the thresholds do not write belong to other stages (the contact classification rule
  // of contact/classify.hpp) and stay; those they write are replaced whole, so a key the new
  // thresholds leave out (rest_raw's "signal") does not survive from the old ones.
  if (entry.is_object())
    for (const auto& [key, value] : entry.items())
      if (key != "rest" && key != "margin" && key != "joints" && key != "friction_band") updated[key] = value;
  entry = std::move(updated);
}

Thresholds constant_thresholds(Signal signal, const std::vector<double>& values, std::size_t joints) {
  if (values.size() != 1 && values.size() != joints)
    throw Error(std::to_string(values.size()) + " thresholds for " + std::to_string(joints) +
                " joints (give one for all, or one per joint)");
  Thresholds t;
  t.signal = signal;
  for (std::size_t j = 0; j < joints; ++j) {
    JointThreshold J;
    J.moving = values.size() == 1 ? values[0] : values[j];
    t.joints.push_back(J);
  }
  std::string why;
  if (!t.IsValid(&why)) throw Error("threshold: " + why);
  return t;
}

}  // namespace momentum::detect
