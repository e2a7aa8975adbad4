#include "momentum/friction_fit/problem.hpp"

#include <ceres/jet.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace momentum::friction_fit {

using friction::Kind;
using Params = friction::Parameters<double>;

std::vector<int> free_parameters(const FitOptions& o, Kind kind) {
  std::vector<int> free;
  for (int i : model_parameters(kind, o.asymmetric))
    if (!o.fixed[static_cast<std::size_t>(i)]) free.push_back(i);
  return free;
}

Problem::Problem(const JointSeries& series, const observer::Gains& gains, Kind k, const FitOptions& options)
    : data(&series), kind(k), friction(options.friction) {
  const std::size_t n = series.size();
  dt.assign(n, 0.0);
  coefficient_of.assign(n, 0);
  // Time stamps written in decimal make the intervals differ in their last bits from one
  // sample to the next, but take few distinct values: one set of coefficients per value.
  std::unordered_map<double, std::uint32_t> known;
  for (std::size_t i = 1; i < n; ++i) {
    dt[i] = series.t[i] - series.t[i - 1];
    auto [it, added] = known.try_emplace(dt[i], static_cast<std::uint32_t>(coefficients.size()));
    if (added) coefficients.push_back(observer::discretize(gains, dt[i]));
    coefficient_of[i] = it->second;
  }
  if (coefficients.empty()) coefficients.emplace_back();
  free = free_parameters(options, k);
  // Unused parameters get harmless values (the model never reads them).
  fixed = {0.0, 0.0, 0.0, 0.0, 0.0, 1.0};
  for (int i = 0; i < kParameterCount; ++i) {
    const auto u = static_cast<std::size_t>(i);
    if (options.fixed[u]) fixed[u] = *options.fixed[u];
    scale[u] = std::max(std::abs(options.bounds.upper[u]), std::abs(options.bounds.lower[u]));
    if (!(scale[u] > 0)) scale[u] = 1;
  }
  scored = series.scored_count();
}

void Problem::set_unknown_starts(const std::vector<std::size_t>& starts, bool slow_pole) {
  const auto& d = *data;
  nuisance_segment.assign(d.size(), -1);
  nuisance_response.assign(d.size(), 0.0);
  nuisance_norm.clear();
  scored_segment.clear();
  scored_response.clear();
  if (!slow_pole) return;
  for (std::size_t g = 0; g < starts.size(); ++g) {
    double state = 1.0;
    nuisance_norm.push_back(0.0);
    for (std::size_t k = starts[g] + 1; k < d.size() && d.restart[k] == 0; ++k) {
      const auto& c = coefficients[coefficient_of[k]];
      state *= c.a2;
      nuisance_segment[k] = static_cast<std::int32_t>(g);
      nuisance_response[k] = -c.gain * state;
      if (d.scored[k]) nuisance_norm[g] += nuisance_response[k] * nuisance_response[k];
    }
  }
  for (std::size_t k = 0; k < d.size(); ++k)
    if (d.scored[k]) {
      scored_segment.push_back(nuisance_segment[k]);
      scored_response.push_back(nuisance_response[k]);
    }
}

double Problem::cost(const Params& p) const {
  if (!friction::feasible(kind, p)) return std::numeric_limits<double>::infinity();
  double sum = 0;
  const auto& d = *data;
  if (has_nuisance()) {
    std::vector<double> projection(nuisance_norm.size(), 0.0);
    simulate(p, [&](std::size_t k, double y, double) {
      if (d.scored[k]) {
        const double e = d.r[k] - y;
        sum += e * e;
        if (nuisance_segment[k] >= 0) projection[static_cast<std::size_t>(nuisance_segment[k])] += nuisance_response[k] * e;
      }
    });
    for (std::size_t g = 0; g < projection.size(); ++g)
      if (nuisance_norm[g] > 0) sum -= projection[g] * projection[g] / nuisance_norm[g];
    return 0.5 * std::max(sum, 0.0);
  }
  simulate(p, [&](std::size_t k, double y, double) {
    if (d.scored[k]) {
      const double e = d.r[k] - y;
      sum += e * e;
    }
  });
  return 0.5 * sum;
}

namespace {

// The counted residuals e = r - r_model and their Jacobian d e / d x (x: the free parameters
// over `scale`, as Residuals) in one pass of the model with N-dual numbers, N the number of free
// parameters; memory: the m x N result, nothing per sample besides. False where the parameters
// are infeasible.
template <int N>
bool jacobian_pass(const Problem& problem, const std::vector<double>& x,
                   const std::array<double, kParameterCount>& scale, Eigen::VectorXd& e,
                   Eigen::MatrixXd& jacobian) {
  using J = ceres::Jet<double, N>;
  std::array<J, kParameterCount> v{};
  for (int j = 0; j < N; ++j) v[static_cast<std::size_t>(j)] = J(x[static_cast<std::size_t>(j)], j);
  const auto p = problem.assemble<J>(v.data(), scale.data());
  if (!friction::feasible(problem.kind, p)) return false;
  const auto m = static_cast<Eigen::Index>(problem.scored);
  e.resize(m);
  jacobian.resize(m, N);
  const auto& d = *problem.data;
  Eigen::Index row = 0;
  problem.simulate(p, [&](std::size_t k, const J& y, const J&) {
    if (!d.scored[k]) return;
    e(row) = d.r[k] - y.a;
    jacobian.row(row) = -y.v.transpose();
    ++row;
  });
  // On a subset, the residuals the cost sees: each segment's best multiple of the slow state's
  // response removed, a linear projection, so the Jacobian's columns go through it too.
  if (problem.has_nuisance()) {
    problem.remove_nuisance(e.data());
    for (Eigen::Index c = 0; c < jacobian.cols(); ++c) problem.remove_nuisance(jacobian.col(c).data());
  }
  return true;
}

}  // namespace

bool jacobian_at(const Problem& problem, const std::vector<double>& x,
                 const std::array<double, kParameterCount>& scale, Eigen::VectorXd& e,
                 Eigen::MatrixXd& jacobian) {
  switch (x.size()) {
    case 1: return jacobian_pass<1>(problem, x, scale, e, jacobian);
    case 2: return jacobian_pass<2>(problem, x, scale, e, jacobian);
    case 3: return jacobian_pass<3>(problem, x, scale, e, jacobian);
    case 4: return jacobian_pass<4>(problem, x, scale, e, jacobian);
    case 5: return jacobian_pass<5>(problem, x, scale, e, jacobian);
    case 6: return jacobian_pass<6>(problem, x, scale, e, jacobian);
    case 7: return jacobian_pass<7>(problem, x, scale, e, jacobian);
    case 8: return jacobian_pass<8>(problem, x, scale, e, jacobian);
    default: return false;
  }
}

FitMetrics metrics_of(const Problem& problem, const Params& p) {
  const auto& d = *problem.data;
  double sum_r = 0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < d.size(); ++k)
    if (d.scored[k]) sum_r += d.r[k], ++n;
  const double mean = n ? sum_r / static_cast<double>(n) : 0.0;
  FitMetrics m;
  double sse = 0, sst = 0;
  problem.simulate(p, [&](std::size_t k, double y, double) {
    if (!d.scored[k]) return;
    const double e = d.r[k] - y;
    sse += e * e;
    sst += (d.r[k] - mean) * (d.r[k] - mean);
    m.max_abs = std::max(m.max_abs, std::abs(e));
  });
  m.samples = n;
  m.cost = 0.5 * sse;
  m.rms = n ? std::sqrt(sse / static_cast<double>(n)) : 0.0;
  m.r_squared = sst > 0 ? 1.0 - sse / sst : (sse == 0 ? 1.0 : 0.0);
  return m;
}

}  // namespace momentum::friction_fit
