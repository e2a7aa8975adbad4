#include "momentum/observer/observe_stream.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "momentum/core/number.hpp"
#include "momentum/stream/error.hpp"
#include "momentum/stream/format.hpp"

namespace momentum::observer {
namespace {

using core::exact;

// The largest j for which a column prefix<j> exists (j >= 1), or 0.
int largest_joint_column(const stream::Reader& in, const std::string& prefix) {
  int largest = 0;
  for (const auto& name : in.columns()) {
    if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string digits = name.substr(prefix.size());
    if (digits.find_first_not_of("0123456789") != std::string::npos || digits[0] == '0' || digits.size() > 6) continue;
    largest = std::max(largest, std::stoi(digits));
  }
  return largest;
}

}  // namespace

namespace {
MomentumObserver make_observer(stream::Reader& in, const model::Model& model,
                               const ObserveStreamOptions& options) {
  const int n = model.nq;
  auto fail = [&](const std::string& message) { throw Error(located(in.name(), 0, message)); };
  const std::string chain = "the profile's chain " + model.root + ".." + model.tip + " has " +
                            std::to_string(n) + " joint" + (n == 1 ? "" : "s");
  // Joint columns: q1..qN, dq1..dqN, and tau_m<j> or i<j>; N must be the chain's nq.
  // The stream's joint count is the largest j among q<j>, dq<j>, tau_m<j>, i<j>; columns
  // missing below it are reported by name afterwards.
  int found = 0;
  for (const char* prefix : {"q", "dq", "tau_m", "i"}) found = std::max(found, largest_joint_column(in, prefix));
  if (found == 0) in.require("q1");
  if (found != n) {
    fail("the stream has " + std::to_string(found) + " joint" + (found == 1 ? "" : "s") +
         " (columns up to q" + std::to_string(found) + ", dq" + std::to_string(found) + ") but " + chain);
  }
  for (int j = 1; j <= n; ++j) {
    in.require("q" + std::to_string(j));
    in.require("dq" + std::to_string(j));
  }
  return MomentumObserver(model, options.observer, options.friction);
}
}  // namespace

StreamObserver::StreamObserver(stream::Reader& in, const model::Model& model,
                               const ObserveStreamOptions& options)
    : in_(in), model_(model), options_(options), observer_(make_observer(in, model, options)) {
  const int n = model.nq;
  t_index_ = in.require("t");
  q_index_.resize(n);
  dq_index_.resize(n);
  torque_index_.resize(n);
  torque_scale_.resize(n);
  for (int j = 0; j < n; ++j) {
    const std::string k = std::to_string(j + 1);
    q_index_[j] = *in.find("q" + k);
    dq_index_[j] = *in.find("dq" + k);
    if (auto tau = in.find("tau_m" + k)) {
      torque_index_[j] = *tau;
      torque_scale_[j] = 1.0;
    } else if (auto current = in.find("i" + k)) {
      torque_index_[j] = *current;
      torque_scale_[j] = model.k_i.size() == n ? model.k_i[j] : 1.0;
    } else {
      throw Error(located(in.name(), 0, "missing column 'tau_m" + k + "' (or 'i" + k + "' with the profile's k_i)"));
    }
  }
  // Output columns: the input's, then those we add (or overwrite where the input has them).
  columns_ = in.columns();
  auto place = [&](const std::string& name) {
    if (auto existing = in.find(name)) return *existing;
    columns_.push_back(name);
    return columns_.size() - 1;
  };
  for (int j = 0; j < n; ++j) r_out_.push_back(place("r" + std::to_string(j + 1)));
  if (observer_.has_friction()) {
    for (int j = 0; j < n; ++j) tau_f_out_.push_back(place("tau_f" + std::to_string(j + 1)));
    for (int j = 0; j < n; ++j) mu_out_.push_back(place("mu" + std::to_string(j + 1)));
  }
  if (options.restart_column) restart_out_ = place("restart");
}

ObserveStreamSummary StreamObserver::run(stream::Writer& out) {
  const int n = model_.nq;
  const bool friction = observer_.has_friction();
  out.header(columns_);
  in_.on_comment([&out](std::string_view text) { out.comment(text); });
  const std::size_t width_in = in_.columns().size();
  std::vector<double> row_out(columns_.size());
  std::vector<double> q(n), dq(n), tau(n), r(n), tau_f(n), mu(n);
  ObserveStreamSummary summary;
  std::string bad_run_start;
  // The previous row as read, to tell exact duplicates from other rows out of time order.
  std::vector<double> previous_row(width_in);
  bool have_previous_row = false;
  constexpr std::uint64_t kReportedPerKind = 5;
  std::string first_skipped;
  std::uint64_t rows = 0;
  double t = 0;

  // Counts, reports (the first few of each kind) and skips a row whose time does not increase.
  auto skip = [&](bool duplicate, const std::string& where, const std::string& message) {
    if (options_.strict) throw Error(where + ": " + message);
    ++summary.rejected_rows;
    std::uint64_t& count = duplicate ? summary.duplicate_rows : summary.out_of_order_rows;
    ++count;
    if (first_skipped.empty()) first_skipped = where;
    if (count <= kReportedPerKind) warn_row(duplicate ? "duplicate row" : "time out of order", where + ": " + message + ": skipped");
  };

  // Steps the observer with one row and writes it. `where`: its location, or nullptr for the
  // row the reader returned last.
  auto process = [&](const double* row, bool duplicate, const std::string* where) {
    auto here = [&] { return where ? *where : in_.where(); };
    t = row[t_index_];
    for (int j = 0; j < n; ++j) {
      q[j] = row[q_index_[j]];
      dq[j] = row[dq_index_[j]];
      tau[j] = torque_scale_[j] * row[torque_index_[j]];
    }
    const double previous_t = observer_.last_time();
    const SampleStatus status = observer_.step(t, q.data(), dq.data(), tau.data(), r.data(),
                                               tau_f.data(), mu.data());
    switch (status) {
      case SampleStatus::time_not_increasing:
        skip(duplicate, here(),
             std::string(duplicate ? "duplicate row" : "time does not increase") + ": t=" + exact(t) +
                 " after t=" + exact(previous_t));
        return;
      case SampleStatus::bridged:
        ++summary.bridged_gaps;
        summary.longest_bridge = std::max(summary.longest_bridge, observer_.last_gap());
        break;
      case SampleStatus::invalid:
        if (bad_run_start.empty()) bad_run_start = here();
        ++summary.invalid_rows;
        break;
      case SampleStatus::restarted_after_gap:
        ++summary.restarts;
        warn(here() + ": observer restarted at t=" + exact(t) + " after a gap of " +
             short_number(observer_.last_gap()) + " s (median dt " +
             short_number(observer_.median_dt()) + " s)" +
             (observer_.last_gap_mismatched()
                  ? ": joint " + std::to_string(observer_.mismatch_joint() + 1) +
                        "'s position moved " + short_number(observer_.mismatch()) +
                        " away from its integrated velocity"
                  : std::string()));
        break;
      case SampleStatus::restarted_after_bad: {
        ++summary.restarts;
        const std::uint64_t bad = observer_.last_bad_run();
        warn(here() + ": observer restarted at t=" + exact(t) + " after " +
             std::to_string(bad) + " row" + (bad == 1 ? "" : "s") + " with nan or inf from " +
             bad_run_start);
        bad_run_start.clear();
        break;
      }
      case SampleStatus::started:
        bad_run_start.clear();
        break;
      case SampleStatus::ok:
        break;
    }
    std::copy(row, row + width_in, row_out.begin());
    for (int j = 0; j < n; ++j) row_out[r_out_[j]] = r[j];
    if (friction) {
      for (int j = 0; j < n; ++j) {
        row_out[tau_f_out_[j]] = tau_f[j];
        row_out[mu_out_[j]] = mu[j];
      }
    }
    if (restart_out_) {
      row_out[*restart_out_] = status == SampleStatus::ok || status == SampleStatus::bridged ? 0.0 : 1.0;
    }
    out.row(row_out.data());
    ++summary.rows_written;
  };

  while (const double* row = in_.next()) {
    ++rows;
    if (options_.progress && (rows & 0xffff) == 0) options_.progress(rows, t);
    const bool duplicate = have_previous_row &&
                           std::equal(row, row + width_in, previous_row.begin(),
                                      [](double a, double b) { return a == b || (a != a && b != b); });
    std::copy(row, row + width_in, previous_row.begin());
    have_previous_row = true;
    if (in_.time_mark() == stream::TimeMark::clock_step) {
      // The stream's time policy kept this row as the start of a new time line.
      ++summary.restarts;
      warn(in_.where() + ": observer restarted at t=" + exact(row[t_index_]) +
           ": the clock stepped back from t=" + exact(observer_.last_time()));
      observer_.restart_clock();
    }
    process(row, duplicate, nullptr);
  }
  if (summary.rejected_rows) {
    // Only without the reader's time policy (which reports its own): rows the observer refused.
    std::string text = std::to_string(summary.rejected_rows) + " row" +
                       (summary.rejected_rows == 1 ? "" : "s") + " skipped for their time (";
    text += std::to_string(summary.duplicate_rows) + " duplicate, " +
            std::to_string(summary.out_of_order_rows) + " out of time order; first at " +
            first_skipped + ")";
    warn(text);
  }
  if (const stream::TimeOrder::Summary* time = in_.time_summary()) {
    summary.duplicate_rows += time->duplicates;
    summary.out_of_order_rows += time->out_of_order + time->not_finite;
    summary.rejected_rows += time->dropped();
  }
  if (summary.bridged_gaps) {
    warn(std::to_string(summary.bridged_gaps) + " gap" + (summary.bridged_gaps == 1 ? "" : "s") +
         " bridged without a restart (longest " + short_number(summary.longest_bridge) + " s)");
  }
  if (!bad_run_start.empty()) {
    warn(located(in_.name(), 0, "the stream ends with rows with nan or inf from " + bad_run_start));
  }
  summary.median_dt = observer_.median_dt();
  return summary;
}

ObserveStreamSummary observe_stream(stream::Reader& in, stream::Writer& out,
                                    const model::Model& model, const ObserveStreamOptions& options) {
  return StreamObserver(in, model, options).run(out);
}

ObserverOptions observer_options_from_profile(const model::Profile& profile) {
  const auto it = profile.document.find("observer");
  if (it == profile.document.end()) return {};
  std::vector<std::string> warnings;
  ObserverOptions options;
  try {
    options = observer_options_from_json(*it, &warnings);
  } catch (const Error& e) {
    throw Error(located(profile.path.string(), 0, e.what()));
  }
  for (const auto& w : warnings) warn(located(profile.path.string(), 0, w));
  return options;
}

std::optional<friction::FrictionModel> friction_from_profile(const model::Profile& profile, int joints) {
  const auto it = profile.document.find("friction");
  if (it == profile.document.end()) return std::nullopt;
  std::vector<std::string> warnings;
  friction::FrictionModel model;
  try {
    model = friction::friction_from_json(*it, &warnings);
  } catch (const Error& e) {
    throw Error(located(profile.path.string(), 0, e.what()));
  }
  for (const auto& w : warnings) warn(located(profile.path.string(), 0, w));
  if (static_cast<int>(model.joints.size()) != joints) {
    throw Error(located(profile.path.string(), 0,
                        "friction: " + std::to_string(model.joints.size()) + " joint entries for a chain of " +
                            std::to_string(joints) + " joints"));
  }
  return model;
}

}  // namespace momentum::observer
