#include "momentum/can/cycle.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/core/text.hpp"

namespace momentum::can {

namespace {

using core::trim;

bool valid_column_name(std::string_view s) {
  if (s.empty()) return false;
  for (char c : s)
    if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}

// Stream column families in the order of the design notes.
constexpr std::string_view kFamilies[] = {"q", "dq", "ddq", "i", "tau_m"};

// (family rank, joint) of a name like "dq3"; rank -1 if it is not such a name.
std::pair<int, long> column_rank(std::string_view name) {
  std::size_t digits = name.size();
  while (digits > 0 && name[digits - 1] >= '0' && name[digits - 1] <= '9') --digits;
  if (digits == name.size() || digits == 0 || name[digits] == '0') return {-1, 0};
  const std::string_view family = name.substr(0, digits);
  for (int r = 0; r < static_cast<int>(std::size(kFamilies)); ++r)
    if (family == kFamilies[r]) return {r, std::stol(std::string(name.substr(digits)))};
  return {-1, 0};
}

}  // namespace

std::vector<ColumnSource> parse_column_map(std::string_view text, std::string_view name, const Database& db) {
  std::vector<ColumnSource> out;
  std::uint64_t line_no = 0;
  while (!text.empty()) {
    const std::size_t nl = text.find('\n');
    std::string_view line = text.substr(0, nl);
    text = nl == std::string_view::npos ? std::string_view() : text.substr(nl + 1);
    ++line_no;
    line = trim(line);
    if (line.empty() || line.front() == '#') continue;
    auto fail = [&](const std::string& message) { throw Error(located(name, line_no, message)); };
    const std::size_t eq = line.find('=');
    if (eq == std::string_view::npos) fail("expected 'column = Message.Signal'");
    const std::string_view column = trim(line.substr(0, eq));
    const std::string_view source = trim(line.substr(eq + 1));
    if (!valid_column_name(column)) fail("bad column name '" + std::string(column) + "'");
    if (column == "t") fail("column 't' is the cycle time and cannot be mapped");
    const std::size_t dot = source.find('.');
    if (dot == std::string_view::npos) fail("expected Message.Signal after '='");
    const std::string_view message_name = trim(source.substr(0, dot));
    const std::string_view signal_name = trim(source.substr(dot + 1));
    const Message* m = db.find_name(message_name);
    if (m == nullptr) fail("no message '" + std::string(message_name) + "' in the dbc");
    const int s = m->find(signal_name);
    if (s < 0) fail("message " + m->name + " has no signal '" + std::string(signal_name) + "'");
    for (const ColumnSource& c : out)
      if (c.column == column) fail("column '" + std::string(column) + "' mapped twice");
    out.push_back({std::string(column), m, s});
  }
  if (out.empty()) throw Error(std::string(name) + ": no column mapped");
  return out;
}

std::vector<ColumnSource> read_column_map(const std::string& path, const Database& db) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open: " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  return parse_column_map(text.str(), path, db);
}

std::vector<ColumnSource> columns_from_signal_names(const Database& db) {
  std::vector<ColumnSource> out;
  for (const Message& m : db.messages()) {
    for (std::size_t i = 0; i < m.signals.size(); ++i) {
      const std::string& name = m.signals[i].name;
      if (column_rank(name).first < 0) continue;
      for (const ColumnSource& c : out)
        if (c.column == name)
          throw Error("signal " + name + " is in messages " + c.message->name + " and " + m.name +
                      ": say which with --map");
      out.push_back({name, &m, static_cast<int>(i)});
    }
  }
  std::stable_sort(out.begin(), out.end(), [](const ColumnSource& a, const ColumnSource& b) {
    return column_rank(a.column) < column_rank(b.column);
  });
  return out;
}

bool valid_period(double period, std::string* why) {
  if (period >= kMinPeriod && period <= kMaxPeriod) return true;  // false for NaN
  if (why != nullptr)
    *why = "the cycle period must be " + core::significant(kMinPeriod, 3) + " to " + core::significant(kMaxPeriod, 3) +
           " s, not " + core::significant(period, 6);
  return false;
}

bool CycleOptions::IsValid(std::string* why) const {
  auto no = [&](const char* message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (hold < 0) return no("hold must be 0 or more cycles");
  if (boundary == CycleBoundary::period) return valid_period(period, why);
  return true;
}

CycleAssembler::CycleAssembler(const Database& db, std::vector<ColumnSource> sources, CycleOptions options)
    : db_(&db), sources_(std::move(sources)), options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw Error(why);
  columns_.push_back("t");
  message_map_.assign(db.messages().size(), -1);
  std::size_t most = 0;
  for (const Message& m : db.messages()) most = std::max(most, m.signals.size());
  decoded_.resize(most);
  for (std::size_t c = 0; c < sources_.size(); ++c) {
    const ColumnSource& src = sources_[c];
    const Message* base = db.messages().data();
    if (src.message == nullptr || src.message < base || src.message >= base + db.messages().size() ||
        src.signal < 0 || static_cast<std::size_t>(src.signal) >= src.message->signals.size())
      throw Error("column " + src.column + ": source is not a signal of this dbc");
    const std::size_t mi = static_cast<std::size_t>(src.message - base);
    if (message_map_[mi] < 0) {
      message_map_[mi] = static_cast<std::int32_t>(signal_column_.size());
      signal_column_.resize(signal_column_.size() + src.message->signals.size(), -1);
    }
    signal_column_[static_cast<std::size_t>(message_map_[mi] + src.signal)] = static_cast<std::int32_t>(c);
    columns_.push_back(src.column);
  }
  value_.assign(sources_.size(), std::numeric_limits<double>::quiet_NaN());
  fresh_.assign(sources_.size(), 0);
  age_.assign(sources_.size(), 0);
  ever_.assign(sources_.size(), 0);
  for (auto& row : rows_) row.assign(columns_.size(), std::numeric_limits<double>::quiet_NaN());
}

void CycleAssembler::open_cycle(double t) {
  open_ = true;
  started_ = true;
  any_value_ = false;
  fresh_count_ = 0;
  cycle_t_ = t;
  std::fill(fresh_.begin(), fresh_.end(), 0);
}

bool CycleAssembler::close_cycle() {
  if (!open_) return false;
  open_ = false;
  std::vector<double>& row = rows_[ready_++];
  row[0] = cycle_t_;
  bool complete = true;
  for (std::size_t c = 0; c < sources_.size(); ++c) {
    if (fresh_[c]) {
      age_[c] = 0;
      row[c + 1] = value_[c];
      continue;
    }
    complete = false;
    ++age_[c];
    if (ever_[c] && age_[c] <= options_.hold) {
      row[c + 1] = value_[c];
      ++stats_.held_values;
    } else {
      row[c + 1] = std::numeric_limits<double>::quiet_NaN();
      ++stats_.missing_values;
    }
  }
  if (complete) {
    ++stats_.complete_cycles;
  } else {
    ++stats_.incomplete_cycles;
  }
  return true;
}

void CycleAssembler::take(const Frame& frame, const Message& message) {
  const std::size_t mi = static_cast<std::size_t>(&message - db_->messages().data());
  bool truncated = false;
  const std::int32_t base = message_map_[mi];
  if (base < 0 || !started_) {
    // Not mapped, or before the first cycle: only the length check is of interest.
    if (frame.len < message.length) ++stats_.short_frames;
    return;
  }
  const std::size_t n = decode(message, frame, decoded_.data(), &truncated);
  if (truncated) ++stats_.short_frames;
  for (std::size_t k = 0; k < n; ++k) {
    const std::int32_t c = signal_column_[static_cast<std::size_t>(base) + decoded_[k].index];
    if (c < 0) continue;
    const auto column = static_cast<std::size_t>(c);
    if (!open_) {
      // The cycle's row is out (every signal was in): a second value of the cycle comes too
      // late for it. Counted as repeated, and not kept for the next cycle (it is this one's).
      ++stats_.repeated_values;
      continue;
    }
    if (fresh_[column]) ++stats_.repeated_values;
    else ++fresh_count_;
    value_[column] = decoded_[k].value;
    fresh_[column] = 1;
    ever_[column] = 1;
    any_value_ = true;
  }
  // Every mapped signal of the cycle is in: nothing more can change its row, so it goes out
  // now rather than at the next boundary (one cycle period later).
  if (open_ && fresh_count_ == sources_.size()) close_cycle();
}

std::size_t CycleAssembler::add(const Frame& frame) {
  ready_ = 0;
  ++stats_.frames;
  if (frame.error) {
    ++stats_.error_frames;
    return 0;
  }
  if (frame.rtr) {
    ++stats_.remote_frames;
    return 0;
  }
  const std::uint32_t key = frame.key();
  const double t = frame.has_time ? frame.seconds() : std::numeric_limits<double>::quiet_NaN();
  switch (options_.boundary) {
    case CycleBoundary::sync:
      if (key == options_.sync_key) {
        ++stats_.sync_frames;
        close_cycle();
        open_cycle(t);
        return ready_;
      }
      break;
    case CycleBoundary::message:
      if (key == options_.message_key) {
        close_cycle();
        open_cycle(t);
      }
      break;
    case CycleBoundary::period: {
      if (!frame.has_time) throw Error("cycles of a fixed period need timestamps (capture with candump -t a or -L)");
      if (!have_t0_) {
        have_t0_ = true;
        t0_ns_ = frame.time_ns;
        period_index_ = 0;
        open_cycle(frame.seconds());
        break;
      }
      // Whole nanoseconds, so that cycle k starts at exactly t0 + k * period.
      const std::int64_t period_ns = std::max<std::int64_t>(1, std::llround(options_.period * 1e9));
      const std::int64_t index = (frame.time_ns - t0_ns_) >= 0 ? (frame.time_ns - t0_ns_) / period_ns
                                                                : -((t0_ns_ - frame.time_ns + period_ns - 1) / period_ns);
      if (index > period_index_) {
        // A period whose row went out early is not empty; an open one without a value is.
        if (open_ && !(any_value_ && close_cycle())) ++stats_.empty_periods;
        stats_.empty_periods += static_cast<std::uint64_t>(index - period_index_ - 1);
        period_index_ = index;
        Frame start;
        start.time_ns = t0_ns_ + index * period_ns;
        open_cycle(start.seconds());
      }
      break;
    }
  }
  const Message* m = db_->find(key);
  if (m == nullptr) {
    ++stats_.unknown_ids;
    if (!started_) ++stats_.before_first_cycle;
    return ready_;
  }
  ++stats_.decoded;
  if (!started_) ++stats_.before_first_cycle;
  take(frame, *m);
  return ready_;
}

bool CycleAssembler::finish() {
  ready_ = 0;
  if (!open_ || !any_value_) {
    open_ = false;
    return false;
  }
  return close_cycle();
}

}  // namespace momentum::can
