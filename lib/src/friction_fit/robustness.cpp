#include "momentum/friction_fit/robustness.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <string>
#include <unordered_map>

#include "momentum/core/error.hpp"

namespace momentum::friction_fit {

bool ResidualSplitOptions::IsValid(std::string* why) const {
  if (!(position_fraction > 0 && position_fraction <= 1)) return invalid(why, "position fraction must be in (0, 1]");
  if (!(relative_size >= 0) || !std::isfinite(relative_size)) return invalid(why, "relative size must be a finite number >= 0");
  return true;
}

namespace {

// Every feature through the observer's filter, sample by sample, restarted as the observer was;
// each counted sample (rows) handed to `row(i, x)` with its filtered features x, in order.
template <class Feature, class Row>
void filtered_features(const JointSeries& d, const observer::Gains& gains, std::size_t count,
                       const Feature& feature, const std::vector<std::size_t>& rows, const Row& row) {
  // DisturbanceFilter's arithmetic, with the coefficients of each distinct interval computed
  // once (decimal time stamps alternate between a few intervals that differ in their last bits).
  std::unordered_map<double, observer::FilterCoefficients> known;
  std::vector<observer::FilterState<double>> filters(count);
  std::vector<double> value(count), previous(count, 0.0), x(count);
  std::size_t next = 0;
  for (std::size_t k = 0; k < d.size(); ++k) {
    feature(k, value);
    const bool start = k == 0 || d.restart[k] != 0;
    const observer::FilterCoefficients* c = nullptr;
    if (!start) {
      const double dt = d.t[k] - d.t[k - 1];
      auto it = known.find(dt);
      if (it == known.end()) it = known.emplace(dt, observer::discretize(gains, dt)).first;
      c = &it->second;
    }
    for (std::size_t f = 0; f < count; ++f) {
      double y = 0;
      if (start) {
        filters[f].reset();
      } else {
        filters[f].advance(*c, previous[f], value[f]);
        y = filters[f].output(*c);
      }
      previous[f] = value[f];
      x[f] = y;
    }
    if (next < rows.size() && rows[next] == k) row(next++, x);
  }
}

// Least squares of y on an intercept and p features, fed row by row in constant memory: the
// triangular factor R of [1 x y] is updated a chunk of rows at a time (Householder QR of R
// stacked on the chunk), and [A y] = Q R gives |A b - y|^2 = |R_A b - z|^2 + rho^2 for every b,
// so the small system has the same solution (pivoted QR, rank-revealing) and residual.
class StreamingLeastSquares {
 public:
  explicit StreamingLeastSquares(std::size_t p)
      : width_(static_cast<Eigen::Index>(p) + 2), stack_(Eigen::MatrixXd::Zero(width_ + kChunk, width_)) {}
  void add(double y, const std::vector<double>& x) {
    const Eigen::Index i = width_ + filled_;
    stack_(i, 0) = 1.0;
    for (std::size_t f = 0; f < x.size(); ++f) stack_(i, 1 + static_cast<Eigen::Index>(f)) = x[f];
    stack_(i, width_ - 1) = y;
    sum_ += y;
    sum_squares_ += y * y;
    ++n_;
    if (++filled_ == kChunk) reduce();
  }
  // Adjusted R^2 of y (centred) on the features plus an intercept; the RMS of the fitted
  // values about their mean in `explained_rms`.
  double adjusted_r_squared(double* explained_rms) {
    reduce();
    const Eigen::Index p = width_ - 2, m = width_ - 1;
    const Eigen::MatrixXd r = stack_.topLeftCorner(m, m).triangularView<Eigen::Upper>();
    const Eigen::VectorXd z = stack_.col(m).head(m);
    const double rho = stack_(m, m);
    const Eigen::VectorXd beta = r.colPivHouseholderQr().solve(z);
    const double sse = (r * beta - z).squaredNorm() + rho * rho;
    const double n = static_cast<double>(n_);
    const double mean = n_ ? sum_ / n : 0.0;
    const double sst = std::max(0.0, sum_squares_ - n * mean * mean);
    if (explained_rms) *explained_rms = n_ ? std::sqrt(std::max(0.0, sst - sse) / n) : 0.0;
    if (!(sst > 0) || static_cast<Eigen::Index>(n_) <= p + 1) return 0.0;
    const double r2 = 1.0 - sse / sst;
    return 1.0 - (1.0 - r2) * (n - 1) / (n - static_cast<double>(p) - 1);
  }

 private:
  static constexpr Eigen::Index kChunk = 2048;
  void reduce() {
    if (filled_ == 0) return;
    const Eigen::Index rows = width_ + filled_;
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(stack_.topRows(rows));
    stack_.setZero();
    stack_.topRows(width_) = qr.matrixQR().topRows(width_).triangularView<Eigen::Upper>();
    filled_ = 0;
  }
  Eigen::Index width_;
  Eigen::MatrixXd stack_;  // R (width_ rows), then up to kChunk new rows
  Eigen::Index filled_ = 0;
  std::size_t n_ = 0;
  double sum_ = 0, sum_squares_ = 0;
};

}  // namespace

ResidualSplit split_residual(const JointSeries& d, const observer::Gains& gains, const std::vector<double>& residual,
                             const ResidualSplitOptions& options) {
  ResidualSplit out;
  if (!d.has_positions() || residual.size() != d.size()) return out;
  const Positions& q = *d.positions;
  const std::size_t n = q.size();
  // Consecutive sums q_a + ... + q_b, 1 <= a <= b <= n.
  std::vector<std::pair<std::size_t, std::size_t>> sums;
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = a; b < n; ++b) sums.push_back({a, b});
  const std::size_t position_count = 2 * sums.size();
  constexpr std::size_t kVelocityCount = 5;
  std::vector<std::size_t> rows;
  for (std::size_t k = 0; k < d.size(); ++k)
    if (d.scored[k]) rows.push_back(k);
  if (rows.size() < 10 * (position_count + 1)) return out;

  StreamingLeastSquares on_positions(position_count), on_velocity(kVelocityCount);
  filtered_features(d, gains, position_count, [&](std::size_t k, std::vector<double>& v) {
    for (std::size_t s = 0; s < sums.size(); ++s) {
      double angle = 0;
      for (std::size_t j = sums[s].first; j <= sums[s].second; ++j) angle += q[j][k];
      v[2 * s] = std::sin(angle);
      v[2 * s + 1] = std::cos(angle);
    }
  }, rows, [&](std::size_t i, const std::vector<double>& x) { on_positions.add(residual[rows[i]], x); });
  filtered_features(d, gains, kVelocityCount, [&](std::size_t k, std::vector<double>& v) {
    const double w = d.dq[k];
    const double sign = w > 0 ? 1.0 : (w < 0 ? -1.0 : 0.0);
    v[0] = w;
    v[1] = w * std::abs(w);
    v[2] = w * w * w;
    v[3] = sign;
    v[4] = sign * std::exp(-(w / 0.1) * (w / 0.1));
  }, rows, [&](std::size_t i, const std::vector<double>& x) { on_velocity.add(residual[rows[i]], x); });

  out.position_fraction = std::max(0.0, on_positions.adjusted_r_squared(&out.explained_rms));
  out.velocity_fraction = std::max(0.0, on_velocity.adjusted_r_squared(nullptr));
  out.samples = rows.size();
  out.position_features = position_count;
  double mean = 0;
  for (std::size_t k : rows) mean += residual[k];
  mean /= static_cast<double>(rows.size());
  double spread = 0;
  for (std::size_t k : rows) spread += (residual[k] - mean) * (residual[k] - mean);
  out.residual_rms = std::sqrt(spread / static_cast<double>(rows.size()));
  double signal = 0;
  for (std::size_t k : rows) signal += d.r[k] * d.r[k];
  out.signal_rms = std::sqrt(signal / static_cast<double>(rows.size()));
  out.position_dependent = out.position_fraction >= options.position_fraction &&
                           out.position_fraction > out.velocity_fraction &&
                           out.explained_rms >= options.relative_size * out.signal_rms;
  out.computed = true;
  return out;
}

}  // namespace momentum::friction_fit
