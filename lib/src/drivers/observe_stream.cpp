#include "momentum/drivers/observe_stream.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/stream/columns.hpp"
#include "momentum/stream/format.hpp"

namespace momentum::drivers {

// This driver runs the observer stage: its names are this file's vocabulary.
using namespace observer;
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

void StepJitter::add(double dt, double median) {
  if (!(dt > 0 && median > 0 && std::isfinite(dt) && std::isfinite(median))) return;
  const double e = dt / median - 1;
  if (e <= kGap) {
    ++ordinary_;
    sum_abs_ += std::abs(e);
    return;
  }
  ++gaps_;
  longest_ = std::max(longest_, e);
  const double bin = std::floor(e / kBin);
  ++histogram_[bin < kBins ? static_cast<std::size_t>(bin) : kBins];
}

double StepJitter::sigma() const {
  return ordinary_ ? std::sqrt(std::numbers::pi / 2) * sum_abs_ / static_cast<double>(ordinary_) : 0.0;
}

double StepJitter::gap_line() const {
  const double k = std::sqrt(2 * std::log(50.0 * static_cast<double>(std::max<std::uint64_t>(steps(), 1))));
  return std::max(kGap, k * sigma());
}

std::uint64_t StepJitter::unusual_gaps() const {
  if (!(longest_ > gap_line())) return 0;
  // To within a bin: the bin the line falls in counts whole.
  const auto first = static_cast<std::size_t>(std::min(std::floor(gap_line() / kBin), double{kBins}));
  std::uint64_t count = 0;
  for (std::size_t b = first; b < histogram_.size(); ++b) count += histogram_[b];
  return count;
}

double StepJitter::longest_unusual() const { return longest_ > gap_line() ? 1 + longest_ : 0.0; }

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
  // A stream numbered from 0 would otherwise read as one joint short, or lose joint 0.
  if (const std::string zero = stream::zero_based_joint_message(in.columns()); !zero.empty()) fail(zero);
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
  if (options.flag_column) flagged_out_ = place("flagged");
}

ObserveStreamSummary StreamObserver::run(stream::Writer& out) {
  const int n = model_.nq;
  const bool friction = observer_.has_friction();
  out.header(columns_);
  in_.on_comment([&out](std::string_view text) { out.comment(text); });
  const std::size_t width_in = in_.columns().size();
  std::vector<double> row_out(columns_.size());
  std::vector<double> q(n), dq(n), tau(n), r(n), tau_f(n), mu(n);
  // The residual as last written: what a row left out is written with.
  std::vector<double> held_r(n, 0.0), held_tau_f(n, 0.0), held_mu(n, 0.0);
  ObserveStreamSummary summary;
  StepJitter jitter;
  std::string bad_run_start;
  // The previous row as read, to tell exact duplicates from other rows out of time order.
  std::vector<double> previous_row(width_in);
  bool have_previous_row = false;
  constexpr std::uint64_t kReportedPerKind = 5;
  constexpr std::size_t kFlaggedTimes = 20;
  std::string first_skipped;
  std::uint64_t rows = 0;
  double t = 0;

  // The signal check's reference: the last row the observer advanced with (t, q, dq), and
  // whether the interval into it was a plain one (learnt from).
  SignalCheck check(model_, options_.observer.signals);
  const bool checking = options_.observer.signals.enabled;
  std::vector<double> good_q(n), good_dq(n), good_tau(n), held_q(n), held_dq(n);
  double good_t = 0;
  bool have_good = false;
  bool limits_suspended = false;
  std::string first_flagged;
  // Rows held back while the signal check waits for a later row to decide (see run()).
  struct Held {
    std::vector<double> values;
    std::string where;
    std::string why;
    bool impossible = false;  // beyond the physical limits: never taken as real
    bool jump = false;        // its velocity left the trend (SignalCheck::velocity_jumps)
  };
  constexpr std::size_t kMaxHeld = 32;
  std::vector<Held> held(kMaxHeld);
  std::size_t held_count = 0;

  // Counts, reports (the first few of each kind) and skips a row whose time does not increase.
  auto skip = [&](bool duplicate, const std::string& where, const std::string& message) {
    if (options_.strict) throw Error(where + ": " + message);
    ++summary.rejected_rows;
    std::uint64_t& count = duplicate ? summary.duplicate_rows : summary.out_of_order_rows;
    ++count;
    if (first_skipped.empty()) first_skipped = where;
    if (count <= kReportedPerKind) warn_row(duplicate ? "duplicate row" : "time out of order", where + ": " + message + ": skipped");
  };

  // The row whose values t, q, dq and tau hold, so that the check's row is not unpacked again
  // for the observer; reset with every row read and when q, dq and tau are swapped away.
  const double* unpacked = nullptr;
  auto unpack = [&](const double* row) {
    unpacked = row;
    t = row[t_index_];
    for (int j = 0; j < n; ++j) {
      q[j] = row[q_index_[j]];
      dq[j] = row[dq_index_[j]];
      tau[j] = torque_scale_[j] * row[torque_index_[j]];
    }
  };

  auto write = [&](const double* row, bool restarted, bool flagged) {
    std::copy(row, row + width_in, row_out.begin());
    for (int j = 0; j < n; ++j) row_out[r_out_[j]] = r[j];
    if (friction) {
      for (int j = 0; j < n; ++j) {
        row_out[tau_f_out_[j]] = tau_f[j];
        row_out[mu_out_[j]] = mu[j];
      }
    }
    if (restart_out_) row_out[*restart_out_] = restarted ? 1.0 : 0.0;
    if (flagged_out_) row_out[*flagged_out_] = flagged ? 1.0 : 0.0;
    out.row(row_out.data());
    ++summary.rows_written;
  };

  // Steps the observer with one row and writes it. `where`: its location, or nullptr for the
  // row the reader returned last. `after_left_out`: rows were left out just before it (the
  // observer bridges them; not counted as a gap).
  auto process = [&](const double* row, bool duplicate, const std::string* where, bool after_left_out) {
    auto here = [&] { return where ? *where : in_.where(); };
    if (row != unpacked) unpack(row);
    const double previous_t = observer_.last_time();
    const double median = observer_.median_dt();
    const SampleStatus status = observer_.step(t, q.data(), dq.data(), tau.data(), r.data(),
                                               tau_f.data(), mu.data());
    switch (status) {
      case SampleStatus::time_not_increasing:
        skip(duplicate, here(),
             std::string(duplicate ? "duplicate row" : "time does not increase") + ": t=" + exact(t) +
                 " after t=" + exact(previous_t));
        return;
      case SampleStatus::ok:
        if (!after_left_out) jitter.add(t - previous_t, median);
        break;
      case SampleStatus::bridged:
        if (!after_left_out) {
          jitter.add(t - previous_t, median);
          ++summary.bridged_gaps;
          summary.longest_bridge = std::max(summary.longest_bridge, observer_.last_gap());
        }
        break;
      case SampleStatus::invalid:
        if (bad_run_start.empty()) bad_run_start = here();
        ++summary.invalid_rows;
        break;
      case SampleStatus::restarted_after_gap:
        ++summary.restarts;
        warn(here() + ": observer restarted at t=" + exact(t) + " after a gap of " +
             core::short_number(observer_.last_gap()) + " s (median dt " +
             core::short_number(observer_.median_dt()) + " s)" +
             (after_left_out ? std::string(" across rows left out") : std::string()) +
             (observer_.last_gap_mismatched()
                  ? ": joint " + std::to_string(observer_.mismatch_joint() + 1) +
                        "'s position moved " + core::short_number(observer_.mismatch()) +
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
    }
    if (status != SampleStatus::invalid) {
      // The signal check learns its tolerance from plain intervals between good rows only.
      if (checking && status == SampleStatus::ok && have_good && !after_left_out)
        check.learn(good_t, good_q.data(), good_dq.data(), good_tau.data(), t, q.data(), dq.data(), tau.data());
      good_t = t;
      // Swapped, not copied: unpack() writes every element of q, dq and tau anew for the next
      // row, and nothing reads them before it.
      good_q.swap(q);
      good_dq.swap(dq);
      good_tau.swap(tau);
      unpacked = nullptr;
      have_good = true;
    }
    write(row, status != SampleStatus::ok && status != SampleStatus::bridged, false);
    if (status != SampleStatus::invalid) {
      // Swapped, not copied, once written: the observer's next step writes every element of r,
      // tau_f and mu anew (or returns time_not_increasing, and nothing is written), and a row
      // left out copies the held values into them.
      held_r.swap(r);
      if (friction) {
        held_tau_f.swap(tau_f);
        held_mu.swap(mu);
      }
    }
  };

  // Writes a row left out: its input as read, the residual held at its last value.
  auto write_left_out = [&](const Held& h) {
    r = held_r;
    if (friction) {
      tau_f = held_tau_f;
      mu = held_mu;
    }
    write(h.values.data(), false, true);
    ++summary.flagged_rows;
  };

  // Reports one stretch of rows left out (the first few) and counts it.
  auto report_left_out = [&](const Held& first, std::size_t count, const char* ending) {
    ++summary.flagged_stretches;
    const double t_first = first.values[t_index_];
    if (summary.flagged_times.size() < kFlaggedTimes) summary.flagged_times.push_back(t_first);
    if (first_flagged.empty()) first_flagged = first.where;
    if (summary.flagged_stretches <= kReportedPerKind)
      warn(first.where + ": t=" + exact(t_first) + ": " + first.why + ": " +
                                       std::to_string(count) + " row" + (count == 1 ? "" : "s") +
                                       " left out, " + ending);
  };

  // The held rows were a sensor fault: left out; the next row continues from the last good one.
  auto leave_out_held = [&](const char* ending) {
    if (held_count == 0) return;
    report_left_out(held[0], held_count, ending);
    for (std::size_t k = 0; k < held_count; ++k) write_left_out(held[k]);
    held_count = 0;
  };

  // The held rows are taken as real (those beyond the limits excepted), in order.
  auto release_held = [&](bool confirmed) {
    bool left_out = false;
    std::size_t run_start = 0, run_length = 0;
    for (std::size_t k = 0; k < held_count; ++k) {
      Held& h = held[k];
      if (h.impossible) {
        if (run_length++ == 0) run_start = k;
        write_left_out(h);
        left_out = true;
        continue;
      }
      if (run_length) {
        report_left_out(held[run_start], run_length, "bridged");
        run_length = 0;
      }
      ++(confirmed ? summary.confirmed_rows : summary.unresolved_rows);
      if (!confirmed && k == 0)
        warn(h.where + ": t=" + exact(h.values[t_index_]) + ": " + h.why +
                                         ": for longer than a bridge, taken as they are");
      process(h.values.data(), false, &h.where, left_out);
      left_out = false;
    }
    if (run_length) report_left_out(held[run_start], run_length, "bridged");
    held_count = 0;
  };

  auto hold = [&](const double* row, bool impossible, std::string why, bool jump = false) {
    Held& h = held[held_count++];
    h.values.assign(row, row + width_in);
    h.where = in_.where();
    h.why = std::move(why);
    h.impossible = impossible;
    h.jump = jump;
  };

  // One row through the signal check: written now, or held back until a later row decides.
  auto check_row = [&](const double* row, bool duplicate) {
    unpack(row);
    const bool finite = std::isfinite(t) && core::all_finite(q.data(), dq.data(), tau.data(), n);
    const double t_reference = held_count ? held[held_count - 1].values[t_index_] : good_t;
    if (finite && held_count && !(t > t_reference)) {
      // A time fault after a held row (its duplicate, say): skipped as the observer skips one
      // after a row it has taken, the held rows still waiting.
      skip(duplicate, in_.where(),
           std::string(duplicate ? "duplicate row" : "time does not increase") + ": t=" + exact(t) + " after t=" +
               exact(t_reference));
      return;
    }
    if (!finite || (have_good && !(t > t_reference))) {
      // Not the check's to judge (the observer skips or restarts); held rows stay unconfirmed.
      leave_out_held("bridged");
      process(row, duplicate, nullptr, false);
      return;
    }
    // Most rows: every test passes plainly, in one pass over the joints.
    if (held_count == 0 && have_good &&
        check.plainly_passes(good_t, good_q.data(), good_dq.data(), t, q.data(), dq.data(), tau.data(),
                             observer_.median_dt())) {
      limits_suspended = false;
      process(row, duplicate, nullptr, false);
      return;
    }
    std::string why;
    const bool beyond = check.beyond_limits(q.data(), dq.data(), tau.data(), &why) >= 0;
    if (!beyond) limits_suspended = false;
    const bool impossible = beyond && !limits_suspended;
    const double typical_dt = observer_.median_dt();
    // A row after more lost samples than a bridge spans is the observer's to judge (it
    // restarts there, TIMING FAULTS). Across a gap it bridges, the disagreement test applies
    // with its tolerance grown for the longer interval: a glitch there would otherwise become
    // the state the observer goes on from.
    const bool after_gap = held_count == 0 && observer_.is_gap(t) &&
                           !(t - good_t <= options_.observer.gap_factor * observer_.median_dt());
    auto agrees_with_good = [&](std::string* reason) {
      return !have_good || after_gap ||
             !check.disagree(good_t, good_q.data(), good_dq.data(), t, q.data(), dq.data(), typical_dt, reason);
    };
    // A held row's q and dq into held_q and held_dq; its time.
    auto unpack_held = [&](const Held& h) {
      for (int j = 0; j < n; ++j) {
        held_q[j] = h.values[q_index_[j]];
        held_dq[j] = h.values[dq_index_[j]];
      }
      return h.values[t_index_];
    };
    // One held row whose velocity jumped, and this row's velocity is back on the trend of the
    // rows before it: a one-row spike of the velocity signal.
    auto jump_came_back = [&] {
      if (held_count != 1 || !held[0].jump) return false;
      const double t_held = unpack_held(held[0]);
      return check.velocity_on_trend(good_t, good_dq.data(), t_held, held_dq.data(), t, dq.data());
    };
    // One row held for disagreeing, and this row's velocity continues its change monotonically
    // (SignalCheck::velocity_change_explains): the arm changed speed within a sample.
    auto velocity_change_explains_held = [&] {
      if (held_count != 1 || held[0].jump || held[0].impossible) return false;
      const double t_held = unpack_held(held[0]);
      return check.velocity_change_explains(good_t, good_q.data(), good_dq.data(), t_held, held_q.data(),
                                            held_dq.data(), t, q.data(), dq.data(), typical_dt);
    };
    auto agrees_with_last_held = [&] {
      const double t_held = unpack_held(held[held_count - 1]);
      return !check.disagree(t_held, held_q.data(), held_dq.data(), t, q.data(), dq.data(), typical_dt, nullptr);
    };
    if (held_count == 0) {
      std::string jump_why;
      const bool jump = have_good && check.velocity_jumps(good_t, good_dq.data(), good_tau.data(), t, q.data(),
                                                          dq.data(), tau.data(), &jump_why);
      if (!impossible && agrees_with_good(&why)) {
        if (!jump) {
          process(row, duplicate, nullptr, false);
          return;
        }
        why = std::move(jump_why);
      }
      hold(row, impossible, why, jump);
    } else if (!impossible && jump_came_back() && agrees_with_good(nullptr)) {
      leave_out_held("bridged");
      process(row, duplicate, nullptr, true);
      return;
    } else if (!impossible && !held[held_count - 1].impossible && agrees_with_last_held()) {
      // The held rows were real: the sensors saw a fast change together. Asked before the last
      // good row (a velocity spike that came back excepted, above), so that a row that agrees
      // with both (an impact within one interval, which the trapezoid over the longer interval
      // may also pass) is observed, not left out.
      release_held(true);
      process(row, duplicate, nullptr, false);
      return;
    } else if (!impossible && velocity_change_explains_held()) {
      release_held(true);
      process(row, duplicate, nullptr, false);
      return;
    } else if (!impossible && agrees_with_good(nullptr)) {
      leave_out_held("bridged");
      process(row, duplicate, nullptr, true);
      return;
    } else {
      hold(row, impossible, why);
    }
    // A stretch longer than a bridge cannot be bridged: taken as it is.
    const double span = t - good_t;
    if (held_count == kMaxHeld || !have_good ||
        !(span <= options_.observer.gap_factor * observer_.median_dt())) {
      bool all_impossible = true;
      for (std::size_t k = 0; k < held_count; ++k) all_impossible = all_impossible && held[k].impossible;
      if (all_impossible && held_count) {
        limits_suspended = true;
        warn(held[0].where + ": t=" + exact(held[0].values[t_index_]) + ": " +
                                         held[0].why + ": for longer than a bridge; the limits are not applied "
                                         "again until a row is within them");
        leave_out_held("the observer goes on from them");
      } else {
        release_held(false);
      }
    }
  };

  // The observer's dynamics, several rows at once where that is cheaper: this row and the
  // rows after it that the reader already holds (never more than it has read, so a live stream
  // waits for nothing). The observer takes a result only for the very q and dq it was computed
  // from, so the rows the check holds, leaves out or the reader drops change nothing.
  constexpr int kAhead = model::MomentumBatch::kLanes;
  const bool compute_ahead = observer_.can_precompute();
  std::vector<double> peeked(compute_ahead ? (kAhead - 1) * width_in : 0);
  std::vector<double> ahead_q(compute_ahead ? kAhead * n : 0), ahead_dq(ahead_q.size());
  auto precompute_ahead = [&](const double* row) {
    const std::size_t more = in_.peek(peeked.data(), kAhead - 1);
    if (more == 0) return;
    const double* q_of[kAhead];
    const double* dq_of[kAhead];
    for (std::size_t k = 0; k <= more; ++k) {
      const double* values = k == 0 ? row : &peeked[(k - 1) * width_in];
      double* q_k = &ahead_q[k * n];
      double* dq_k = &ahead_dq[k * n];
      for (int j = 0; j < n; ++j) {
        q_k[j] = values[q_index_[j]];
        dq_k[j] = values[dq_index_[j]];
      }
      q_of[k] = q_k;
      dq_of[k] = dq_k;
    }
    observer_.precompute(static_cast<int>(more + 1), q_of, dq_of);
  };

  const bool reader_orders_time = in_.time_summary() != nullptr;
  while (const double* row = in_.next()) {
    ++rows;
    unpacked = nullptr;
    if (compute_ahead && observer_.precomputed() == 0) precompute_ahead(row);
    if (options_.progress && (rows & 0xffff) == 0) options_.progress(rows, t);
    // An exact duplicate has the same time first (or both NaN): most rows are told by it alone.
    // The reader's time policy hands on rows in increasing time only, none a duplicate.
    bool duplicate = false;
    if (!reader_orders_time) {
      const double row_t = row[t_index_], previous_t = previous_row[t_index_];
      duplicate = have_previous_row && (row_t == previous_t || (row_t != row_t && previous_t != previous_t)) &&
                  std::equal(row, row + width_in, previous_row.begin(),
                             [](double a, double b) { return a == b || (a != a && b != b); });
      std::copy(row, row + width_in, previous_row.begin());
      have_previous_row = true;
    }
    if (in_.time_mark() == stream::TimeMark::clock_step) {
      // The stream's time policy kept this row as the start of a new time line.
      leave_out_held("bridged");
      ++summary.restarts;
      warn(in_.where() + ": observer restarted at t=" + exact(row[t_index_]) +
           ": the clock stepped back from t=" + exact(observer_.last_time()));
      observer_.restart_clock();
      have_good = false;
    }
    if (checking) check_row(row, duplicate);
    else process(row, duplicate, nullptr, false);
  }
  leave_out_held("at the end of the stream");
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
  summary.step_jitter = jitter.sigma();
  summary.unusual_gaps = jitter.unusual_gaps();
  if (summary.unusual_gaps) {
    // Gaps within the log's own jitter are its ordinary timing, bridged without a word.
    const std::uint64_t gaps = summary.unusual_gaps;
    warn(std::to_string(gaps) + " gap" + (gaps == 1 ? "" : "s") + " bridged without a restart (longest " +
         core::short_number(summary.longest_bridge) + " s, " + core::significant(jitter.longest_unusual(), 3) +
         " median steps; the log's steps otherwise spread by " + core::fixed(100 * jitter.sigma(), 1) +
         "%): samples were lost");
  }
  if (summary.flagged_rows) {
    std::string times;
    for (double when : summary.flagged_times) times += (times.empty() ? "" : ", ") + core::short_number(when);
    if (summary.flagged_stretches > summary.flagged_times.size()) times += ", ...";
    warn(std::to_string(summary.flagged_rows) + " row" + (summary.flagged_rows == 1 ? "" : "s") +
         " left out because their signals disagree, in " + std::to_string(summary.flagged_stretches) +
         " stretch" + (summary.flagged_stretches == 1 ? "" : "es") + " (first at " + first_flagged +
         "; t=" + times + ")");
  }
  if (!bad_run_start.empty()) {
    warn(located(in_.name(), 0, "the stream ends with rows with nan or inf from " + bad_run_start));
  }
  summary.median_dt = observer_.median_dt();
  summary.rows_computed_ahead = observer_.precomputed_taken();
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

}  // namespace momentum::drivers
