#include "momentum/detect/events_json.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string_view>

#include "momentum/core/error.hpp"
#include "momentum/model/json_number.hpp"

namespace momentum::detect {

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
                            {"peak_force_sd", model::json_number(c.peak_force_sd)},
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

JsonLinesWriter::JsonLinesWriter(const std::string& path) : out_(path) {}

JsonLinesWriter::~JsonLinesWriter() = default;

void JsonLinesWriter::write(const nlohmann::json& object) { out_.write(object.dump() + "\n"); }

}  // namespace momentum::detect
