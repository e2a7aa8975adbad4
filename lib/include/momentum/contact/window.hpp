#pragma once
// The rows of one contact, kept for identification in constant memory: a ring of the latest
// rows (so that when an event opens, its rows since the estimated onset and the level before it
// are still there), and while an event is open its rows, halved in rate whenever the buffer
// fills (a contact held for minutes keeps a bounded, evenly spaced record of itself).

#include <cstddef>
#include <span>
#include <vector>

#include "momentum/contact/locate.hpp"

namespace momentum::contact {

class ContactWindow {
 public:
  // `joints`: n. `ring_rows`: rows kept before an event (>= 2), `capacity`: most rows kept of
  // one event (>= 4), `level_seconds`: the span before the onset whose mean residual is the
  // level subtracted from the event's rows (model error, static friction held), s > 0.
  ContactWindow(std::size_t joints, std::size_t ring_rows = 1024, std::size_t capacity = 512,
                double level_seconds = 0.05);

  // Every row, in time order: t (s), q (n), residual x (n), and the weight of each joint's
  // residual on this row (n, 1/Nm). A row with a non-finite t, q or x is left out.
  void add(double t, const double* q, const double* x, const double* weight);
  // An event opened on the last row added, with the contact estimated to start at
  // t_onset_estimate: its level is the mean residual of the ring's rows in the level span
  // before that time (0 when there are none), and its record starts at that time. A recorded
  // row's weight of each joint is at most the least weight of the joint's level rows: the row's
  // residual minus the level is no better known than the level. A joint at rest before the
  // contact holds a torque against static friction that the model cannot know (the level),
  // and when the contact or the arm's reaction to it breaks the joint free, or changes what
  // it holds, that torque goes and the change is read as a disturbance: the noise of a joint at
  // rest, not of a moving one. (On the MuJoCo UR5 campaigns, learnt on one and scored on the
  // other, the learnt link temperature went from 119 and 71 to 2.3 and 4.3, and the link
  // probabilities' Brier score from 0.126 and 0.122 to 0.102 and 0.091.)
  void open(double t_onset_estimate);
  // The residuals come from a first-order observer of gains k1 (1/s, n values, > 0), r' = K1
  // (tau - r): every sample recorded from now on also carries tau, the disturbance with the
  // observer's lag undone. Over the span back to the last row at least kLagSpan / K1 seconds
  // earlier (t - s), the observer's own recursion for a constant disturbance, r(t) = a r(s) +
  // (1 - a) tau with a = exp(-K1 (t - s)), solved for tau: the disturbance's (exponentially
  // weighted) mean over that span. The residual lags a disturbance by 1/K1 (20 ms at the
  // default 50 1/s) and keeps a short impact under its peak (a 40 ms push at 86%, a 10 ms one
  // at 39%). The span is one time constant of the observer: tau resolves what the observer's
  // own time scale does, and its noise is sqrt(1 + a^2) / (1 - a) = 1.7 times the residual's
  // (a = exp(-1)). A span of 0.4 time constants (noise 3.6 times) made the peaks of long
  // contacts, the maximum over many noisier rows, 10% too high on the MuJoCo UR5 campaigns.
  void undo_first_order_lag(std::vector<double> k1);
  static constexpr double kLagSpan = 1.0;
  void close() { open_ = false; }
  bool is_open() const { return open_; }

  // The event's rows so far, residual minus the level, weights at most the level's.
  std::span<const ResidualSample> samples() const { return samples_; }
  double t_onset_estimate() const { return t_onset_; }

 private:
  std::size_t width() const { return 1 + 3 * n_; }
  void offer(const double* row);  // kept when the stride says so
  void record(const double* row);
  std::size_t n_;
  std::size_t ring_rows_, capacity_;
  double level_seconds_;
  std::vector<double> ring_;  // ring_rows x (1 + 3n): t, q, x, weight
  std::size_t ring_next_ = 0, ring_size_ = 0;
  bool open_ = false;
  double t_onset_ = 0;
  Eigen::VectorXd level_;
  Eigen::VectorXd level_weight_;  // per joint: the least weight of the level rows
  std::vector<ResidualSample> samples_;
  std::size_t stride_ = 1, since_kept_ = 0;
  std::vector<double> k1_;  // empty: the lag is not undone
  double lag_span_ = 0;     // s: kLagSpan / the smallest K1
  // The latest row of the ring at least `span` s before `row` (a row of the ring), or nullptr.
  const double* row_before(const double* row, double span) const;
};

}  // namespace momentum::contact
