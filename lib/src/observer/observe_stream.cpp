#include "momentum/observer/observe_stream.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "momentum/stream/error.hpp"
#include "momentum/stream/format.hpp"

namespace momentum::observer {
namespace {

std::string exact(double value) {
  char buffer[40];
  return std::string(buffer, stream::format_double(value, buffer));
}

std::string short_number(double value) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.6g", value);
  return buffer;
}

int count_joint_columns(const stream::Reader& in, const std::string& prefix) {
  int n = 0;
  while (in.find(prefix + std::to_string(n + 1))) ++n;
  return n;
}

}  // namespace

ObserveStreamSummary observe_stream(stream::Reader& in, stream::Writer& out,
                                    const model::Model& model, const ObserveStreamOptions& options) {
  const int n = model.nq;
  auto fail = [&](const std::string& message) { throw Error(located(in.name(), 0, message)); };
  const std::string chain = "the profile's chain " + model.root + ".." + model.tip + " has " +
                            std::to_string(n) + " joint" + (n == 1 ? "" : "s");
  // Joint columns: q1..qN, dq1..dqN, and tau_m<j> or i<j>; N must be the chain's nq.
  for (const char* prefix : {"q", "dq"}) {
    const int found = count_joint_columns(in, prefix);
    if (found == 0) in.require(std::string(prefix) + "1");
    if (found != n) {
      fail("the stream has " + std::to_string(found) + " joint" + (found == 1 ? "" : "s") + " (" +
           prefix + "1.." + prefix + std::to_string(found) + ") but " + chain);
    }
  }
  const std::size_t t_index = in.require("t");
  std::vector<std::size_t> q_index(n), dq_index(n), torque_index(n);
  std::vector<double> torque_scale(n);
  for (int j = 0; j < n; ++j) {
    const std::string k = std::to_string(j + 1);
    q_index[j] = *in.find("q" + k);
    dq_index[j] = *in.find("dq" + k);
    if (auto tau = in.find("tau_m" + k)) {
      torque_index[j] = *tau;
      torque_scale[j] = 1.0;
    } else if (auto current = in.find("i" + k)) {
      torque_index[j] = *current;
      torque_scale[j] = model.k_i.size() == n ? model.k_i[j] : 1.0;
    } else {
      fail("missing column 'tau_m" + k + "' (or 'i" + k + "' with the profile's k_i)");
    }
  }
  const std::string next = std::to_string(n + 1);
  if (in.find("tau_m" + next) || in.find("i" + next))
    fail("the stream has torque or current columns for joint " + next + " but " + chain);

  MomentumObserver observer(model, options.observer, options.friction);
  const bool friction = observer.has_friction();

  // Output columns: the input's, then those we add (or overwrite where the input has them).
  std::vector<std::string> columns = in.columns();
  auto place = [&](const std::string& name) {
    if (auto existing = in.find(name)) return *existing;
    columns.push_back(name);
    return columns.size() - 1;
  };
  std::vector<std::size_t> r_out(n), tau_f_out, mu_out;
  for (int j = 0; j < n; ++j) r_out[j] = place("r" + std::to_string(j + 1));
  if (friction) {
    for (int j = 0; j < n; ++j) tau_f_out.push_back(place("tau_f" + std::to_string(j + 1)));
    for (int j = 0; j < n; ++j) mu_out.push_back(place("mu" + std::to_string(j + 1)));
  }
  std::optional<std::size_t> restart_out;
  if (options.restart_column) restart_out = place("restart");
  out.header(columns);
  in.on_comment([&out](std::string_view text) { out.comment(text); });

  const std::size_t width_in = in.columns().size();
  std::vector<double> row_out(columns.size());
  std::vector<double> q(n), dq(n), tau(n), r(n), tau_f(n), mu(n);
  ObserveStreamSummary summary;
  std::string bad_run_start;
  std::uint64_t rows = 0;
  double t = 0;
  while (const double* row = in.next()) {
    ++rows;
    if (options.progress && (rows & 0xffff) == 0) options.progress(rows, t);
    t = row[t_index];
    for (int j = 0; j < n; ++j) {
      q[j] = row[q_index[j]];
      dq[j] = row[dq_index[j]];
      tau[j] = torque_scale[j] * row[torque_index[j]];
    }
    const double previous_t = observer.last_time();
    const SampleStatus status = observer.step(t, q.data(), dq.data(), tau.data(), r.data(),
                                              tau_f.data(), mu.data());
    switch (status) {
      case SampleStatus::time_not_increasing:
        ++summary.rejected_rows;
        in.reject_row("time does not increase: t=" + exact(t) + " after t=" + exact(previous_t));
        continue;
      case SampleStatus::invalid:
        if (bad_run_start.empty()) bad_run_start = in.where();
        ++summary.invalid_rows;
        break;
      case SampleStatus::restarted_after_gap:
        ++summary.restarts;
        warn(in.where() + ": observer restarted at t=" + exact(t) + " after a gap of " +
             short_number(observer.last_gap()) + " s (median dt " +
             short_number(observer.median_dt()) + " s)");
        break;
      case SampleStatus::restarted_after_bad: {
        ++summary.restarts;
        const std::uint64_t bad = observer.last_bad_run();
        warn(in.where() + ": observer restarted at t=" + exact(t) + " after " +
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
    for (int j = 0; j < n; ++j) row_out[r_out[j]] = r[j];
    if (friction) {
      for (int j = 0; j < n; ++j) {
        row_out[tau_f_out[j]] = tau_f[j];
        row_out[mu_out[j]] = mu[j];
      }
    }
    if (restart_out) row_out[*restart_out] = status == SampleStatus::ok ? 0.0 : 1.0;
    out.row(row_out.data());
    ++summary.rows_written;
  }
  if (!bad_run_start.empty()) {
    warn(located(in.name(), 0, "the stream ends with rows with nan or inf from " + bad_run_start));
  }
  summary.median_dt = observer.median_dt();
  return summary;
}

}  // namespace momentum::observer
