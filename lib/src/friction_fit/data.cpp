#include "momentum/friction_fit/data.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "momentum/core/statistics.hpp"

#include "momentum/core/error.hpp"
#include "momentum/stream/columns.hpp"
#include "momentum/stream/non_finite.hpp"

namespace momentum::friction_fit {

std::size_t JointSeries::scored_count() const {
  return static_cast<std::size_t>(std::count(scored.begin(), scored.end(), std::uint8_t{1}));
}

double JointSeries::median_dt() const {
  if (t.size() < 2) return 0;
  std::vector<double> dt(t.size() - 1);
  for (std::size_t k = 1; k < t.size(); ++k) dt[k - 1] = t[k] - t[k - 1];
  auto mid = dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2);
  std::nth_element(dt.begin(), mid, dt.end());
  return *mid;
}

bool SelectOptions::IsValid(std::string* why) const {
  if (!(skip >= 0) || !std::isfinite(skip)) return invalid(why, "skip must be a finite number of seconds >= 0");
  if (window_begin && !std::isfinite(*window_begin)) return invalid(why, "window start is not finite");
  if (window_end && !std::isfinite(*window_end)) return invalid(why, "window end is not finite");
  if (window_begin && window_end && !(*window_begin < *window_end))
    return invalid(why, "window start must be before its end");
  for (int j : joints)
    if (j < 1) return invalid(why, "joint numbers start at 1");
  if (!(gap_factor > 1)) return invalid(why, "gap factor must be > 1");
  if (!(thin_window > 0) || !std::isfinite(thin_window) || !(thin_warmup >= 0) || !(thin_warmup < thin_window))
    return invalid(why, "thinning windows must be longer than their warm-up");
  return true;
}

namespace {

// `into` then `more`, column by column; null when either has none or their joints differ.
std::shared_ptr<const Positions> append_positions(const JointSeries& into, const JointSeries& more) {
  if (!into.has_positions() || !more.has_positions() || into.positions->size() != more.positions->size())
    return nullptr;
  auto out = std::make_shared<Positions>(into.positions->size());
  for (std::size_t j = 0; j < out->size(); ++j) {
    auto& q = (*out)[j];
    q.reserve((*into.positions)[j].size() + (*more.positions)[j].size());
    q.insert(q.end(), (*into.positions)[j].begin(), (*into.positions)[j].end());
    q.insert(q.end(), (*more.positions)[j].begin(), (*more.positions)[j].end());
  }
  return out;
}

void append_samples(JointSeries& into, const JointSeries& more) {
  double step = into.median_dt();
  if (!(step > 0)) step = more.median_dt();
  if (!(step > 0)) step = 1.0;
  const double shift = into.t.back() + step - more.t.front();
  const std::size_t total = into.size() + more.size();
  into.t.reserve(total);
  into.dq.reserve(total);
  into.r.reserve(total);
  into.restart.reserve(total);
  into.scored.reserve(total);
  for (std::size_t k = 0; k < more.size(); ++k) {
    into.t.push_back(more.t[k] + shift);
    into.dq.push_back(more.dq[k]);
    into.r.push_back(more.r[k]);
    into.restart.push_back(k == 0 ? 2 : more.restart[k]);
    into.scored.push_back(more.scored[k]);
  }
  if (into.source != more.source) into.source += ", " + more.source;
}

}  // namespace

void append_series(JointSeries& into, const JointSeries& more) {
  if (more.size() == 0) return;
  if (into.size() == 0) {
    into = more;
    return;
  }
  into.positions = append_positions(into, more);  // one log without positions: none at all
  append_samples(into, more);
}

void append_log(std::vector<JointSeries>& into, const std::vector<JointSeries>& more) {
  if (into.empty()) {
    into = more;
    return;
  }
  if (into.size() != more.size()) throw Error("append_log: the logs have different joints");
  // Joints that shared their positions in both logs share the appended ones too.
  std::vector<std::pair<std::pair<const Positions*, const Positions*>, std::shared_ptr<const Positions>>> done;
  for (std::size_t i = 0; i < into.size(); ++i) {
    if (more[i].size() == 0) continue;
    if (into[i].size() == 0) {
      into[i] = more[i];
      continue;
    }
    const std::pair<const Positions*, const Positions*> key{into[i].positions.get(), more[i].positions.get()};
    std::shared_ptr<const Positions> positions;
    bool found = false;
    for (const auto& [k, p] : done)
      if (k == key) {
        positions = p;
        found = true;
      }
    if (!found) {
      positions = append_positions(into[i], more[i]);
      done.push_back({key, positions});
    }
    into[i].positions = std::move(positions);
    append_samples(into[i], more[i]);
  }
}

namespace {

// Keeps the samples k for which keep(k) holds, in place, in every column of the series.
template <class Keep>
void keep_samples(JointSeries& s, Keep keep) {
  std::size_t out = 0;
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (!keep(k)) continue;
    s.t[out] = s.t[k];
    s.dq[out] = s.dq[k];
    s.r[out] = s.r[k];
    s.restart[out] = s.restart[k];
    s.scored[out] = s.scored[k];
    ++out;
  }
  for (auto* v : {&s.t, &s.dq, &s.r}) v->resize(out);
  for (auto* v : {&s.restart, &s.scored}) v->resize(out);
}

// The same for the positions read (one table for every joint, with its own times).
template <class Keep>
void keep_positions(std::vector<double>& t, Positions& q, Keep keep) {
  std::size_t out = 0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (!keep(t[k])) continue;
    t[out] = t[k];
    for (auto& column : q) column[out] = column[k];
    ++out;
  }
  t.resize(out);
  for (auto& column : q) column.resize(out);
}

}  // namespace

std::size_t thin_to_budget(std::vector<JointSeries>& series, std::size_t max_samples) {
  if (max_samples == 0 || series.empty()) return 0;
  const std::size_t first_size = series.front().size();
  // Positions already thinned: (the positions before, the samples kept, the positions after).
  struct Thinned {
    std::shared_ptr<const Positions> before;
    std::vector<std::uint8_t> keep;
    std::shared_ptr<const Positions> after;
  };
  std::vector<Thinned> thinned;
  for (auto& s : series) {
    if (s.size() <= max_samples) continue;
    std::vector<std::size_t> starts;  // of the segments, then the end
    for (std::size_t k = 0; k < s.size(); ++k)
      if (k == 0 || s.restart[k] == 2) starts.push_back(k);
    const std::size_t segments = starts.size();
    starts.push_back(s.size());
    auto kept_with = [&](std::size_t stride) {
      std::size_t n = 0;
      for (std::size_t i = 0; i < segments; i += stride) n += starts[i + 1] - starts[i];
      return n;
    };
    std::size_t stride = 1;
    while (stride < segments && kept_with(stride) > max_samples) stride *= 2;
    if (stride == 1) continue;
    std::vector<std::uint8_t> keep(s.size(), 0);
    for (std::size_t i = 0; i < segments; i += stride)
      std::fill(keep.begin() + static_cast<std::ptrdiff_t>(starts[i]),
                keep.begin() + static_cast<std::ptrdiff_t>(starts[i + 1]), std::uint8_t{1});
    if (s.has_positions()) {
      std::shared_ptr<const Positions> after;
      for (const auto& done : thinned)
        if (done.before == s.positions && done.keep == keep) after = done.after;
      if (!after) {
        auto own = std::make_shared<Positions>(s.positions->size());
        for (std::size_t c = 0; c < own->size(); ++c)
          for (std::size_t k = 0; k < keep.size(); ++k)
            if (keep[k]) (*own)[c].push_back((*s.positions)[c][k]);
        after = own;
        thinned.push_back({s.positions, keep, after});
      }
      s.positions = after;
    }
    keep_samples(s, [&](std::size_t k) { return keep[k] != 0; });
  }
  return first_size - series.front().size();
}

double estimate_velocity_noise(const JointSeries& s) {
  if (s.size() < 3) return 0;
  std::vector<double> d2;
  d2.reserve(s.size() - 2);
  for (std::size_t k = 1; k + 1 < s.size(); ++k)
    if (s.restart[k] < 2 && s.restart[k + 1] < 2) d2.push_back(std::abs(s.dq[k + 1] - 2 * s.dq[k] + s.dq[k - 1]));
  return core::white_noise_from_second_differences(d2);
}

std::size_t exclude_slow_samples(JointSeries& s, double min_speed, double settle) {
  std::size_t removed = 0;
  double last_slow = -std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (std::abs(s.dq[k]) < min_speed) last_slow = s.t[k];
    if (s.t[k] - last_slow <= settle && s.scored[k]) {
      s.scored[k] = 0;
      ++removed;
    }
  }
  return removed;
}


std::vector<JointSeries> read_series(stream::Reader& in, const SelectOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw Error(in.name() + ": " + why);
  const std::size_t t_col = in.require("t");
  std::vector<int> joints = options.joints;
  if (joints.empty()) {
    const std::size_t n = std::min(stream::count_joint_columns(in.columns(), "dq"),
                                   stream::count_joint_columns(in.columns(), "r"));
    if (n == 0) throw Error(in.name() + ": no joint has both dq<j> and r<j> columns (run mo-observe first)");
    for (std::size_t j = 1; j <= n; ++j) joints.push_back(static_cast<int>(j));
  }
  std::vector<JointSeries> series(joints.size());
  std::vector<std::size_t> dq_col(joints.size()), r_col(joints.size());
  for (std::size_t i = 0; i < joints.size(); ++i) {
    const std::string j = std::to_string(joints[i]);
    dq_col[i] = in.require("dq" + j);
    r_col[i] = in.require("r" + j);
    series[i].joint = joints[i];
    series[i].source = in.name();
  }
  const auto restart_col = in.find("restart");
  std::vector<std::size_t> q_col;
  for (std::size_t k = 1; k <= stream::count_joint_columns(in.columns(), "q"); ++k)
    q_col.push_back(in.require("q" + std::to_string(k)));
  // The positions of every row a joint may keep, once for all joints (with their times); each
  // joint gets them (shared) at the end.
  Positions table(q_col.size());
  std::vector<double> table_t;

  std::vector<std::uint8_t> pending(joints.size(), 1);  // next good row restarts the joint
  bool have_time = false;
  double t_first = 0, t_last = 0;
  // Thinning (max_samples): windows whose index is a multiple of `stride` are kept.
  std::uint64_t stride = 1;
  auto window_of = [&](double t) { return static_cast<std::uint64_t>(std::floor((t - t_first) / options.thin_window)); };
  double shift = 0, last_step = 0;  // after a clock step back, stream time + shift continues t_last
  stream::NonFiniteRows non_finite;
  while (const double* row = in.next()) {
    if (have_time && in.time_mark() == stream::TimeMark::clock_step) {
      // The stream's time policy kept this row as the start of a new time line: append it
      // like a log of its own (append_series), the next row restarting every joint.
      in.warn_clock_step("the rows from here are fitted as a log of their own");
      shift = t_last + (last_step > 0 ? last_step : 1.0) - row[t_col];
      std::fill(pending.begin(), pending.end(), 1);
    }
    const double t = row[t_col] + shift;
    if (!in.follows_in_time(t, have_time ? t_last : -INFINITY)) continue;
    if (!have_time) t_first = t;
    if (have_time) last_step = t - t_last;
    have_time = true;
    t_last = t;
    const double stream_t = row[t_col];  // --window is in the stream's own time
    if (options.window_end && stream_t > *options.window_end) continue;
    if (stride > 1 && window_of(t) % stride != 0) continue;
    const bool restart_row = restart_col && row[*restart_col] != 0;
    const bool counts = t >= t_first + options.skip &&
                        (!options.window_begin || stream_t >= *options.window_begin);
    bool positions_ok = true;
    for (std::size_t c : q_col) positions_ok = positions_ok && std::isfinite(row[c]);
    if (positions_ok && !q_col.empty()) {
      table_t.push_back(t);
      for (std::size_t c = 0; c < q_col.size(); ++c) table[c].push_back(row[q_col[c]]);
    }
    bool row_left_out = false;
    for (std::size_t i = 0; i < joints.size(); ++i) {
      const double dq = row[dq_col[i]], r = row[r_col[i]];
      if (!std::isfinite(dq) || !std::isfinite(r) || !positions_ok) {
        pending[i] = 1;
        row_left_out = true;
        continue;
      }
      auto& s = series[i];
      s.t.push_back(t);
      s.dq.push_back(dq);
      s.r.push_back(r);
      s.restart.push_back(s.t.size() == 1 ? 2 : (pending[i] || restart_row ? 1 : 0));
      s.scored.push_back(counts ? 1 : 0);
      pending[i] = 0;
    }
    if (row_left_out) non_finite.note(in, stream_t);
    // Never below one window: a first window longer than the budget is kept whole.
    if (options.max_samples > 0 && !series.empty() && series.front().size() > options.max_samples &&
        window_of(t) >= stride) {
      stride *= 2;
      for (auto& s : series) keep_samples(s, [&](std::size_t k) { return window_of(s.t[k]) % stride == 0; });
      keep_positions(table_t, table, [&](double t) { return window_of(t) % stride == 0; });
    }
  }
  if (non_finite.count() > 0) warn(in.name() + ": " + non_finite.summary() + " for some of the joints fitted");
  if (stride > 1) {
    for (auto& s : series) {
      double window_start = s.t.empty() ? 0 : s.t.front();
      for (std::size_t k = 1; k < s.size(); ++k) {
        if (window_of(s.t[k]) != window_of(s.t[k - 1])) {
          s.restart[k] = 2;
          window_start = s.t[k];
        }
        if (s.t[k] - window_start < options.thin_warmup) s.scored[k] = 0;
      }
    }
  }
  if (!q_col.empty()) {
    // Each joint's positions: the table itself when the joint kept every row of it (shared),
    // else the rows it kept (every sample a joint keeps has its row in the table).
    for (auto& column : table) column.shrink_to_fit();
    auto shared = std::make_shared<const Positions>(std::move(table));
    for (auto& s : series) {
      if (s.t == table_t) {
        s.positions = shared;
        continue;
      }
      auto own = std::make_shared<Positions>(shared->size());
      for (auto& column : *own) column.reserve(s.size());
      std::size_t row = 0;
      for (std::size_t k = 0; k < s.size(); ++k) {
        while (row < table_t.size() && table_t[row] < s.t[k]) ++row;
        for (std::size_t c = 0; c < own->size(); ++c) (*own)[c].push_back((*shared)[c][row]);
      }
      s.positions = std::move(own);
    }
  }
  for (auto& s : series) {
    for (auto* v : {&s.t, &s.dq, &s.r}) v->shrink_to_fit();
    for (auto* v : {&s.restart, &s.scored}) v->shrink_to_fit();
    // Gaps restart the observer; mark them so the model's filter restarts too.
    const double limit = options.gap_factor * s.median_dt();
    for (std::size_t k = 1; k < s.size(); ++k)
      if (s.t[k] - s.t[k - 1] > limit && s.restart[k] == 0) s.restart[k] = 1;
    if (s.scored_count() == 0)
      throw Error(in.name() + ": joint " + std::to_string(s.joint) +
                  ": no sample left to fit (check --skip and --window against the stream's time)");
  }
  return series;
}

}  // namespace momentum::friction_fit
