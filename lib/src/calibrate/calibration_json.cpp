#include "momentum/calibrate/calibration_json.hpp"

#include <cmath>

#include "momentum/model/json_number.hpp"

namespace momentum::calibrate {

// Built on the detector's vocabulary (thresholds, motion states, events).
using namespace detect;

namespace {

nlohmann::json optional_number(const std::optional<double>& x) {
  return x ? model::json_number(*x) : nlohmann::json(nullptr);
}

}  // namespace

std::string calibration_json_lines(const CalibrationResult& result, const nlohmann::json& profile) {
  const std::string signal(signal_name(result.thresholds.signal));
  std::string out;
  for (std::size_t j = 0; j < result.joints.size(); ++j) {
    const JointCalibration& c = result.joints[j];
    const JointThreshold& t = result.thresholds.joints[j];
    const std::pair<const char*, const MagnitudeSummary*> states[] = {
        {"moving", &c.moving}, {"slow", &c.slow}, {"rest", &c.rest}, {"rest_abs", &c.rest_absolute}};
    for (const auto& [state, s] : states) {
      nlohmann::json threshold = nullptr;
      const std::string_view name = state;
      if (name == "moving") threshold = model::json_number(t.moving);
      else if (name == "slow") threshold = optional_number(t.slow);
      else if (name == "rest" && !t.rest_absolute) threshold = optional_number(t.rest);
      else if (name == "rest_abs" && t.rest_absolute) threshold = optional_number(t.rest);
      const bool any = s->samples > 0;
      nlohmann::json line = {{"type", "state"},
                                   {"signal", signal},
                                   {"joint", j + 1},
                                   {"state", state},
                                   {"samples", s->samples},
                                   {"seconds", model::json_number(s->seconds)},
                                   {"rms", any ? model::json_number(s->rms) : nlohmann::json(nullptr)},
                                   {"p99", any ? model::json_number(s->p99) : nlohmann::json(nullptr)},
                                   {"p999", any ? model::json_number(s->p999) : nlohmann::json(nullptr)},
                                   {"max", any ? model::json_number(s->max) : nlohmann::json(nullptr)},
                                   {"t_max", any ? model::json_number(s->t_max) : nlohmann::json(nullptr)},
                                   {"where", any ? nlohmann::json(s->where_max) : nlohmann::json(nullptr)},
                                   {"threshold", threshold}};
      // The data the threshold rests on and the rate it stands for, where the state has one.
      const ThresholdBasis* basis = nullptr;
      if (name == "moving") basis = &c.moving_basis;
      else if (name == "slow" && t.slow) basis = &c.slow_basis;
      else if (!threshold.is_null()) basis = &c.rest_basis;
      line["peaks"] = basis ? nlohmann::json(basis->tail.peaks) : nlohmann::json(nullptr);
      line["left_out"] = basis ? nlohmann::json(basis->tail.outliers.size()) : nlohmann::json(nullptr);
      line["fa_per_h"] = basis ? model::json_number(basis->per_hour) : nlohmann::json(nullptr);
      line["vouched_fa_per_h"] = basis ? model::json_number(basis->vouched_per_hour) : nlohmann::json(nullptr);
      line["data_vouch_for_per_h"] = basis ? model::json_number(basis->tail.supported_per_hour) : nlohmann::json(nullptr);
      out += line.dump() + "\n";
    }
  }
  const nlohmann::json summary = {{"type", "thresholds"},
                                  {"signal", signal},
                                  {"rows", result.rows},
                                  {"streams", result.streams},
                                  {"profile", profile},
                                  {"thresholds", thresholds_to_json(result.thresholds)},
                                  {"false_alarms_stated_per_hour", model::json_number(result.vouched_false_alarms_per_hour())},
                                  {"false_alarms_expected_per_hour", model::json_number(result.expected_false_alarms_per_hour())},
                                  {"false_alarms_vouched_per_hour", model::json_number(result.vouched_false_alarms_per_hour())},
                                  {"out_of_sample", out_of_sample_json(result.out_of_sample)}};
  out += summary.dump() + "\n";
  return out;
}

nlohmann::json out_of_sample_json(const OutOfSample& check) {
  if (check.stretches < 2) return {{"stretches", 0}};
  nlohmann::json states = nlohmann::json::array();
  for (const auto& s : check.states) {
    if (!(s.seconds > 0) && !(s.unchecked_seconds > 0)) continue;
    nlohmann::json item = {{"joint", s.joint + 1},
                           {"state", s.state},
                           {"false_alarms", s.crossings},
                           {"seconds", model::json_number(s.seconds)},
                           {"stated", model::json_number(s.expected)},
                           {"at_least", s.at_least}};
    if (s.unchecked_seconds > 0) {
      item["unchecked_seconds"] = model::json_number(s.unchecked_seconds);
      item["unchecked_false_alarms"] = s.unchecked_crossings;
    }
    states.push_back(item);
  }
  return {{"stretches", check.stretches},
          {"false_alarms", check.crossings},
          {"hours", model::json_number(check.seconds / 3600)},
          {"per_hour", model::json_number(check.seen_per_hour())},
          {"stated", model::json_number(check.expected)},
          {"stated_per_hour", model::json_number(check.stated_per_hour())},
          {"chance", model::json_number(check.chance())},
          {"states", states}};
}

}  // namespace momentum::calibrate
