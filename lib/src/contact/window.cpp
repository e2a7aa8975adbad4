#include "momentum/contact/window.hpp"

#include <algorithm>
#include <cmath>

#include "momentum/core/error.hpp"

namespace momentum::contact {

ContactWindow::ContactWindow(std::size_t joints, std::size_t ring_rows, std::size_t capacity, double level_seconds)
    : n_(joints), ring_rows_(ring_rows), capacity_(capacity), level_seconds_(level_seconds) {
  if (joints == 0 || ring_rows < 2 || capacity < 4 || !(level_seconds > 0))
    throw Error("contact window: needs joints, a ring of 2 rows or more, a capacity of 4 or more, a level span > 0");
  ring_.resize(ring_rows_ * width());
  level_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n_));
  level_weight_ = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(n_), INFINITY);
  samples_.reserve(capacity_);
}

void ContactWindow::add(double t, const double* q, const double* x, const double* weight) {
  // A row with a value missing or broken costs only itself: the contact is fitted without it.
  for (std::size_t j = 0; j < n_; ++j)
    if (!std::isfinite(q[j]) || !std::isfinite(x[j])) return;
  if (!std::isfinite(t)) return;
  double* slot = &ring_[ring_next_ * width()];
  slot[0] = t;
  std::copy(q, q + n_, slot + 1);
  std::copy(x, x + n_, slot + 1 + n_);
  std::copy(weight, weight + n_, slot + 1 + 2 * n_);
  ring_next_ = (ring_next_ + 1) % ring_rows_;
  ring_size_ = std::min(ring_size_ + 1, ring_rows_);
  if (open_) offer(slot);
}

void ContactWindow::offer(const double* row) {
  if (++since_kept_ < stride_) return;
  since_kept_ = 0;
  record(row);
}

void ContactWindow::record(const double* row) {
  if (samples_.size() == capacity_) {
    // Halve the rate: keep every other row, then every stride-th row from now on.
    std::size_t kept = 0;
    for (std::size_t i = 0; i < samples_.size(); i += 2) samples_[kept++] = std::move(samples_[i]);
    samples_.resize(kept);
    stride_ *= 2;
  }
  const auto n = static_cast<Eigen::Index>(n_);
  ResidualSample s;
  s.t = row[0];
  s.q = Eigen::Map<const Eigen::VectorXd>(row + 1, n);
  s.r = Eigen::Map<const Eigen::VectorXd>(row + 1 + n_, n) - level_;
  s.weight = Eigen::Map<const Eigen::VectorXd>(row + 1 + 2 * n_, n).cwiseMin(level_weight_);
  if (!k1_.empty()) {
    s.tau = s.r;
    s.tau_weight = s.weight;
    if (const double* before = row_before(row, lag_span_)) {
      const double span = row[0] - before[0];
      for (std::size_t j = 0; j < n_; ++j) {
        const auto i = static_cast<Eigen::Index>(j);
        const double a = std::exp(-k1_[j] * span);
        s.tau[i] = (row[1 + n_ + j] - a * before[1 + n_ + j]) / (1 - a) - level_[i];
        s.tau_weight[i] *= (1 - a) / std::sqrt(1 + a * a);
      }
    }
  }
  samples_.push_back(std::move(s));
}

void ContactWindow::undo_first_order_lag(std::vector<double> k1) {
  if (k1.size() != n_) throw Error("contact window: " + std::to_string(k1.size()) + " observer gains for " + std::to_string(n_) + " joints");
  for (double k : k1)
    if (!(k > 0) || !std::isfinite(k)) throw Error("contact window: an observer gain must be a finite number > 0");
  lag_span_ = kLagSpan / *std::min_element(k1.begin(), k1.end());
  k1_ = std::move(k1);
}

const double* ContactWindow::row_before(const double* row, double span) const {
  const std::size_t index = static_cast<std::size_t>(row - ring_.data()) / width();
  const std::size_t oldest = (ring_next_ + ring_rows_ - ring_size_) % ring_rows_;
  const std::size_t older = (index + ring_rows_ - oldest) % ring_rows_;  // rows before it in the ring
  for (std::size_t k = 1; k <= older; ++k) {
    const double* before = &ring_[((index + ring_rows_ - k) % ring_rows_) * width()];
    if (before[0] <= row[0] - span) return before;
  }
  return nullptr;
}

void ContactWindow::open(double t_onset_estimate) {
  open_ = true;
  t_onset_ = t_onset_estimate;
  stride_ = 1;
  since_kept_ = stride_ - 1;  // keep the first row offered
  samples_.clear();
  const std::size_t first = (ring_next_ + ring_rows_ - ring_size_) % ring_rows_;
  auto row = [&](std::size_t k) { return &ring_[((first + k) % ring_rows_) * width()]; };
  const auto n = static_cast<Eigen::Index>(n_);
  level_.setZero();
  level_weight_.setConstant(INFINITY);
  int level_rows = 0;
  for (std::size_t k = 0; k < ring_size_; ++k) {
    const double* r = row(k);
    if (r[0] < t_onset_estimate && r[0] >= t_onset_estimate - level_seconds_) {
      level_ += Eigen::Map<const Eigen::VectorXd>(r + 1 + n_, n);
      level_weight_ = level_weight_.cwiseMin(Eigen::Map<const Eigen::VectorXd>(r + 1 + 2 * n_, n));
      ++level_rows;
    }
  }
  if (level_rows > 0) level_ /= level_rows;
  for (std::size_t k = 0; k < ring_size_; ++k) {
    const double* r = row(k);
    if (r[0] >= t_onset_estimate) offer(r);
  }
}

}  // namespace momentum::contact
