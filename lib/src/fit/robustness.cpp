#include "momentum/fit/robustness.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <string>
#include <unordered_map>

namespace momentum::fit {

bool ResidualSplitOptions::IsValid(std::string* why) const {
  if (!(position_fraction > 0 && position_fraction <= 1)) {
    if (why) *why = "position fraction must be in (0, 1]";
    return false;
  }
  if (!(relative_size >= 0) || !std::isfinite(relative_size)) {
    if (why) *why = "relative size must be a finite number >= 0";
    return false;
  }
  return true;
}

namespace {

// Every feature through the observer's filter, sample by sample, restarted as the observer was;
// then the counted samples only (rows), one column per feature.
template <class Feature>
Eigen::MatrixXd filtered_features(const JointSeries& d, const observer::Gains& gains, std::size_t count,
                                  const Feature& feature, const std::vector<std::size_t>& rows) {
  Eigen::MatrixXd x(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(count));
  // DisturbanceFilter's arithmetic, with the coefficients of each distinct interval computed
  // once (decimal time stamps alternate between a few intervals that differ in their last bits).
  std::unordered_map<double, observer::FilterCoefficients> known;
  std::vector<observer::FilterState<double>> filters(count);
  std::vector<double> value(count), previous(count, 0.0);
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
    const bool row = next < rows.size() && rows[next] == k;
    for (std::size_t f = 0; f < count; ++f) {
      double y = 0;
      if (start) {
        filters[f].reset();
      } else {
        filters[f].advance(*c, previous[f], value[f]);
        y = filters[f].output(*c);
      }
      previous[f] = value[f];
      if (row) x(static_cast<Eigen::Index>(next), static_cast<Eigen::Index>(f)) = y;
    }
    if (row) ++next;
  }
  return x;
}

// Adjusted R^2 of y (centred) on the columns of x plus an intercept; the fitted values in `fit`.
double adjusted_r_squared(const Eigen::VectorXd& y, const Eigen::MatrixXd& x, Eigen::VectorXd* fit) {
  const Eigen::Index n = y.size(), p = x.cols();
  Eigen::MatrixXd a(n, p + 1);
  a.col(0).setOnes();
  a.rightCols(p) = x;
  const Eigen::VectorXd beta = a.colPivHouseholderQr().solve(y);
  const Eigen::VectorXd yhat = a * beta;
  const double mean = y.mean();
  const double sst = (y.array() - mean).square().sum();
  const double sse = (y - yhat).squaredNorm();
  if (fit) *fit = yhat.array() - mean;
  if (!(sst > 0) || n <= p + 1) return 0.0;
  const double r2 = 1.0 - sse / sst;
  return 1.0 - (1.0 - r2) * static_cast<double>(n - 1) / static_cast<double>(n - p - 1);
}

}  // namespace

ResidualSplit split_residual(const JointSeries& d, const observer::Gains& gains, const std::vector<double>& residual,
                             const ResidualSplitOptions& options) {
  ResidualSplit out;
  const std::size_t n = d.positions.size();
  if (n == 0 || residual.size() != d.size()) return out;
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

  Eigen::VectorXd y(static_cast<Eigen::Index>(rows.size()));
  for (std::size_t i = 0; i < rows.size(); ++i) y(static_cast<Eigen::Index>(i)) = residual[rows[i]];
  const Eigen::MatrixXd xq = filtered_features(d, gains, position_count, [&](std::size_t k, std::vector<double>& v) {
    for (std::size_t s = 0; s < sums.size(); ++s) {
      double angle = 0;
      for (std::size_t j = sums[s].first; j <= sums[s].second; ++j) angle += d.positions[j][k];
      v[2 * s] = std::sin(angle);
      v[2 * s + 1] = std::cos(angle);
    }
  }, rows);
  const Eigen::MatrixXd xw = filtered_features(d, gains, kVelocityCount, [&](std::size_t k, std::vector<double>& v) {
    const double w = d.dq[k];
    const double sign = w > 0 ? 1.0 : (w < 0 ? -1.0 : 0.0);
    v[0] = w;
    v[1] = w * std::abs(w);
    v[2] = w * w * w;
    v[3] = sign;
    v[4] = sign * std::exp(-(w / 0.1) * (w / 0.1));
  }, rows);

  Eigen::VectorXd explained;
  out.position_fraction = std::max(0.0, adjusted_r_squared(y, xq, &explained));
  out.velocity_fraction = std::max(0.0, adjusted_r_squared(y, xw, nullptr));
  out.samples = rows.size();
  out.position_features = position_count;
  const double mean = y.mean();
  out.residual_rms = std::sqrt((y.array() - mean).square().mean());
  out.explained_rms = std::sqrt(explained.array().square().mean());
  double signal = 0;
  for (std::size_t k : rows) signal += d.r[k] * d.r[k];
  out.signal_rms = std::sqrt(signal / static_cast<double>(rows.size()));
  out.position_dependent = out.position_fraction >= options.position_fraction &&
                           out.position_fraction > out.velocity_fraction &&
                           out.explained_rms >= options.relative_size * out.signal_rms;
  out.computed = true;
  return out;
}

}  // namespace momentum::fit
