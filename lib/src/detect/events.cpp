#include "momentum/detect/events.hpp"


#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include "momentum/core/error.hpp"
#include "momentum/core/file.hpp"
#include "momentum/core/text.hpp"
#include "momentum/stream/format.hpp"
#include "momentum/stream/format.hpp"

namespace momentum::detect {

namespace {

constexpr std::size_t npos = static_cast<std::size_t>(-1);

void append_number(std::string& out, double value) {
  char buffer[40];
  out.append(buffer, stream::format_double(value, buffer));
}

// A probability to 3 significant digits (0.912, 1.2e-07): beyond that its digits say nothing of
// its calibration, and a small one keeps its order of magnitude (mo-calibrate --classes tempers
// them).
void append_probability(std::string& out, double p) {
  char buffer[32];
  const int n = std::snprintf(buffer, sizeof buffer, "%.3g", p);
  out.append(buffer, static_cast<std::size_t>(std::max(n, 0)));
}

std::vector<std::string_view> split_fields(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    fields.push_back(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return fields;
}

using core::trim;

// A field without blanks around it and without the double quotes a spreadsheet may add.
std::string_view field(std::string_view text) {
  text = trim(text);
  if (text.size() >= 2 && text.front() == '"' && text.back() == '"') text = text.substr(1, text.size() - 2);
  return text;
}

bool equal_ignoring_case(std::string_view a, std::string_view b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(), [](char x, char y) {
    return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
  });
}

// The contact columns, in order (event_header's documentation).
constexpr const char* kContactColumns[] = {"class", "rise", "width",  "f",       "fx",  "fy",   "fz", "f_sd",
                                           "px",    "py",   "pz",     "p_sd",    "f_peak", "impulse", "fit", "seen"};
// Appended after them (issue 29), so that the columns before keep their places.
constexpr const char* kLinkColumns[] = {"links", "link_set", "p_set", "p_collision"};
// And after those, the peak force's uncertainty (f_sd is the strongest row's force's).
constexpr const char* kPeakForceSdColumn = "f_peak_sd";
constexpr std::size_t kContactNumbers = 14;  // columns 1..14 are numbers, 0 and 15 words

double* contact_number(Event::Contact& c, std::size_t k) {
  double* fields[kContactNumbers] = {&c.rise, &c.width, &c.force, &c.fx,       &c.fy,         &c.fz,      &c.force_sd,
                                     &c.px,   &c.py,    &c.pz,    &c.point_sd, &c.peak_force, &c.impulse, &c.fit};
  return fields[k];
}

}  // namespace

std::string_view kind_name(EventKind kind) {
  switch (kind) {
    case EventKind::onset: return "onset";
    case EventKind::identified: return "identified";
    case EventKind::end: break;
  }
  return "end";
}

std::string_view end_reason_name(EndReason reason) {
  switch (reason) {
    case EndReason::release: return "release";
    case EndReason::next: return "next";
    case EndReason::eof: return "eof";
    case EndReason::signal: return "signal";
    case EndReason::clock_step: return "clock_step";
    case EndReason::none: break;
  }
  return "";
}

std::string event_header(std::size_t joints, bool contact) {
  std::string header = "t_onset_estimate,t_detect,link,joints,kind,event,t_end,ended_by";
  for (std::size_t j = 1; j <= joints; ++j) header += ",peak" + std::to_string(j);
  if (contact) {
    for (const char* column : kContactColumns) header += std::string(",") + column;
    for (const char* column : kLinkColumns) header += std::string(",") + column;
    header += std::string(",") + kPeakForceSdColumn;
  }
  return header;
}

std::string format_event(const Event& e, bool contact) {
  std::string line;
  line.reserve(64 + 24 * e.peaks.size());
  append_number(line, e.t_onset_estimate);
  line += ',';
  append_number(line, e.t_detect);
  line += ',';
  line += std::to_string(e.link);
  line += ',';
  for (std::size_t i = 0; i < e.joints.size(); ++i) {
    if (i) line += ';';
    line += std::to_string(e.joints[i]);
  }
  line += ',';
  line += kind_name(e.kind);
  line += ',';
  line += std::to_string(e.id);
  line += ',';
  if (e.kind == EventKind::end && !std::isnan(e.t_end)) append_number(line, e.t_end);
  line += ',';
  if (e.kind == EventKind::end) line += end_reason_name(e.ended_by);
  for (double p : e.peaks) {
    line += ',';
    append_number(line, p);
  }
  if (contact) {
    Event::Contact c = e.contact;
    line += ',';
    line += c.event_class;
    for (std::size_t k = 0; k < kContactNumbers; ++k) {
      line += ',';
      if (const double v = *contact_number(c, k); !std::isnan(v)) append_number(line, v);
    }
    line += ',';
    line += c.seen;
    line += ',';
    for (std::size_t i = 0; i < c.link_probabilities.size(); ++i) {
      if (i) line += ';';
      line += std::to_string(c.link_probabilities[i].first) + ':';
      append_probability(line, c.link_probabilities[i].second);
    }
    line += ',';
    for (std::size_t i = 0; i < c.link_set.size(); ++i) {
      if (i) line += ';';
      line += std::to_string(c.link_set[i]);
    }
    line += ',';
    if (!std::isnan(c.set_probability)) append_probability(line, c.set_probability);
    line += ',';
    if (!std::isnan(c.collision_probability)) append_probability(line, c.collision_probability);
    line += ',';
    if (!std::isnan(c.peak_force_sd)) append_number(line, c.peak_force_sd);
  }
  return line;
}

// ---- writer ----------------------------------------------------------------------------

EventWriter::EventWriter(const std::string& path, std::size_t joints, const std::vector<std::string>& comments,
                         bool contact)
    : out_(path), joints_(joints), contact_(contact) {
  std::string head;
  // A comment with a line break must not become an event row (issue 26).
  for (const auto& c : comments) head += stream::csv_comment_lines(c);
  head += event_header(joints, contact) + "\n";
  out_.write(head);
}

EventWriter::~EventWriter() = default;

void EventWriter::write(const Event& event) {
  if (event.peaks.size() != joints_)
    throw Error(out_.name() + ": event with " + std::to_string(event.peaks.size()) + " peaks, header has " +
                std::to_string(joints_));
  out_.write(format_event(event, contact_) + "\n");
  ++rows_;
}

// ---- reader ----------------------------------------------------------------------------

std::unique_ptr<EventReader> EventReader::open(const std::string& path, EventReaderOptions options) {
  std::unique_ptr<EventReader> reader(new EventReader());
  reader->options_ = options;
  const bool from_stdin = core::is_standard_input(path);
  reader->name_ = core::input_name(path);
  reader->file_ = from_stdin ? stdin : std::fopen(path.c_str(), "rb");
  if (!reader->file_) throw Error(path + ": cannot open: " + std::strerror(errno));
  reader->owns_ = !from_stdin;
  std::string line;
  bool have_header = false;
  while (reader->read_line(line)) {
    if (!line.empty() && line.front() == '#') {
      reader->comments_.push_back(line.substr(1));
      continue;
    }
    if (trim(line).empty()) continue;
    have_header = true;
    break;
  }
  if (!have_header) throw Error(located(reader->name_, reader->line_, "no header (empty event file)"));
  const auto fields = split_fields(line);
  reader->width_ = fields.size();
  auto find = [&](std::string_view name) {
    for (std::size_t i = 0; i < fields.size(); ++i)
      if (field(fields[i]) == name) return i;
    return npos;
  };
  auto require = [&](std::string_view name) {
    const std::size_t i = find(name);
    if (i == npos)
      throw Error(located(reader->name_, reader->line_, "missing column '" + std::string(name) +
                                                            "' (not an event file of mo-detect?)"));
    return i;
  };
  if (options.other_detectors) {
    reader->c_detect_ = find("t_detect");
    reader->c_link_ = find("link");
    if (reader->c_detect_ == npos || reader->c_link_ == npos)
      throw Error(located(reader->name_, reader->line_,
                          std::string("event file needs columns t_detect and link (missing ") +
                              (reader->c_detect_ == npos ? "t_detect" : "link") + ")"));
    reader->c_onset_ = find("t_onset_estimate");
    reader->c_joints_ = find("joints");
    reader->c_kind_ = find("kind");
    reader->c_id_ = find("event");
  } else {
    reader->c_onset_ = require("t_onset_estimate");
    reader->c_detect_ = require("t_detect");
    reader->c_link_ = require("link");
    reader->c_joints_ = require("joints");
    reader->c_kind_ = require("kind");
    reader->c_id_ = require("event");
  }
  reader->c_end_ = find("t_end");
  reader->c_ended_by_ = find("ended_by");
  for (std::size_t j = 1;; ++j) {
    const std::size_t i = find("peak" + std::to_string(j));
    if (i == npos) break;
    reader->c_peaks_.push_back(i);
  }
  reader->joints_ = reader->c_peaks_.size();
  for (const char* column : kContactColumns) reader->c_contact_.push_back(find(column));
  for (const char* column : kLinkColumns) reader->c_links_.push_back(find(column));
  reader->c_peak_force_sd_ = find(kPeakForceSdColumn);
  return reader;
}

EventReader::~EventReader() {
  if (owns_ && file_) std::fclose(file_);
}

bool EventReader::read_line(std::string& line) {
  line.clear();
  int c;
  bool any = false;
  while ((c = std::getc(file_)) != EOF) {
    any = true;
    if (c == '\n') break;
    line += static_cast<char>(c);
  }
  if (!any) {
    if (std::ferror(file_)) throw Error(name_ + ": read error: " + std::strerror(errno));
    return false;
  }
  ++line_;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return true;
}

std::string EventReader::where() const { return name_ + ":" + std::to_string(line_); }

std::optional<Event> EventReader::next() {
  std::string line;
  for (;;) {
    if (!read_line(line)) return std::nullopt;
    if (!line.empty() && line.front() == '#') {
      comments_.push_back(line.substr(1));
      continue;
    }
    if (trim(line).empty()) continue;
    try {
      if (auto event = parse(line)) return event;
    } catch (const Error& e) {
      if (options_.strict) throw;
      warn_row("bad event row", std::string(e.what()) + "; row skipped");
    }
  }
}

std::optional<Event> EventReader::parse(const std::string& line) const {
  auto fail = [&](const std::string& message) -> Error { return Error(located(name_, line_, message)); };
  const bool other = options_.other_detectors;
  const auto fields = split_fields(line);
  if (fields.size() != width_)
    throw fail(std::to_string(fields.size()) + " fields, header has " + std::to_string(width_));
  auto number = [&](std::size_t column, const char* what) {
    auto value = stream::parse_double(field(fields[column]));
    if (!value) throw fail(std::string("bad ") + what + " '" + core::printable(fields[column]) + "'");
    return *value;
  };
  auto integer = [&](std::string_view text, const char* what) {
    text = field(text);
    long long value = 0;
    auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || text.empty())
      throw fail(std::string("bad ") + what + " '" + core::printable(text) + "'");
    return value;
  };
  Event e;
  if (c_kind_ != npos) {
    const std::string_view kind = field(fields[c_kind_]);
    if (equal_ignoring_case(kind, "onset")) e.kind = EventKind::onset;
    else if (equal_ignoring_case(kind, "end")) e.kind = EventKind::end;
    else if (equal_ignoring_case(kind, "identified")) e.kind = EventKind::identified;
    else if (other) return std::nullopt;
    else throw fail("bad kind '" + core::printable(kind) + "' (onset, identified or end)");
  }
  e.t_onset_estimate = c_onset_ != npos ? number(c_onset_, "t_onset_estimate") : std::numeric_limits<double>::quiet_NaN();
  e.t_detect = number(c_detect_, "t_detect");
  if (!std::isfinite(e.t_detect)) throw fail("bad t_detect '" + core::printable(fields[c_detect_]) + "'");
  if (c_id_ != npos) {
    const long long id = integer(fields[c_id_], "event");
    if (id < 1) throw fail("bad event number " + std::to_string(id));
    e.id = static_cast<std::uint64_t>(id);
  }
  const long long n = static_cast<long long>(joints_);
  if (!(other && field(fields[c_link_]).empty())) {
    const long long link = integer(fields[c_link_], "link");
    if (link < (other ? 0 : 1) || (n > 0 && link > n))
      throw fail("link " + std::to_string(link) + " out of 1.." + std::to_string(n));
    e.link = static_cast<int>(link);
  }
  std::string_view list = c_joints_ != npos ? field(fields[c_joints_]) : std::string_view();
  while (!list.empty()) {
    const std::size_t semi = list.find(';');
    const long long j = integer(list.substr(0, semi), "joint in joints");
    if (j < 1 || (n > 0 && j > n)) throw fail("joint " + std::to_string(j) + " out of 1.." + std::to_string(n));
    e.joints.push_back(static_cast<int>(j));
    if (semi == std::string_view::npos) break;
    list.remove_prefix(semi + 1);
  }
  if (e.joints.empty() && !other) throw fail("no joints in an event");
  e.t_end = std::numeric_limits<double>::quiet_NaN();
  if (e.kind == EventKind::end && c_end_ != npos && !field(fields[c_end_]).empty()) e.t_end = number(c_end_, "t_end");
  if (e.kind == EventKind::end && c_ended_by_ != npos) {
    const std::string_view by = field(fields[c_ended_by_]);
    if (by == "release") e.ended_by = EndReason::release;
    else if (by == "next") e.ended_by = EndReason::next;
    else if (by == "eof") e.ended_by = EndReason::eof;
    else if (by == "signal") e.ended_by = EndReason::signal;
    else if (by == "clock_step") e.ended_by = EndReason::clock_step;
    else if (!by.empty()) throw fail("bad ended_by '" + core::printable(by) + "'");
  }
  for (std::size_t c : c_peaks_) e.peaks.push_back(number(c, "peak"));
  if (c_contact_.front() != npos) {
    const std::string_view event_class = field(fields[c_contact_.front()]);
    if (!event_class.empty() && event_class != "contact" && event_class != "collision")
      throw fail("bad class '" + core::printable(event_class) + "' (contact, collision or empty)");
    e.contact.event_class = std::string(event_class);
  }
  for (std::size_t k = 0; k < kContactNumbers; ++k) {
    const std::size_t c = c_contact_[k + 1];
    if (c != npos && !field(fields[c]).empty()) *contact_number(e.contact, k) = number(c, kContactColumns[k + 1]);
  }
  if (c_contact_.back() != npos) e.contact.seen = std::string(field(fields[c_contact_.back()]));
  auto probability = [&](std::string_view text, const char* what) {
    auto value = stream::parse_double(field(text));
    if (!value || !(*value >= 0 && *value <= 1))
      throw fail(std::string("bad ") + what + " '" + core::printable(text) + "' (a probability, 0..1)");
    return *value;
  };
  auto link_number = [&](std::string_view text, const char* what) {
    const long long link = integer(text, what);
    if (link < 1 || (n > 0 && link > n)) throw fail("link " + std::to_string(link) + " out of 1.." + std::to_string(n));
    return static_cast<int>(link);
  };
  if (c_links_[0] != npos)
    for (std::string_view rest = field(fields[c_links_[0]]); !rest.empty();) {
      const std::size_t semi = rest.find(';');
      const std::string_view pair = rest.substr(0, semi);
      const std::size_t colon = pair.find(':');
      if (colon == std::string_view::npos) throw fail("bad links entry '" + core::printable(pair) + "' (link:probability)");
      e.contact.link_probabilities.emplace_back(link_number(pair.substr(0, colon), "link in links"),
                                                probability(pair.substr(colon + 1), "probability in links"));
      if (semi == std::string_view::npos) break;
      rest.remove_prefix(semi + 1);
    }
  if (c_links_[1] != npos)
    for (std::string_view rest = field(fields[c_links_[1]]); !rest.empty();) {
      const std::size_t semi = rest.find(';');
      e.contact.link_set.push_back(link_number(rest.substr(0, semi), "link in link_set"));
      if (semi == std::string_view::npos) break;
      rest.remove_prefix(semi + 1);
    }
  if (c_links_[2] != npos && !field(fields[c_links_[2]]).empty())
    e.contact.set_probability = probability(fields[c_links_[2]], "p_set");
  if (c_links_[3] != npos && !field(fields[c_links_[3]]).empty())
    e.contact.collision_probability = probability(fields[c_links_[3]], "p_collision");
  if (c_peak_force_sd_ != npos && !field(fields[c_peak_force_sd_]).empty()) {
    e.contact.peak_force_sd = number(c_peak_force_sd_, kPeakForceSdColumn);
    if (!(e.contact.peak_force_sd >= 0))
      throw fail(std::string("bad ") + kPeakForceSdColumn + " '" + core::printable(fields[c_peak_force_sd_]) +
                 "' (a standard deviation, >= 0)");
  }
  return e;
}

std::vector<Event> read_events(const std::string& path) {
  auto reader = EventReader::open(path);
  std::vector<Event> events;
  bool pending = false;  // the last event has an onset row and no end row yet
  while (auto e = reader->next()) {
    if (e->kind == EventKind::onset) {
      events.push_back(*e);
      events.back().t_end = std::numeric_limits<double>::quiet_NaN();
      events.back().ended_by = EndReason::none;
      pending = true;
    } else if (e->kind == EventKind::identified) {
      // What identification found at detection: the link and contact of the open event.
      if (pending && events.back().id == e->id) {
        events.back().link = e->link;
        events.back().contact = e->contact;
      }
    } else if (pending && events.back().id == e->id) {
      events.back() = *e;
      pending = false;
    } else {
      // An end row without its onset row (a file that starts mid-event): keep it.
      events.push_back(*e);
      pending = false;
    }
  }
  return events;
}

}  // namespace momentum::detect
