#include "momentum/detect/events_json.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string_view>

#include "momentum/model/json_number.hpp"
#include "momentum/stream/error.hpp"

namespace momentum::detect {

namespace {

nlohmann::json optional_number(const std::optional<double>& x) {
  return x ? model::json_number(*x) : nlohmann::json(nullptr);
}

}  // namespace

nlohmann::json profile_identity(const nlohmann::json& document, const std::string& path) {
  if (path.empty()) return nullptr;
  nlohmann::json identity = {{"name", nullptr}, {"path", nullptr}, {"calibrated", nullptr}};
  if (const auto it = document.find("name"); it != document.end() && it->is_string()) identity["name"] = *it;
  std::error_code ec;
  const auto absolute = std::filesystem::absolute(path, ec);
  identity["path"] = (ec ? std::filesystem::path(path) : absolute.lexically_normal()).string();
  if (const auto it = document.find("provenance"); it != document.end() && it->is_array()) {
    for (const auto& entry : *it) {
      if (entry.is_object() && entry.value("tool", "") == "mo-calibrate" && entry.contains("time"))
        identity["calibrated"] = entry["time"];
    }
  }
  return identity;
}

nlohmann::json event_json(const Event& event, const std::string& source, const nlohmann::json& profile,
                          const Thresholds& thresholds) {
  nlohmann::json peaks = nlohmann::json::array();
  for (const double p : event.peaks) peaks.push_back(model::json_number(p));
  const bool end = event.kind == EventKind::end;
  const Event::Contact& c = event.contact;
  auto word = [](const std::string& w) { return w.empty() ? nlohmann::json(nullptr) : nlohmann::json(w); };
  nlohmann::json links = nlohmann::json::array();
  for (const auto& [link, p] : c.link_probabilities) links.push_back({{"link", link}, {"p", p}});
  nlohmann::json contact = {{"class", word(c.event_class)},
                            {"rise", model::json_number(c.rise)},
                            {"width", model::json_number(c.width)},
                            {"force", model::json_number(c.force)},
                            {"force_sd", model::json_number(c.force_sd)},
                            {"force_world", std::isnan(c.fx) ? nlohmann::json(nullptr)
                                                             : nlohmann::json{model::json_number(c.fx), model::json_number(c.fy), model::json_number(c.fz)}},
                            {"point", std::isnan(c.px) ? nlohmann::json(nullptr)
                                                       : nlohmann::json{model::json_number(c.px), model::json_number(c.py), model::json_number(c.pz)}},
                            {"point_sd", model::json_number(c.point_sd)},
                            {"peak_force", model::json_number(c.peak_force)},
                            {"impulse", model::json_number(c.impulse)},
                            {"fit", model::json_number(c.fit)},
                            {"seen", word(c.seen)},
                            {"links", links},
                            {"link_set", c.link_set},
                            {"p_set", model::json_number(c.set_probability)},
                            {"p_collision", model::json_number(c.collision_probability)}};
  return {{"event", event.id},
          {"kind", std::string(kind_name(event.kind))},
          {"t_onset_estimate", model::json_number(event.t_onset_estimate)},
          {"t_detect", model::json_number(event.t_detect)},
          {"link", event.link},
          {"joints", event.joints},
          {"t_end", end ? model::json_number(event.t_end) : nlohmann::json(nullptr)},
          {"ended_by", end ? nlohmann::json(std::string(end_reason_name(event.ended_by))) : nlohmann::json(nullptr)},
          {"peaks", peaks},
          {"contact", contact},
          {"source", source},
          {"profile", profile},
          {"signal", std::string(signal_name(thresholds.signal))},
          {"thresholds", thresholds_to_json(thresholds)}};
}

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
    if (!(s.seconds > 0)) continue;
    states.push_back({{"joint", s.joint + 1},
                      {"state", s.state},
                      {"false_alarms", s.crossings},
                      {"seconds", model::json_number(s.seconds)},
                      {"stated", model::json_number(s.expected)},
                      {"at_least", s.at_least}});
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

JsonLinesWriter::JsonLinesWriter(const std::string& path) : out_(path) {}

JsonLinesWriter::~JsonLinesWriter() = default;

void JsonLinesWriter::write(const nlohmann::json& object) { out_.write(object.dump() + "\n"); }

}  // namespace momentum::detect
