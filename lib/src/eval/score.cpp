#include "momentum/eval/score.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/detect/events.hpp"
#include "momentum/model/json_number.hpp"

namespace momentum::eval {

namespace {

// A delay in seconds as the tables show it: milliseconds with one decimal, "-" for none.
std::string ms(double seconds) { return std::isfinite(seconds) ? core::fixed(seconds * 1e3, 1) : "-"; }

using core::fixed;

std::string percent(int part, int whole) {
  if (whole == 0) return "-";
  return fixed(100.0 * part / whole, 1) + "%";
}

DelayStats stats_of(const std::vector<double>& values) {
  DelayStats s;
  s.count = static_cast<int>(values.size());
  if (values.empty()) return s;
  s.min = *std::min_element(values.begin(), values.end());
  s.max = *std::max_element(values.begin(), values.end());
  s.median = percentile(values, 50);
  s.p95 = percentile(values, 95);
  double sum = 0;
  for (double v : values) sum += v;
  s.mean = sum / static_cast<double>(values.size());
  return s;
}

nlohmann::json stats_json(const DelayStats& s) {
  return {{"count", s.count},          {"min", model::json_number(s.min)},   {"median", model::json_number(s.median)},
          {"p95", model::json_number(s.p95)}, {"max", model::json_number(s.max)}, {"mean", model::json_number(s.mean)}};
}

}  // namespace

std::vector<Detection> read_detections(const std::string& path, bool strict) {
  auto reader = detect::EventReader::open(path, {.other_detectors = true, .strict = strict});
  std::vector<Detection> detections;
  // What identification found, from the event's last row read (the end row when there is one).
  auto read_contact = [](const detect::Event& e, Detection& d) {
    d.event_class = e.contact.event_class;
    d.peak_force = e.contact.peak_force;
    d.point = {e.contact.px, e.contact.py, e.contact.pz};
    d.peak_force_sd = e.contact.peak_force_sd;
    d.point_sd = e.contact.point_sd;
    d.width = e.contact.width;
    d.rise = e.contact.rise;
    d.peaks = e.peaks;
    d.link_probabilities = e.contact.link_probabilities;
    d.link_set = e.contact.link_set;
    d.set_probability = e.contact.set_probability;
    d.collision_probability = e.contact.collision_probability;
  };
  std::map<std::uint64_t, std::size_t> event_index;  // event number -> index in detections
  while (const auto e = reader->next()) {
    if (e->kind == detect::EventKind::end) {
      // The end row completes its event: the final link, over every joint that fired.
      const auto it = e->id != 0 ? event_index.find(e->id) : event_index.end();
      if (it != event_index.end() && e->link != 0) {
        detections[it->second].final_link = e->link;
        read_contact(*e, detections[it->second]);
      }
      continue;
    }
    if (e->kind == detect::EventKind::identified) {
      // Identification at detection (mo-detect writes it after the onset row): the link at
      // detection is the identified one, as the end row's is.
      const auto it = e->id != 0 ? event_index.find(e->id) : event_index.end();
      if (it != event_index.end()) {
        if (e->link != 0) detections[it->second].link = detections[it->second].final_link = e->link;
        read_contact(*e, detections[it->second]);
        continue;
      }
    }
    if (e->id != 0 && event_index.count(e->id)) continue;  // a repeated row of an event
    Detection d;
    d.where = reader->where();
    d.t_detect = e->t_detect;
    d.link = e->link;
    d.final_link = d.link;
    d.t_onset_estimate = e->t_onset_estimate;
    read_contact(*e, d);
    if (e->id != 0) event_index[e->id] = detections.size();
    detections.push_back(d);
  }
  return detections;
}

bool ScoreOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(window) && window > 0)) return invalid(why, "window must be a positive number of seconds");
  if (!(std::isfinite(min_torque) && min_torque >= 0)) return invalid(why, "min torque must be a number of Nm >= 0");
  if (duration && !(std::isfinite(*duration) && *duration > 0)) return invalid(why, "duration must be a positive number of seconds");
  return true;
}

std::vector<contact::ClassExample> class_examples(const Truth& truth, const std::vector<Detection>& detections,
                                                  const ScoreOptions& options) {
  std::vector<contact::ClassExample> examples;
  for (const auto& o : score(truth, detections, options).outcomes) {
    if (o.detection < 0) continue;
    const Detection& d = detections[static_cast<std::size_t>(o.detection)];
    if (std::isfinite(d.width)) examples.push_back({d.width, d.peaks, o.contact.clamp, d.rise});
  }
  return examples;
}

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return NAN;
  std::sort(values.begin(), values.end());
  const double position = std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(values.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(position));
  const std::size_t hi = std::min(lo + 1, values.size() - 1);
  const double fraction = position - static_cast<double>(lo);
  return values[lo] + fraction * (values[hi] - values[lo]);
}

Score score(const Truth& truth, const std::vector<Detection>& detections, const ScoreOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw Error(why);
  Score s;
  s.window = options.window;
  s.min_torque = options.min_torque;
  s.duration = options.duration ? options.duration : truth.duration;
  s.contacts = static_cast<int>(truth.contacts.size());
  s.events = static_cast<int>(detections.size());
  for (const auto& c : truth.contacts) {
    ContactOutcome o;
    o.contact = c;
    s.outcomes.push_back(o);
  }

  std::vector<const Detection*> events;
  for (const auto& d : detections) events.push_back(&d);
  std::stable_sort(events.begin(), events.end(),
                   [](const Detection* a, const Detection* b) { return a->t_detect < b->t_detect; });

  const double w = options.window;
  for (const Detection* e : events) {
    const double t = e->t_detect;
    const int index = static_cast<int>(e - detections.data());
    ContactOutcome* hit = nullptr;
    bool in_span = false;
    for (auto& o : s.outcomes) {
      if (o.contact.t_onset > t) break;
      if (!o.detected && t <= o.contact.t_onset + w && !hit) hit = &o;
      if (t <= std::max(o.contact.t_end, o.contact.t_onset) + w) in_span = true;
    }
    if (hit) {
      hit->detected = true;
      hit->delay = t - hit->contact.t_onset;
      hit->reported_link = e->final_link;
      hit->link_at_detection = e->link;
      if (std::isfinite(e->t_onset_estimate)) hit->onset_error = e->t_onset_estimate - hit->contact.t_onset;
      hit->detection = index;
      hit->event_class = e->event_class;
      if (std::isfinite(e->peak_force) && std::isfinite(hit->contact.peak_force))
        hit->force_error = std::abs(e->peak_force - hit->contact.peak_force);
      if (e->final_link == hit->contact.link && e->point.allFinite() && hit->contact.point.allFinite())
        hit->point_error = (e->point - hit->contact.point).norm();
      hit->peak_force_sd = e->peak_force_sd;
      hit->point_sd = e->point_sd;
      hit->link_probabilities = e->link_probabilities;
      hit->link_set = e->link_set;
      hit->set_probability = e->set_probability;
      hit->collision_probability = e->collision_probability;
    } else if (in_span) {
      // Within some contact's span: a repeat when one there is detected, else late.
      bool any_detected = false;
      for (const auto& o : s.outcomes)
        if (o.contact.t_onset <= t && t <= std::max(o.contact.t_end, o.contact.t_onset) + w && o.detected)
          any_detected = true;
      (any_detected ? s.repeats : s.late)++;
    } else {
      ++s.false_alarms;
      s.false_alarm_times.push_back(t);
    }
  }

  std::vector<double> delays, onset_errors;
  std::map<int, std::vector<double>> link_delays;
  std::map<int, LinkScore> by_link;
  // Errors of identification, over all contacts (key 0) and per link.
  std::map<int, std::array<std::vector<double>, 3>> errors;  // force N, force %, point m
  auto add_identification = [&](IdentificationStats& stats, std::array<std::vector<double>, 3>& e,
                                const ContactOutcome& o) {
    if (!o.event_class.empty()) {
      ++stats.classified;
      stats.class_right += (o.event_class == "collision") == o.contact.clamp;
    }
    if (std::isfinite(o.force_error) && std::isfinite(o.peak_force_sd)) {
      ++stats.force_with_sd;
      stats.force_covered += o.force_error <= o.peak_force_sd;
    }
    if (std::isfinite(o.point_error) && std::isfinite(o.point_sd)) {
      ++stats.point_with_sd;
      stats.point_covered += o.point_error <= o.point_sd;
    }
    if (std::isfinite(o.force_error)) {
      e[0].push_back(o.force_error);
      e[1].push_back(100 * o.force_error / o.contact.peak_force);
    }
    if (std::isfinite(o.point_error)) e[2].push_back(o.point_error);
  };
  for (const auto& o : s.outcomes) {
    LinkScore& l = by_link[o.contact.link];
    l.link = o.contact.link;
    ++l.contacts;
    const bool felt = !(o.contact.peak_torque < options.min_torque);  // NaN: unknown, so felt
    s.felt += felt;
    s.felt_detected += felt && o.detected;
    if (!o.detected) continue;
    ++s.detected;
    ++l.detected;
    delays.push_back(o.delay);
    link_delays[o.contact.link].push_back(o.delay);
    if (o.reported_link == o.contact.link) ++s.isolated, ++l.isolated;
    if (o.link_at_detection == o.contact.link) ++s.isolated_at_detection;
    if (std::isfinite(o.onset_error)) onset_errors.push_back(std::abs(o.onset_error));
    add_identification(s.identification, errors[0], o);
    add_identification(l.identification, errors[o.contact.link], o);
  }
  auto finish_identification = [](IdentificationStats& stats, const std::array<std::vector<double>, 3>& e) {
    stats.force_error = stats_of(e[0]);
    stats.force_error_percent = stats_of(e[1]);
    stats.point_error = stats_of(e[2]);
  };
  // The stated link sets and probabilities.
  {
    LinkSetStats& l = s.link_sets;
    std::vector<std::pair<double, bool>> link_statements, class_statements;
    double sizes = 0, stated = 0;
    int stated_count = 0;
    for (const auto& o : s.outcomes) {
      if (!o.detected) continue;
      if (!o.link_set.empty()) {
        ++l.with_set;
        const bool in = std::find(o.link_set.begin(), o.link_set.end(), o.contact.link) != o.link_set.end();
        l.truth_in_set += in;
        l.truth_in_pair += in && o.link_set.size() <= 2;
        sizes += static_cast<double>(o.link_set.size());
        if (std::isfinite(o.set_probability)) stated += o.set_probability, ++stated_count;
      }
      bool named = false;
      for (const auto& [link, p] : o.link_probabilities) {
        link_statements.emplace_back(p, link == o.contact.link);
        named = named || link == o.contact.link;
      }
      if (!o.link_probabilities.empty() && !named) link_statements.emplace_back(0.0, true);
      if (std::isfinite(o.collision_probability)) class_statements.emplace_back(o.collision_probability, o.contact.clamp);
    }
    if (l.with_set) l.mean_size = sizes / l.with_set;
    if (stated_count) l.mean_stated = stated / stated_count;
    l.links = calibration(link_statements);
    l.classes = calibration(class_statements);
  }
  s.missed = s.contacts - s.detected;
  s.delay = stats_of(delays);
  s.onset_error = stats_of(onset_errors);
  finish_identification(s.identification, errors[0]);
  for (auto& [link, l] : by_link) {
    l.delay = stats_of(link_delays[link]);
    finish_identification(l.identification, errors[link]);
    s.by_link.push_back(l);
  }

  if (s.duration) {
    // Union of the spans [onset, end + window] within [0, duration].
    double busy = 0, covered_to = 0;
    for (const auto& c : truth.contacts) {
      const double a = std::max(c.t_onset, covered_to);
      const double b = std::min(std::max(c.t_end, c.t_onset) + w, *s.duration);
      if (b > a) busy += b - a;
      covered_to = std::max(covered_to, b);
    }
    s.collision_free = std::max(0.0, *s.duration - busy);
    if (*s.collision_free > 0) s.false_alarms_per_hour = s.false_alarms / (*s.collision_free / 3600.0);
  }
  return s;
}

Calibration calibration(const std::vector<std::pair<double, bool>>& statements, int bins) {
  Calibration c;
  bins = std::max(bins, 1);
  for (int b = 0; b < bins; ++b) c.bins.push_back({static_cast<double>(b) / bins, static_cast<double>(b + 1) / bins, 0, 0, 0.0});
  double brier = 0, log_loss = 0;
  for (const auto& [p, came_true] : statements) {
    if (!std::isfinite(p)) continue;
    const double q = std::clamp(p, 0.0, 1.0);
    ++c.statements;
    c.came_true += came_true;
    const double outcome = came_true ? 1.0 : 0.0;
    brier += (q - outcome) * (q - outcome);
    const double kept = std::clamp(q, 1e-6, 1 - 1e-6);
    log_loss -= std::log(came_true ? kept : 1 - kept);
    ReliabilityBin& bin = c.bins[static_cast<std::size_t>(std::min(bins - 1, static_cast<int>(q * bins)))];
    ++bin.statements;
    bin.came_true += came_true;
    bin.mean_stated += q;  // a sum until the end
  }
  for (auto& bin : c.bins) bin.mean_stated = bin.statements ? bin.mean_stated / bin.statements : NAN;
  if (c.statements) c.brier = brier / c.statements, c.log_loss = log_loss / c.statements;
  return c;
}

std::string format_table(const Score& s, bool list) {
  std::string out;
  auto line = [&](const std::string& label, const std::string& value) {
    char buffer[40];
    std::snprintf(buffer, sizeof buffer, "%-14s", label.c_str());
    out += buffer + value + "\n";
  };
  line("contacts", std::to_string(s.contacts) + (s.duration ? " in " + fixed(*s.duration, 1) + " s" : "") +
                       ", window " + ms(s.window) + " ms");
  line("detected", std::to_string(s.detected) + " of " + std::to_string(s.contacts) + " (" +
                       percent(s.detected, s.contacts) + ")");
  line("missed", std::to_string(s.missed));
  if (s.min_torque > 0)
    line("felt", std::to_string(s.felt_detected) + " of " + std::to_string(s.felt) + " detected (" +
                     percent(s.felt_detected, s.felt) + "); " + std::to_string(s.contacts - s.felt) +
                     " below " + fixed(s.min_torque, 1) + " Nm on every joint");
  std::string fa = std::to_string(s.false_alarms);
  if (s.false_alarms_per_hour)
    fa += " (" + fixed(*s.false_alarms_per_hour, 2) + " per hour over " + fixed(*s.collision_free / 3600.0, 3) +
          " h collision-free)";
  else
    fa += " (rate unknown: no duration; give --duration)";
  line("false alarms", fa);
  if (s.repeats || s.late)
    line("other events", std::to_string(s.repeats) + " repeat, " + std::to_string(s.late) + " late");
  if (s.delay.count)
    line("delay", "min " + ms(s.delay.min) + "  median " + ms(s.delay.median) + "  p95 " + ms(s.delay.p95) +
                      "  max " + ms(s.delay.max) + " ms");
  else
    line("delay", "-");
  line("isolation", std::to_string(s.isolated) + " of " + std::to_string(s.detected) + " right (" +
                        percent(s.isolated, s.detected) + "); at detection " +
                        std::to_string(s.isolated_at_detection) + " (" +
                        percent(s.isolated_at_detection, s.detected) + ")");
  if (s.onset_error.count)
    line("onset error", "median " + ms(s.onset_error.median) + "  max " + ms(s.onset_error.max) + " ms");
  const IdentificationStats& id = s.identification;
  const bool identified = id.classified > 0 || id.force_error.count > 0;
  auto median_text = [](const DelayStats& d, int digits, const char* unit) {
    return d.count ? fixed(d.median, digits) + unit : std::string("-");
  };
  if (id.classified)
    line("class", std::to_string(id.class_right) + " of " + std::to_string(id.classified) + " right (" +
                      percent(id.class_right, id.classified) + ")");
  if (id.force_error.count)
    line("force error", "median " + fixed(id.force_error.median, 1) + " N (" +
                            fixed(id.force_error_percent.median, 0) + "% of the peak), p95 " +
                            fixed(id.force_error.p95, 1) + " N, over " + std::to_string(id.force_error.count));
  if (id.point_error.count)
    line("point error", "median " + fixed(id.point_error.median, 3) + " m, p95 " + fixed(id.point_error.p95, 3) +
                            " m, over " + std::to_string(id.point_error.count) + " (right link, true point known)");
  if (id.force_with_sd || id.point_with_sd)
    line("within 1 sd", "force " + std::to_string(id.force_covered) + " of " + std::to_string(id.force_with_sd) + " (" +
                            percent(id.force_covered, id.force_with_sd) + "), point " +
                            std::to_string(id.point_covered) + " of " + std::to_string(id.point_with_sd) + " (" +
                            percent(id.point_covered, id.point_with_sd) + "); about 68% if the stated uncertainties hold");
  const LinkSetStats& ls = s.link_sets;
  if (ls.with_set)
    line("link sets", "truth in " + std::to_string(ls.truth_in_set) + " of " + std::to_string(ls.with_set) + " (" +
                          percent(ls.truth_in_set, ls.with_set) + "; stated " + fixed(100 * ls.mean_stated, 0) +
                          "%), mean size " + fixed(ls.mean_size, 2) + ", in a set of 1 or 2: " +
                          std::to_string(ls.truth_in_pair));
  auto calibration_lines = [&](const char* what, const Calibration& c) {
    if (!c.statements) return;
    line(what, "Brier " + fixed(c.brier, 3) + ", log-loss " + fixed(c.log_loss, 3) + " over " +
                   std::to_string(c.statements) + " statements");
    for (const auto& bin : c.bins) {
      if (!bin.statements) continue;
      char buffer[120];
      std::snprintf(buffer, sizeof buffer, "  p %.1f-%.1f: stated %.2f, came true %d of %d (%.2f)\n", bin.low, bin.high,
                    bin.mean_stated, bin.came_true, bin.statements, static_cast<double>(bin.came_true) / bin.statements);
      out += buffer;
    }
  };
  calibration_lines("link p", ls.links);
  calibration_lines("collision p", ls.classes);
  if (!s.by_link.empty()) {
    out += "\nlink  contacts  detected  isolated  median delay\n";
    for (const auto& l : s.by_link) {
      char buffer[96];
      std::snprintf(buffer, sizeof buffer, "%4d  %8d  %8d  %8d  %9s ms\n", l.link, l.contacts, l.detected, l.isolated,
                    ms(l.delay.median).c_str());
      out += buffer;
    }
    if (identified) {
      out += "\nlink  classified  class right  force error  point error\n";
      for (const auto& l : s.by_link) {
        const IdentificationStats& i = l.identification;
        char buffer[120];
        std::snprintf(buffer, sizeof buffer, "%4d  %10d  %11d  %11s  %11s\n", l.link, i.classified, i.class_right,
                      median_text(i.force_error_percent, 0, " %").c_str(), median_text(i.point_error, 3, " m").c_str());
        out += buffer;
      }
    }
  }
  if (list) {
    out += "\n";
    for (const auto& o : s.outcomes) {
      std::string text = "contact t " + fixed(o.contact.t_onset, 3) + " link " + std::to_string(o.contact.link);
      if (std::isfinite(o.contact.peak_force)) text += " " + fixed(o.contact.peak_force, 1) + " N";
      if (std::isfinite(o.contact.peak_torque)) {
        text += " (joints up to " + fixed(o.contact.peak_torque, 1) + " Nm";
        text += o.contact.peak_torque < s.min_torque ? ", unfelt)" : ")";
      }
      if (o.contact.clamp) text += " clamp";
      if (o.detected) {
        text += ": detected after " + ms(o.delay) + " ms, link " + std::to_string(o.reported_link) +
                (o.reported_link == o.contact.link ? "" : " (wrong)");
        if (o.link_at_detection != o.reported_link)
          text += ", link " + std::to_string(o.link_at_detection) + " at detection";
        if (!o.event_class.empty())
          text += ", " + o.event_class + ((o.event_class == "collision") == o.contact.clamp ? "" : " (wrong)");
        if (std::isfinite(o.force_error)) text += ", force off by " + fixed(o.force_error, 1) + " N";
        if (std::isfinite(o.point_error)) text += ", point off by " + fixed(o.point_error, 3) + " m";
        if (!o.link_set.empty()) {
          text += ", links";
          for (std::size_t i = 0; i < o.link_set.size(); ++i) text += (i ? ";" : " ") + std::to_string(o.link_set[i]);
          if (std::isfinite(o.set_probability)) text += " at " + fixed(o.set_probability, 2);
        }
      } else {
        text += ": MISSED";
      }
      out += text + "\n";
    }
    for (double t : s.false_alarm_times) out += "false alarm t " + fixed(t, 3) + "\n";
  }
  return out;
}

nlohmann::json to_json(const Score& s) {
  nlohmann::json j;
  j["window_s"] = s.window;
  j["duration_s"] = s.duration ? nlohmann::json(*s.duration) : nlohmann::json(nullptr);
  j["contacts"] = s.contacts;
  j["detected"] = s.detected;
  j["missed"] = s.missed;
  j["min_torque_nm"] = s.min_torque;
  j["felt"] = s.felt;
  j["felt_detected"] = s.felt_detected;
  j["detection_rate"] = s.contacts ? nlohmann::json(double(s.detected) / s.contacts) : nlohmann::json(nullptr);
  j["events"] = s.events;
  j["false_alarms"] = s.false_alarms;
  j["false_alarms_per_hour"] = s.false_alarms_per_hour ? nlohmann::json(*s.false_alarms_per_hour) : nlohmann::json(nullptr);
  j["collision_free_s"] = s.collision_free ? nlohmann::json(*s.collision_free) : nlohmann::json(nullptr);
  j["repeats"] = s.repeats;
  j["late"] = s.late;
  j["delay_s"] = stats_json(s.delay);
  j["isolated"] = s.isolated;
  j["isolation_rate"] = s.detected ? nlohmann::json(double(s.isolated) / s.detected) : nlohmann::json(nullptr);
  j["isolated_at_detection"] = s.isolated_at_detection;
  j["onset_error_s"] = stats_json(s.onset_error);
  auto identification_json = [](const IdentificationStats& i) -> nlohmann::json {
    return {{"classified", i.classified},
            {"class_right", i.class_right},
            {"force_error_n", stats_json(i.force_error)},
            {"force_error_percent", stats_json(i.force_error_percent)},
            {"point_error_m", stats_json(i.point_error)},
            {"force_with_sd", i.force_with_sd},
            {"force_covered", i.force_covered},
            {"point_with_sd", i.point_with_sd},
            {"point_covered", i.point_covered}};
  };
  j["identification"] = identification_json(s.identification);
  auto calibration_json = [](const Calibration& c) -> nlohmann::json {
    nlohmann::json bins = nlohmann::json::array();
    for (const auto& b : c.bins)
      bins.push_back({{"low", b.low}, {"high", b.high}, {"statements", b.statements}, {"came_true", b.came_true},
                      {"mean_stated", model::json_number(b.mean_stated)}});
    return {{"statements", c.statements}, {"came_true", c.came_true}, {"brier", model::json_number(c.brier)},
            {"log_loss", model::json_number(c.log_loss)}, {"bins", bins}};
  };
  j["link_sets"] = {{"with_set", s.link_sets.with_set},
                    {"truth_in_set", s.link_sets.truth_in_set},
                    {"truth_in_pair", s.link_sets.truth_in_pair},
                    {"mean_size", model::json_number(s.link_sets.mean_size)},
                    {"mean_stated", model::json_number(s.link_sets.mean_stated)},
                    {"links", calibration_json(s.link_sets.links)},
                    {"classes", calibration_json(s.link_sets.classes)}};
  j["by_link"] = nlohmann::json::array();
  for (const auto& l : s.by_link)
    j["by_link"].push_back({{"link", l.link}, {"contacts", l.contacts}, {"detected", l.detected},
                            {"isolated", l.isolated}, {"delay_s", stats_json(l.delay)},
                            {"identification", identification_json(l.identification)}});
  j["contacts_detail"] = nlohmann::json::array();
  for (const auto& o : s.outcomes)
    j["contacts_detail"].push_back({{"t_onset", o.contact.t_onset}, {"t_end", o.contact.t_end},
                                    {"link", o.contact.link}, {"clamp", o.contact.clamp},
                                    {"peak_force", model::json_number(o.contact.peak_force)},
                                    {"peak_torque", model::json_number(o.contact.peak_torque)},
                                    {"detected", o.detected}, {"delay_s", model::json_number(o.delay)},
                                    {"reported_link", o.reported_link},
                                    {"link_at_detection", o.link_at_detection},
                                    {"class", o.event_class.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.event_class)},
                                    {"force_error_n", model::json_number(o.force_error)},
                                    {"point_error_m", model::json_number(o.point_error)},
                                    {"link_set", o.link_set},
                                    {"p_set", model::json_number(o.set_probability)},
                                    {"p_collision", model::json_number(o.collision_probability)}});
  j["false_alarm_times"] = s.false_alarm_times;
  return j;
}

}  // namespace momentum::eval
