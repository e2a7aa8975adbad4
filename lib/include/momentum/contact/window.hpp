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
  // before that time (0 when there are none), and its record starts at that time.
  void open(double t_onset_estimate);
  void close() { open_ = false; }
  bool is_open() const { return open_; }

  // The event's rows so far, residual minus the level.
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
  std::vector<ResidualSample> samples_;
  std::size_t stride_ = 1, since_kept_ = 0;
};

}  // namespace momentum::contact
