#include "momentum/fit/friction_fit.hpp"

#include <ceres/ceres.h>
#include <ceres/dynamic_autodiff_cost_function.h>

#include <Eigen/SVD>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>
#include <unordered_map>

#include "momentum/stream/error.hpp"
#include "momentum/core/random.hpp"

namespace momentum::fit {

using friction::Kind;
using Params = friction::Parameters<double>;

ParameterBounds paper_bounds() {
  ParameterBounds b;
  b.lower = {6e4, 0.0, 0.0, 1e-5, 1e-5, 1e-7, -3.0, -3.0};
  b.upper = {1e5, 500.0, 10.0, 10.0, 10.0, 0.1, 3.0, 3.0};
  return b;
}

int parameter_index(const std::string& name) {
  for (int i = 0; i < kParameterCount; ++i)
    if (name == friction::kParameterNames[i]) return i;
  return -1;
}

std::vector<int> model_parameters(Kind kind, bool asymmetric) {
  switch (kind) {
    case Kind::lugre: return asymmetric ? std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7} : std::vector<int>{0, 1, 2, 3, 4, 5};
    case Kind::stribeck: return asymmetric ? std::vector<int>{2, 3, 4, 5, 6, 7} : std::vector<int>{2, 3, 4, 5};
    case Kind::coulomb_viscous: return asymmetric ? std::vector<int>{2, 3, 6} : std::vector<int>{2, 3};
  }
  return {};
}

GeneticOptions quick_search() {
  GeneticOptions o;
  o.population = 40;
  o.generations = 60;
  o.restarts = 2;
  o.stall_generations = 20;
  return o;
}

bool PolishOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* text) {
    if (why) *why = text;
    return false;
  };
  if (max_iterations < 1) return fail("polish: max iterations must be >= 1");
  if (!(function_tolerance > 0)) return fail("polish: function tolerance must be > 0");
  if (!(parameter_tolerance > 0)) return fail("polish: parameter tolerance must be > 0");
  return true;
}

namespace {

// Smallest value a parameter may take for a model: > 0 (strictly) or >= 0.
bool must_be_positive(Kind kind, int i) {
  if (i >= 6) return false;  // asymmetries have either sign
  if (i == 0) return kind == Kind::lugre;
  if (i == 3) return kind != Kind::coulomb_viscous;
  return i == 4 || i == 5;  // tau_s, w_s (used only by LuGre and Stribeck)
}

std::vector<int> free_parameters(const FitOptions& o, Kind kind) {
  std::vector<int> free;
  for (int i : model_parameters(kind, o.asymmetric))
    if (!o.fixed[static_cast<std::size_t>(i)]) free.push_back(i);
  return free;
}

// The levels of both directions are positive (non-negative for Coulomb-viscous): outside this
// the friction model is meaningless (the LuGre rate would change sign).
template <class T>
bool feasible(Kind kind, const friction::Parameters<T>& p) {
  using std::abs;
  if (kind == Kind::coulomb_viscous) return !(abs(p.delta_c) > p.tau_c);
  return abs(p.delta_c) < p.tau_c && abs(p.delta_s) < p.tau_s;
}

}  // namespace

bool FitOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& text) {
    if (why) *why = text;
    return false;
  };
  if (!friction.IsValid(why)) return false;
  if (!global.IsValid(why)) return false;
  if (!polish.IsValid(why)) return false;
  if (!search_subset.IsValid(why)) return false;
  if (!(identifiability_threshold > 0)) return fail("identifiability threshold must be > 0");
  std::vector<Kind> kinds{kind};
  if (kind == Kind::lugre && compare_static) kinds.push_back(Kind::stribeck);
  for (Kind k : kinds) {
    for (int i : model_parameters(k, asymmetric)) {
      const auto u = static_cast<std::size_t>(i);
      const std::string name = friction::kParameterNames[i];
      const bool signed_parameter = i >= 6;
      if (fixed[u]) {
        const double v = *fixed[u];
        if (!std::isfinite(v) || (v < 0 && !signed_parameter) || (must_be_positive(k, i) && v == 0))
          return fail(name + " = " + std::to_string(v) + " is not a valid fixed value");
        continue;
      }
      const double lo = bounds.lower[u], hi = bounds.upper[u];
      if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi))
        return fail(name + ": bounds must be finite with lower < upper");
      if ((lo < 0 && !signed_parameter) || (must_be_positive(k, i) && lo <= 0))
        return fail(name + ": lower bound must be " + (must_be_positive(k, i) ? "> 0" : ">= 0"));
    }
    if (free_parameters(*this, k).empty()) return fail("every parameter is fixed: nothing to fit");
  }
  return true;
}

namespace {

// One model on one joint's data, with everything per sample precomputed: the interval and
// the observer filter's coefficients (identical consecutive intervals share them).
struct Problem {
  const JointSeries* data = nullptr;
  Kind kind = Kind::lugre;
  friction::Options friction;
  std::vector<double> dt;                                 // dt[0] = 0
  std::vector<observer::FilterCoefficients> coefficients; // one per distinct interval
  std::vector<std::uint32_t> coefficient_of;              // per sample
  std::vector<int> free;
  std::array<double, kParameterCount> fixed{};            // values of the parameters not free
  std::array<double, kParameterCount> scale{};            // Ceres works on x / scale
  std::size_t scored = 0;
  // Unknown filter states of a search subset (set_unknown_starts); empty otherwise.
  std::vector<std::int32_t> nuisance_segment;  // per sample: its segment, -1 none
  std::vector<double> nuisance_response;       // per sample: h
  std::vector<double> nuisance_norm;           // per segment: sum of h^2 over counted samples
  std::vector<std::int32_t> scored_segment;    // per counted sample
  std::vector<double> scored_response;         // per counted sample

  Problem(const JointSeries& series, const observer::Gains& gains, Kind k,
          const FitOptions& options)
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

  // A search subset's segments start where the observer had been running: the observer's filter
  // state there is unknown, and the model's starts at rest. The filter is linear, so the
  // difference in its slow state (the second-order observer's K2 pole, seconds long, too slow
  // for a short warm-up) adds a known response h to r, decaying with that pole, times an
  // unknown size per segment; the cost takes the best size for each segment (a linear least
  // squares in closed form), as if the filter had been warmed up for ever. The fast pole and
  // the friction state settle within the segment's uncounted warm-up. `starts`: first sample
  // of each such segment; `slow_pole`: false for a first-order observer (no slow state).
  void set_unknown_starts(const std::vector<std::size_t>& starts, bool slow_pole) {
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
  bool has_nuisance() const { return !nuisance_norm.empty(); }

  // Removes from the counted residuals e (in counted order) each segment's best multiple of h.
  template <class T>
  void remove_nuisance(T* e) const {
    std::vector<T> projection(nuisance_norm.size(), T(0));
    for (std::size_t m = 0; m < scored_segment.size(); ++m)
      if (scored_segment[m] >= 0) projection[static_cast<std::size_t>(scored_segment[m])] += scored_response[m] * e[m];
    for (std::size_t g = 0; g < projection.size(); ++g)
      projection[g] = nuisance_norm[g] > 0 ? projection[g] / nuisance_norm[g] : T(0);
    for (std::size_t m = 0; m < scored_segment.size(); ++m)
      if (scored_segment[m] >= 0) e[m] -= projection[static_cast<std::size_t>(scored_segment[m])] * scored_response[m];
  }

  // Parameters from the free values x: physical units when `scales` is null, otherwise
  // x[j] * scales[free[j]].
  template <class T>
  friction::Parameters<T> assemble(const T* x, const double* scales) const {
    T all[kParameterCount];
    for (int i = 0; i < kParameterCount; ++i) all[i] = T(fixed[static_cast<std::size_t>(i)]);
    for (std::size_t j = 0; j < free.size(); ++j) {
      const auto i = static_cast<std::size_t>(free[j]);
      all[i] = scales ? x[j] * scales[i] : x[j];
    }
    return friction::Parameters<T>::from_array(all);
  }

  // Runs the model over every sample: sink(k, r_model, tau_f). The observer's filter is
  // advanced with its own state type and coefficients (exactly DisturbanceFilter::step, with
  // the coefficients computed once instead of per call), restarted at rest where the
  // observer restarted.
  // With substeps > 1 the friction model is advanced in that many equal steps per interval,
  // the velocity interpolated linearly between the samples (a finer discretisation of the
  // same model, used to measure how much the estimate depends on sub-sample dynamics).
  template <class T, class Sink>
  void simulate(const friction::Parameters<T>& p, Sink&& sink, int substeps = 1) const {
    friction::JointFriction<T> model(kind, p, friction);
    observer::FilterState<T> filter;
    T previous = T(0);
    const auto& d = *data;
    for (std::size_t k = 0; k < d.size(); ++k) {
      if (d.restart[k] >= 2) model.reset();
      T tau;
      if (substeps > 1 && d.restart[k] < 2) {
        for (int s = 1; s <= substeps; ++s) {
          const double f = static_cast<double>(s) / substeps;
          tau = model.step(T(d.dq[k - 1] + f * (d.dq[k] - d.dq[k - 1])), dt[k] / substeps);
        }
      } else {
        tau = model.step(T(d.dq[k]), dt[k]);
      }
      if (d.restart[k]) {
        filter.reset();
        previous = tau;
        sink(k, T(0), tau);
        continue;
      }
      const auto& c = coefficients[coefficient_of[k]];
      filter.advance(c, previous, tau);
      previous = tau;
      sink(k, filter.output(c), tau);
    }
  }

  // 1/2 sum of squared errors over the counted samples, for parameters in physical units;
  // infinite where a direction's level is not positive.
  double cost(const Params& p) const {
    if (!feasible(kind, p)) return std::numeric_limits<double>::infinity();
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
};

// Ceres residuals r - r_model over the counted samples; parameter i is x * scale[i].
struct Residuals {
  const Problem* problem;
  std::array<double, kParameterCount> scale;
  template <class T>
  bool operator()(T const* const* x, T* residuals) const {
    const auto p = problem->assemble<T>(x[0], scale.data());
    if (!feasible(problem->kind, p)) return false;  // Ceres rejects the step
    const auto& d = *problem->data;
    std::size_t m = 0;
    problem->simulate(p, [&](std::size_t k, const T& y, const T&) {
      if (d.scored[k]) residuals[m++] = T(d.r[k]) - y;
    });
    if (problem->has_nuisance()) problem->remove_nuisance(residuals);
    return true;
  }
};

// The upper triangular factor R of a tall matrix a = Q R (a.cols() square), by Householder QR
// of R stacked on one chunk of rows after another: the memory of a chunk, not a copy of a.
Eigen::MatrixXd triangular_factor(const Eigen::MatrixXd& a) {
  constexpr Eigen::Index kChunk = 4096;
  const Eigen::Index p = a.cols();
  Eigen::MatrixXd stack(p + kChunk, p);
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(p, p);
  for (Eigen::Index begin = 0; begin < a.rows(); begin += kChunk) {
    const Eigen::Index rows = std::min(kChunk, a.rows() - begin);
    stack.topRows(p) = r;
    stack.middleRows(p, rows) = a.middleRows(begin, rows);
    Eigen::Ref<Eigen::MatrixXd> block = stack.topRows(p + rows);
    Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(block);  // in place
    r = qr.matrixQR().topRows(p).triangularView<Eigen::Upper>();
  }
  return r;
}

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
  if (!feasible(problem.kind, p)) return false;
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
  return true;
}

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

// Levenberg-Marquardt on all the data from a point the polish on the search subset found (so
// close that a few steps do): each step costs one dual-number pass and one plain pass of the
// model. Bounds as the polish treats them (a parameter on a bound whose gradient points out
// is held). On return x is the best point found, e and jacobian are at x (when the last step
// was too small to matter: at the point before it). Returns the number of passes with
// derivatives; 0 when the first one failed.
int refine_on_all(const Problem& problem, std::vector<double>& x, const std::vector<double>& lower,
                  const std::vector<double>& upper, Eigen::VectorXd& e, Eigen::MatrixXd& jacobian,
                  std::uint64_t* plain_passes) {
  const auto n = static_cast<Eigen::Index>(x.size());
  auto physical_cost = [&](const std::vector<double>& v) {
    std::vector<double> p(v.size());
    for (std::size_t j = 0; j < v.size(); ++j) p[j] = v[j] * problem.scale[static_cast<std::size_t>(problem.free[j])];
    ++*plain_passes;
    return problem.cost(problem.assemble(p.data(), nullptr));
  };
  int passes = 0;
  double lambda = 1e-6;
  for (int iteration = 0; iteration < 20; ++iteration) {
    if (!jacobian_at(problem, x, problem.scale, e, jacobian)) return passes;
    ++passes;
    const double cost = 0.5 * e.squaredNorm();
    const Eigen::MatrixXd a = jacobian.transpose() * jacobian;
    const Eigen::VectorXd g = jacobian.transpose() * e;
    std::vector<Eigen::Index> open;
    for (Eigen::Index j = 0; j < n; ++j) {
      const auto u = static_cast<std::size_t>(j);
      const double tol = 1e-9 * (upper[u] - lower[u]);
      const bool out_low = x[u] <= lower[u] + tol && g(j) > 0;
      const bool out_high = x[u] >= upper[u] - tol && g(j) < 0;
      if (!out_low && !out_high) open.push_back(j);
    }
    if (open.empty()) return passes;
    const auto k = static_cast<Eigen::Index>(open.size());
    Eigen::MatrixXd sub(k, k);
    Eigen::VectorXd rhs(k);
    for (Eigen::Index a1 = 0; a1 < k; ++a1) {
      rhs(a1) = -g(open[static_cast<std::size_t>(a1)]);
      for (Eigen::Index b1 = 0; b1 < k; ++b1) sub(a1, b1) = a(open[static_cast<std::size_t>(a1)], open[static_cast<std::size_t>(b1)]);
    }
    bool accepted = false, negligible = false;
    for (int attempt = 0; attempt < 8 && !accepted; ++attempt) {
      Eigen::MatrixXd damped = sub;
      for (Eigen::Index d = 0; d < k; ++d) damped(d, d) += lambda * std::max(sub(d, d), 1e-300);
      const Eigen::VectorXd step = damped.ldlt().solve(rhs);
      if (!step.allFinite()) {
        lambda *= 10;
        continue;
      }
      std::vector<double> trial = x;
      double largest = 0;
      for (Eigen::Index a1 = 0; a1 < k; ++a1) {
        const auto u = static_cast<std::size_t>(open[static_cast<std::size_t>(a1)]);
        trial[u] = std::clamp(x[u] + step(a1), lower[u], upper[u]);
        largest = std::max(largest, std::abs(trial[u] - x[u]) / std::max(std::abs(x[u]), 1e-12));
      }
      const double trial_cost = physical_cost(trial);
      if (trial_cost < cost) {
        accepted = true;
        negligible = (cost - trial_cost) <= 1e-12 * cost || largest < 1e-10;
        lambda = std::max(lambda / 10, 1e-12);
        if (negligible) return passes;  // e and jacobian stay those of x: the step changes nothing that matters
        x = std::move(trial);
      } else {
        lambda *= 10;
      }
    }
    if (!accepted) {
      return passes;  // no step lowers the cost: x is the minimum to rounding
    }
  }
  jacobian_at(problem, x, problem.scale, e, jacobian);
  return passes + 1;
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

// How far the residuals stay correlated, in samples: the last lag of Geyer's initial positive
// sequence (pairs of lags summed while their sum stays positive, up to a quarter of the data), 0
// for white residuals. On long data every `stride`-th product estimates a lag's covariance.
std::size_t correlated_lags(const std::vector<double>& e) {
  const std::size_t n = e.size();
  if (n < 8) return 0;
  double mean = 0;
  for (double v : e) mean += v;
  mean /= static_cast<double>(n);
  double c0 = 0;
  for (double v : e) c0 += (v - mean) * (v - mean);
  if (!(c0 > 0)) return 0;
  const std::size_t stride = std::max<std::size_t>(1, n / 100000);
  auto rho = [&](std::size_t lag) {
    double c = 0;
    std::size_t terms = 0;
    for (std::size_t k = lag; k < n; k += stride, ++terms) c += (e[k] - mean) * (e[k - lag] - mean);
    return stride == 1 ? c / c0 : c * static_cast<double>(n - lag) / static_cast<double>(terms) / c0;
  };
  std::size_t last = 0;
  for (std::size_t lag = 1; lag + 1 <= n / 4; lag += 2) {
    if (!(rho(lag) + rho(lag + 1) > 0)) break;
    last = lag + 1;
  }
  return last;
}

// The covariance of the scores (rows s_k of a matrix, taken at sample indices index[k], sorted)
// that Newey and West's estimator gives with Bartlett weights over `lag` samples:
// sum over pairs of (1 - |index_k - index_l| / (lag + 1))+ s_k s_l^T. Computed as the sum of
// W W^T over every window W of lag + 1 consecutive sample indices (the sum of the scores in
// it), divided by lag + 1: the pairs' weights are the numbers of windows they share. O(samples).
Eigen::MatrixXd bartlett_score_covariance(const Eigen::MatrixXd& scores, const std::vector<std::size_t>& index,
                                          std::size_t lag) {
  const Eigen::Index p = scores.cols();
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(p, p);
  const std::size_t rows = index.size();
  if (rows == 0) return m;
  Eigen::VectorXd window = Eigen::VectorXd::Zero(p);
  std::size_t in = 0, out = 0;  // rows [out, in) are in the window
  // Windows [t - lag, t] for every t from index[0] to index.back() + lag, skipping those with
  // no row (their sum is 0).
  std::size_t t = index[0];  // the window is [t - lag, t]
  const std::size_t last = index.back() + lag;
  while (t <= last) {
    while (in < rows && index[in] <= t) window += scores.row(static_cast<Eigen::Index>(in++)).transpose();
    while (out < in && index[out] + lag < t) window -= scores.row(static_cast<Eigen::Index>(out++)).transpose();
    if (out == in) {  // an empty window: jump to the next row
      if (in == rows) break;
      t = index[in];
      window.setZero();  // no rounding left over from an emptied window
      continue;
    }
    m.selfadjointView<Eigen::Lower>().rankUpdate(window);
    ++t;
  }
  const Eigen::MatrixXd full = m.selfadjointView<Eigen::Lower>();
  return full / static_cast<double>(lag + 1);
}

std::string format(const char* fmt, double a) {
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, fmt, a);
  return buffer;
}

// Why a flagged parameter is not identifiable, in terms of the data.
std::string explain(const Problem& problem, const ModelFit& fit, int i) {
  const auto& d = *problem.data;
  const Params& p = fit.parameters;
  const double rate = 1.0 / std::max(d.median_dt(), 1e-12);
  std::string why;
  if (i == 0 || i == 1) {
    // The bristle state only leaves its steady state for ~ g / (sigma0 |w|) seconds: samples
    // where that is not small against the sample interval carry sigma0 and sigma1.
    std::size_t transient = 0;
    for (std::size_t k = 1; k < d.size(); ++k) {
      if (!d.scored[k]) continue;
      const double g = friction::stribeck_level(p, d.dq[k]);
      if (p.sigma0 * std::abs(d.dq[k]) * problem.dt[k] / g < 3.0) ++transient;
    }
    why = "bristle dynamics settle within " +
          format("%.2g", friction::stribeck_level(p, 0.0) / p.sigma0) +
          " rad of travel; only " + std::to_string(transient) + " of " +
          std::to_string(fit.metrics.samples) + " samples at " + format("%.4g", rate) +
          " Hz see them (near velocity reversals)";
  } else if (i == 5) {
    std::size_t slow = 0;
    for (std::size_t k = 0; k < d.size(); ++k)
      if (d.scored[k] && std::abs(d.dq[k]) < 2.0 * p.w_s) ++slow;
    why = "only " + std::to_string(slow) + " samples move slower than 2 w_s";
  }
  // The strongest partner, if any.
  double strongest = 0;
  int partner = -1;
  for (std::size_t a = 0; a < fit.free.size(); ++a) {
    if (fit.free[a] != i) continue;
    for (std::size_t b = 0; b < fit.free.size(); ++b) {
      if (a == b) continue;
      const double c = fit.correlation(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
      if (std::isfinite(c) && std::abs(c) > std::abs(strongest)) strongest = c, partner = fit.free[b];
    }
  }
  if (partner >= 0 && std::abs(strongest) >= 0.95) {
    if (!why.empty()) why += "; ";
    why += std::string("correlated with ") + friction::kParameterNames[partner] + " (" +
           format("%.3f", strongest) + ")";
  }
  return why;
}

ModelFit fit_model(const JointSeries& data, const observer::Gains& gains, Kind kind,
                   const FitOptions& options, std::uint64_t seed, int joint,
                   const JointProgressCallback& progress) {
  const auto start = std::chrono::steady_clock::now();
  Problem problem(data, gains, kind, options);
  const std::size_t nfree = problem.free.size();
  ModelFit fit;
  fit.kind = kind;
  fit.asymmetric = options.asymmetric;
  fit.free = problem.free;

  // The search's samples: all of them, or on long data a constant-size set of windows.
  std::vector<std::size_t> segment_start, origin;
  const JointSeries subset = search_subset(data, gains, options.search_subset, &segment_start, &fit.subset, &origin);
  std::optional<Problem> subset_problem;
  if (fit.subset.used) {
    subset_problem.emplace(subset, gains, kind, options);
    std::vector<std::size_t> unknown;
    for (std::size_t g : segment_start)
      if (data.restart[origin[g]] == 0) unknown.push_back(g);
    subset_problem->set_unknown_starts(unknown, gains.k2 > 0);
  }
  const Problem& search = fit.subset.used ? *subset_problem : problem;

  // Global search in physical units over the free parameters' box.
  Bounds box;
  for (int i : problem.free) {
    box.lower.push_back(options.bounds.lower[static_cast<std::size_t>(i)]);
    box.upper.push_back(options.bounds.upper[static_cast<std::size_t>(i)]);
  }
  GlobalOptions global = options.global;
  global.genetic.seed = seed;
  if (progress) {
    const char* stage = friction::kind_name(kind);
    global.genetic.on_generation = [&progress, joint, stage](const SearchProgress& s) {
      progress({joint, stage, s});
    };
  }
  fit.global = minimize_global(
      [&](std::span<const double> x) { return search.cost(search.assemble(x.data(), nullptr)); },
      box, global);
  if (!std::isfinite(fit.global.cost))
    throw Error("joint " + std::to_string(joint) + ": " + friction::kind_name(kind) +
                " model: the cost is not finite anywhere in the bounds");
  fit.parameters = problem.assemble(fit.global.best.data(), nullptr);
  fit.global_metrics = metrics_of(problem, fit.parameters);
  fit.evaluations = fit.global.evaluations;

  // Polish, then covariance, in scaled parameters x / scale (so that the trust region and the
  // rank decisions see comparable columns). The polish starts from the best of every run of
  // the global search (the cost has several basins; the runs usually find different ones)
  // and keeps the lowest end point.
  auto scaled = [&](const std::vector<double>& physical) {
    std::vector<double> v(nfree);
    for (std::size_t j = 0; j < nfree; ++j) v[j] = physical[j] / problem.scale[static_cast<std::size_t>(problem.free[j])];
    return v;
  };
  auto physical = [&](const std::vector<double>& v) {
    std::vector<double> p(nfree);
    for (std::size_t j = 0; j < nfree; ++j) p[j] = v[j] * problem.scale[static_cast<std::size_t>(problem.free[j])];
    return problem.assemble(p.data(), nullptr);
  };
  auto add_block = [&](ceres::Problem& cp, std::vector<double>& v, const Problem& on) {
    auto* cost = new ceres::DynamicAutoDiffCostFunction<Residuals, kParameterCount>(new Residuals{&on, on.scale});
    cost->AddParameterBlock(static_cast<int>(nfree));
    cost->SetNumResiduals(static_cast<int>(on.scored));
    cp.AddResidualBlock(cost, nullptr, v.data());
    for (std::size_t j = 0; j < nfree; ++j) {
      const auto i = static_cast<std::size_t>(problem.free[j]);
      cp.SetParameterLowerBound(v.data(), static_cast<int>(j), options.bounds.lower[i] / problem.scale[i]);
      cp.SetParameterUpperBound(v.data(), static_cast<int>(j), options.bounds.upper[i] / problem.scale[i]);
    }
  };
  std::vector<double> x = scaled(fit.global.best);
  if (options.polish.enabled) {
    if (progress) progress({joint, "polish", {0, 0, fit.global.cost, fit.evaluations}});
    ceres::Solver::Options so;
    so.minimizer_type = ceres::TRUST_REGION;
    so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = options.polish.max_iterations;
    so.function_tolerance = options.polish.function_tolerance;
    so.parameter_tolerance = options.polish.parameter_tolerance;
    so.gradient_tolerance = 1e-16;
    so.logging_type = ceres::SILENT;
    so.minimizer_progress_to_stdout = false;
    so.num_threads = 1;
    std::vector<std::vector<double>> starts = fit.global.run_best;
    if (starts.empty()) starts.push_back(fit.global.best);
    double best_cost = fit.global.cost;  // on the search's samples
    int improved = 0;
    // Ceres' projected steps stall when the unconstrained step leaves the box (a bristle
    // parameter pinned at its bound makes it "converge" far from the optimum of the others):
    // so parameters that end on a bound are held there and the rest solved again, and held
    // ones whose gradient points back into the box are released (an active-set loop).
    auto at_bound = [&](const std::vector<double>& v, std::size_t j) {
      const auto i = static_cast<std::size_t>(problem.free[j]);
      const double lo = options.bounds.lower[i] / problem.scale[i], hi = options.bounds.upper[i] / problem.scale[i];
      const double tol = 1e-9 * (hi - lo);
      return v[j] <= lo + tol ? -1 : (v[j] >= hi - tol ? +1 : 0);
    };
    // Polishes v in place on `on`; false when Ceres found no usable solution.
    auto polish_from = [&](std::vector<double>& v, const Problem& on, ceres::Solver::Summary& summary) {
      std::vector<int> held;
      for (int round = 0; round < 4; ++round) {
        ceres::Problem cp;
        add_block(cp, v, on);
        if (!held.empty()) {
          if (held.size() == nfree) break;
          cp.SetManifold(v.data(), new ceres::SubsetManifold(static_cast<int>(nfree), held));
        }
        ceres::Solve(so, &cp, &summary);
        fit.polish_iterations += static_cast<int>(summary.iterations.size()) - 1;
        fit.polish_residual_evaluations += static_cast<std::uint64_t>(summary.num_residual_evaluations);
        fit.polish_jacobian_evaluations += static_cast<std::uint64_t>(summary.num_jacobian_evaluations);
        if (!summary.IsSolutionUsable()) break;
        // The full gradient (no manifold) decides which bounds stay active.
        ceres::Problem full;
        add_block(full, v, on);
        std::vector<double> gradient;
        double c = 0;
        if (!full.Evaluate(ceres::Problem::EvaluateOptions(), &c, nullptr, &gradient, nullptr)) break;
        std::vector<int> next;
        for (std::size_t j = 0; j < nfree; ++j) {
          const int side = at_bound(v, j);
          // Descent is -gradient: it leaves the box at the lower bound when gradient > 0.
          if ((side < 0 && gradient[j] > 0) || (side > 0 && gradient[j] < 0)) next.push_back(static_cast<int>(j));
        }
        if (next == held) break;
        held = next;
      }
      return summary.IsSolutionUsable();
    };
    // On a subset the cost of the global search is not the cost of all the data: the starts
    // are polished on the subset, and the best end point once more on all the data.
    for (const auto& start_point : starts) {
      std::vector<double> v = scaled(start_point);
      ceres::Solver::Summary summary;
      if (!polish_from(v, search, summary)) continue;
      const Params candidate = physical(v);
      const double c = search.cost(candidate);
      if (c <= best_cost) {
        best_cost = c;
        fit.parameters = candidate;
        x = v;
        fit.polish_message = summary.BriefReport();
        ++improved;
      }
    }
    if (!improved) fit.polish_message = "no polish improved on the global search; kept its result";
    else if (starts.size() > 1)
      fit.polish_message = "best of " + std::to_string(starts.size()) + " starts: " + fit.polish_message;
    fit.evaluations += fit.polish_residual_evaluations + fit.polish_jacobian_evaluations;
  }
  // The Jacobian over every counted sample (the uncertainties' basis); on a subset, first the
  // steps that take the subset's optimum to the optimum of all the data.
  Eigen::VectorXd final_residuals;
  Eigen::MatrixXd jacobian;
  bool have_jacobian = false;
  if (fit.subset.used && options.polish.enabled) {
    std::vector<double> lower(nfree), upper(nfree);
    for (std::size_t j = 0; j < nfree; ++j) {
      const auto i = static_cast<std::size_t>(problem.free[j]);
      lower[j] = options.bounds.lower[i] / problem.scale[i];
      upper[j] = options.bounds.upper[i] / problem.scale[i];
    }
    std::uint64_t plain = 0;
    const double before = problem.cost(fit.parameters);
    std::vector<double> v = x;
    const int passes = refine_on_all(problem, v, lower, upper, final_residuals, jacobian, &plain);
    have_jacobian = passes > 0;
    const Params candidate = physical(v);
    const double after = problem.cost(candidate);
    if (have_jacobian && after <= before) {
      fit.parameters = candidate;
      x = v;
    }
    fit.polish_jacobian_evaluations += static_cast<std::uint64_t>(passes);
    fit.polish_residual_evaluations += plain;
    fit.evaluations += static_cast<std::uint64_t>(passes) + plain;
    fit.polish_message += "; on all " + std::to_string(problem.scored) + " samples: cost " + format("%.6g", before) +
                          " -> " + format("%.6g", std::min(before, after)) + " Nm^2 in " + std::to_string(passes) +
                          " passes with derivatives";
  }
  if (!have_jacobian) have_jacobian = jacobian_at(problem, x, problem.scale, final_residuals, jacobian);
  if (!have_jacobian) jacobian.resize(0, 0);
  fit.metrics = metrics_of(problem, fit.parameters);

  // The residuals, and their sample numbers (the counted samples only, as the Jacobian's rows).
  std::vector<double> residuals;
  std::vector<std::size_t> residual_index;
  {
    const auto& d = *problem.data;
    problem.simulate(fit.parameters, [&](std::size_t k, double y, double) {
      if (!d.scored[k]) return;
      residuals.push_back(d.r[k] - y);
      residual_index.push_back(k);
    });
  }
  const double dof = static_cast<double>(problem.scored) - static_cast<double>(nfree);
  const double variance = dof > 0 ? 2.0 * fit.metrics.cost / dof : std::numeric_limits<double>::quiet_NaN();

  // The Jacobian with unit columns: its condition number, and its null directions (singular
  // values below 1e-7 of the largest, i.e. eigenvalues of J^T J below Ceres' default 1e-14).
  // held[j]: free parameter j is in a null direction and is held fixed for the covariance of
  // the others; undetermined[j]: the reason it is not determined by the data at all.
  std::vector<bool> held(nfree, false);
  std::vector<std::string> undetermined(nfree);
  std::vector<double> column_norm(nfree, 0.0);
  if (jacobian.rows() > 0 && jacobian.allFinite()) {
    Eigen::MatrixXd unit = jacobian;
    for (Eigen::Index c = 0; c < unit.cols(); ++c) {
      const double norm = unit.col(c).norm();
      column_norm[static_cast<std::size_t>(c)] = norm;
      if (norm > 0) unit.col(c) /= norm;
    }
    // The singular values and V of a tall J are those of its triangular factor R: factored in
    // place, no copy of the long matrix beyond `unit`.
    if (unit.rows() > unit.cols()) unit = triangular_factor(unit);
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(unit, Eigen::ComputeThinV);
    const auto& s = svd.singularValues();
    const Eigen::Index last = s.size() - 1;
    fit.condition_number = s(last) > 0 ? s(0) / s(last) : std::numeric_limits<double>::infinity();
    for (Eigen::Index k = last; k >= 0 && !(s(k) > 1e-7 * s(0)); --k) {
      const Eigen::VectorXd v = svd.matrixV().col(k);
      Eigen::Index pick = -1;
      for (Eigen::Index j = 0; j < v.size(); ++j)
        if (!held[static_cast<std::size_t>(j)] && (pick < 0 || std::abs(v(j)) > std::abs(v(pick)))) pick = j;
      if (pick >= 0) held[static_cast<std::size_t>(pick)] = true;
      std::string members;
      for (Eigen::Index j = 0; j < v.size(); ++j)
        if (std::abs(v(j)) >= 0.2) members += std::string(members.empty() ? "" : ", ") + friction::kParameterNames[problem.free[static_cast<std::size_t>(j)]];
      for (Eigen::Index j = 0; j < v.size(); ++j)
        if (std::abs(v(j)) >= 0.2 && undetermined[static_cast<std::size_t>(j)].empty())
          undetermined[static_cast<std::size_t>(j)] =
              members.find(',') == std::string::npos
                  ? "not identifiable: the data do not depend on it"
                  : "not identifiable: the data do not separate " + members + " (rank-deficient Jacobian)";
    }
  } else {
    fit.covariance_note = "the Jacobian could not be evaluated";
  }

  // Systematic sensitivities, as first-order parameter shifts: the change dx that absorbs a
  // change dy of the model, dx = lstsq(J, dy) over the determined parameters (J is
  // d(r - y)/dx, so J dx = dy).
  //  - sub-sample dynamics: dy = the model's own finer discretisation minus itself;
  //  - velocity noise (errors in the variable that drives the model): dy = the mean change of
  //    the model when the measured velocity gets a second dose of its own noise (4 draws).
  //    Noise in dq biases a nonlinear model in proportion to its variance, so the shift from
  //    one dose to two estimates the shift from none to one (the first step of SIMEX).
  std::vector<double> shift(nfree, std::numeric_limits<double>::quiet_NaN());
  std::vector<double> velocity_shift(nfree, std::numeric_limits<double>::quiet_NaN());
  fit.velocity_noise = estimate_velocity_noise(data);
  if (jacobian.rows() > 0 && jacobian.allFinite()) {
    const auto& d = *problem.data;
    auto counted_model = [&](const Problem& pr, int substeps) {
      std::vector<double> y;
      y.reserve(pr.scored);
      pr.simulate(fit.parameters, [&](std::size_t k, double v, double) {
        if (d.scored[k]) y.push_back(v);
      }, substeps);
      return y;
    };
    const std::vector<double> coarse = counted_model(problem, 1);
    std::vector<Eigen::Index> keep;
    for (std::size_t j = 0; j < nfree; ++j)
      if (!held[j]) keep.push_back(static_cast<Eigen::Index>(j));
    if (!keep.empty() && coarse.size() == static_cast<std::size_t>(jacobian.rows())) {
      Eigen::MatrixXd sub(jacobian.rows(), static_cast<Eigen::Index>(keep.size()));
      for (std::size_t c = 0; c < keep.size(); ++c) sub.col(static_cast<Eigen::Index>(c)) = jacobian.col(keep[c]);
      const Eigen::ColPivHouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(sub);  // in place: no copy
      auto absorb = [&](const Eigen::VectorXd& dy, std::vector<double>& out) {
        const Eigen::VectorXd dx = qr.solve(dy);
        for (std::size_t c = 0; c < keep.size(); ++c) {
          const auto j = static_cast<std::size_t>(keep[c]);
          out[j] = dx(static_cast<Eigen::Index>(c)) * problem.scale[static_cast<std::size_t>(problem.free[j])];
        }
      };
      const std::vector<double> fine = counted_model(problem, 4);
      Eigen::VectorXd dy(jacobian.rows());
      for (Eigen::Index k = 0; k < dy.size(); ++k)
        dy(k) = fine[static_cast<std::size_t>(k)] - coarse[static_cast<std::size_t>(k)];
      absorb(dy, shift);
      if (fit.velocity_noise > 0) {
        constexpr int kDraws = 4;
        core::Random rng(derive_seed(seed, 0x5ee0));
        dy.setZero();
        JointSeries noisy;  // the data without positions (the model does not read them)
        noisy.t = data.t;
        noisy.r = data.r;
        noisy.restart = data.restart;
        noisy.scored = data.scored;
        const Problem perturbed(noisy, gains, kind, options);
        for (int draw = 0; draw < kDraws; ++draw) {
          noisy.dq = data.dq;
          for (auto& v : noisy.dq) v += fit.velocity_noise * rng.normal_unpaired();
          const std::vector<double> y = counted_model(perturbed, 1);
          for (Eigen::Index k = 0; k < dy.size(); ++k)
            dy(k) += (y[static_cast<std::size_t>(k)] - coarse[static_cast<std::size_t>(k)]) / kDraws;
        }
        absorb(dy, velocity_shift);
      } else {
        std::fill(velocity_shift.begin(), velocity_shift.end(), 0.0);
      }
    }
  }

  fit.correlation = Eigen::MatrixXd::Constant(static_cast<Eigen::Index>(nfree), static_cast<Eigen::Index>(nfree),
                                              std::numeric_limits<double>::quiet_NaN());
  std::vector<double> standard_error(nfree, std::numeric_limits<double>::quiet_NaN());
  std::vector<int> constant;
  for (std::size_t j = 0; j < nfree; ++j)
    if (held[j]) constant.push_back(static_cast<int>(j));
  if (!std::isfinite(variance)) {
    fit.covariance_note = "too few samples for a covariance";
  } else if (fit.covariance_note.empty() && constant.size() < nfree) {
    // The covariance in parameters y_j = x_j |J_j|, so that every Jacobian column has unit
    // norm and the rank test is scale-free (raw columns differ by many decades, e.g. sigma0
    // against tau_c, which would make a well-determined problem look singular): (U^T U)^-1
    // over the columns U not held, from their SVD, refused when its reciprocal condition
    // number (squared singular values) is below 1e-14, as Ceres' DENSE_SVD covariance does.
    std::array<double, kParameterCount> unit_scale = problem.scale;
    for (std::size_t j = 0; j < nfree; ++j) {
      const auto i = static_cast<std::size_t>(problem.free[j]);
      const double n = column_norm[j] > 0 ? column_norm[j] : 1.0;
      unit_scale[i] = problem.scale[i] / n;
    }
    std::vector<Eigen::Index> kept;
    for (std::size_t j = 0; j < nfree; ++j)
      if (!held[j]) kept.push_back(static_cast<Eigen::Index>(j));
    Eigen::MatrixXd unit(jacobian.rows(), static_cast<Eigen::Index>(kept.size()));
    for (std::size_t c = 0; c < kept.size(); ++c) {
      const double n = column_norm[static_cast<std::size_t>(kept[c])];
      unit.col(static_cast<Eigen::Index>(c)) = jacobian.col(kept[c]) / (n > 0 ? n : 1.0);
    }
    // (Its singular values and V are those of U's triangular factor, which takes no copy of U.)
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(unit.rows() > unit.cols() ? triangular_factor(unit) : unit,
                                          Eigen::ComputeThinV);
    const auto& sv = svd.singularValues();
    Eigen::MatrixXd c = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(nfree), static_cast<Eigen::Index>(nfree));
    const bool invertible = sv.size() > 0 && sv(sv.size() - 1) > 0 &&
                            std::pow(sv(sv.size() - 1) / sv(0), 2) >= 1e-14;
    Eigen::MatrixXd kept_covariance;  // (U^T U)^-1
    if (invertible) {
      const Eigen::MatrixXd v = svd.matrixV();
      kept_covariance = v * sv.cwiseInverse().cwiseAbs2().asDiagonal() * v.transpose();
      for (std::size_t a = 0; a < kept.size(); ++a)
        for (std::size_t b = 0; b < kept.size(); ++b)
          c(kept[a], kept[b]) = kept_covariance(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
    }
    if (invertible && static_cast<Eigen::Index>(residuals.size()) == unit.rows()) {
      // The sandwich (U^T U)^-1 M (U^T U)^-1, M the covariance of the scores u_k e_k from
      // Newey and West's estimator (Bartlett weights) over a bandwidth of at least the
      // observer's settling time 3 / K1, and as long as the residuals stay correlated: the
      // noise in r went through the observer's filter, which correlates it over about that
      // time, it is louder near reversals than elsewhere, and what the model cannot follow
      // (sub-sample dynamics, a friction law of another shape) correlates the residuals for
      // longer. (A single factor from the residuals' integrated autocorrelation, as before,
      // ignored that the regressors are correlated differently from the residuals and that the
      // noise is not equally loud everywhere: over seeds of the simulated paper arm its
      // standard errors were 1 to 8 times the actual scatter and wandered by factors of 10
      // from seed to seed.) m / (m - p) corrects for the fitted parameters, as in
      // sigma^2 = SSE / (m - p).
      const auto settling = static_cast<std::size_t>(
          std::max(0L, std::lround(3.0 / (gains.k1 * std::max(data.median_dt(), 1e-12)))));
      const std::size_t lag = std::max(settling, correlated_lags(residuals));
      Eigen::MatrixXd scores = unit;
      for (Eigen::Index k = 0; k < scores.rows(); ++k) scores.row(k) *= residuals[static_cast<std::size_t>(k)];
      const Eigen::MatrixXd meat = bartlett_score_covariance(scores, residual_index, lag);
      const double rows = static_cast<double>(unit.rows()), kept_count = static_cast<double>(kept.size());
      const Eigen::MatrixXd kept_sandwich =
          (rows / std::max(rows - kept_count, 1.0)) * kept_covariance * meat * kept_covariance;
      Eigen::MatrixXd sandwich = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(nfree), static_cast<Eigen::Index>(nfree));
      for (std::size_t a = 0; a < kept.size(); ++a)
        for (std::size_t b = 0; b < kept.size(); ++b)
          sandwich(kept[a], kept[b]) = kept_sandwich(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
      // Diagnostic: the geometric mean over the parameters of the variance over what white
      // noise of the residuals' variance would give (1 for white residuals).
      double log_ratio = 0;
      int ratios = 0;
      for (std::size_t a = 0; a < nfree; ++a) {
        if (held[a]) continue;
        const auto ia = static_cast<Eigen::Index>(a);
        const double white = c(ia, ia) * variance;
        if (white > 0 && sandwich(ia, ia) > 0) log_ratio += std::log(sandwich(ia, ia) / white), ++ratios;
      }
      fit.autocorrelation_factor = ratios ? std::exp(log_ratio / ratios) : 1.0;
      for (std::size_t a = 0; a < nfree; ++a) {
        if (held[a]) continue;
        const double sa = unit_scale[static_cast<std::size_t>(problem.free[a])];
        const auto ia = static_cast<Eigen::Index>(a);
        standard_error[a] = std::sqrt(std::max(0.0, sandwich(ia, ia))) * sa;
        for (std::size_t b = 0; b < nfree; ++b) {
          if (held[b]) continue;
          const auto ib = static_cast<Eigen::Index>(b);
          const double denom = std::sqrt(sandwich(ia, ia) * sandwich(ib, ib));
          fit.correlation(ia, ib) = denom > 0 ? sandwich(ia, ib) / denom : std::numeric_limits<double>::quiet_NaN();
        }
      }
      fit.covariance_ok = true;
      if (!constant.empty())
        fit.covariance_note = "rank-deficient: covariance of the other parameters with the undetermined ones held";
      else if (!(fit.condition_number < 1e6))
        fit.covariance_note = "ill-conditioned (condition number " + format("%.3g", fit.condition_number) +
                              "): standard errors are first-order estimates at best";
    } else {
      fit.covariance_note = "the covariance could not be computed (the Jacobian is numerically singular)";
    }
  } else if (fit.covariance_note.empty()) {
    fit.covariance_note = "no parameter is determined by the data";
  }

  // Per-parameter report and flags.
  for (int i = 0; i < kParameterCount; ++i) {
    auto& e = fit.estimates[static_cast<std::size_t>(i)];
    double all[kParameterCount];
    fit.parameters.to_array(all);
    e.value = all[i];
    const auto used = model_parameters(kind, options.asymmetric);
    e.used = std::find(used.begin(), used.end(), i) != used.end();
  }
  for (std::size_t j = 0; j < nfree; ++j) {
    const int i = problem.free[j];
    const auto u = static_cast<std::size_t>(i);
    auto& e = fit.estimates[u];
    e.free = true;
    e.standard_error = standard_error[j];
    e.discretization_shift = shift[j];
    e.velocity_noise_shift = velocity_shift[j];
    e.uncertainty = e.standard_error;
    for (double part : {shift[j], velocity_shift[j]})
      if (std::isfinite(part)) e.uncertainty = std::hypot(e.uncertainty, part);
    const double lo = options.bounds.lower[u], hi = options.bounds.upper[u];
    const double near = 1e-6 * (hi - lo);
    if (e.value <= lo + near) e.at_bound = -1;
    if (e.value >= hi - near) e.at_bound = +1;
    // An asymmetry is often truly 0: judge it against its level (tau_c, tau_s), not itself.
    const double reference = i >= 6 ? std::min(i == 6 ? fit.parameters.tau_c : fit.parameters.tau_s, hi - lo)
                                    : std::min(std::abs(e.value), hi - lo);
    std::string note;
    if (!undetermined[j].empty()) {
      e.identifiable = false;
      note = undetermined[j];
      const std::string why = explain(problem, fit, i);
      if (!why.empty()) note += "; " + why;
    } else if (!fit.covariance_ok) {
      e.identifiable = false;
      note = "no standard error: " + fit.covariance_note;
    } else if (!(e.uncertainty <= options.identifiability_threshold * reference)) {
      e.identifiable = false;
      note = "not identifiable: uncertainty " + format("%.3g", e.uncertainty) +
             (reference > 0 ? format(" = %.3g%% of ", 100.0 * e.uncertainty / reference) +
                                  (i >= 6 && reference < hi - lo ? (i == 6 ? "tau_c" : "tau_s")
                                   : reference == std::abs(e.value) ? "the value" : "the bound interval")
                            : std::string(" at a value of 0"));
      const double sub = std::isfinite(e.discretization_shift) ? std::abs(e.discretization_shift) : 0.0;
      const double vel = std::isfinite(e.velocity_noise_shift) ? std::abs(e.velocity_noise_shift) : 0.0;
      if (sub > e.standard_error && sub >= vel)
        note += format(", mostly from dynamics faster than the %.4g Hz sampling", 1.0 / std::max(data.median_dt(), 1e-12));
      else if (vel > e.standard_error)
        note += ", mostly from the velocity noise";
      else
        note += ", mostly from noise in r";
      const std::string why = explain(problem, fit, i);
      if (!why.empty()) note += "; " + why;
    }
    if (e.at_bound) {
      const std::string where = e.at_bound < 0 ? "lower" : "upper";
      const std::string bound_note = "at its " + where + " bound " +
                                     format("%.6g", e.at_bound < 0 ? lo : hi) +
                                     " (the best fit is on or beyond it; widen --bounds to see)";
      note = note.empty() ? bound_note : bound_note + "; " + note;
    }
    e.note = note;
  }
  fit.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return fit;
}

}  // namespace

std::vector<double> predict_residual(const JointSeries& data, const observer::Gains& gains,
                                     Kind kind, const Params& p, const friction::Options& options,
                                     std::vector<double>* friction_torque) {
  FitOptions o;
  o.kind = kind;
  o.friction = options;
  Problem problem(data, gains, kind, o);
  std::vector<double> out(data.size());
  if (friction_torque) friction_torque->assign(data.size(), 0.0);
  problem.simulate(p, [&](std::size_t k, double y, double tau) {
    out[k] = y;
    if (friction_torque) (*friction_torque)[k] = tau;
  });
  return out;
}

FitMetrics evaluate_fit(const JointSeries& data, const observer::Gains& gains, Kind kind,
                        const Params& p, const friction::Options& options) {
  FitOptions o;
  o.kind = kind;
  o.friction = options;
  Problem problem(data, gains, kind, o);
  return metrics_of(problem, p);
}

JointFit fit_joint(const JointSeries& data, const observer::Gains& gains, const FitOptions& options,
                   std::uint64_t seed, const JointProgressCallback& progress) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument("friction fit: " + why);
  if (!gains.IsValid(&why)) throw std::invalid_argument("friction fit: observer gains: " + why);
  if (data.scored_count() == 0)
    throw Error("joint " + std::to_string(data.joint) + ": no sample to fit");
  const auto start = std::chrono::steady_clock::now();
  JointFit result;
  result.joint = data.joint;
  result.model = fit_model(data, gains, options.kind, options, derive_seed(seed, 0), data.joint, progress);
  result.model_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (options.kind == Kind::lugre && options.compare_static) {
    result.static_model =
        fit_model(data, gains, Kind::stribeck, options, derive_seed(seed, 1), data.joint, progress);
    result.static_seconds = result.static_model->seconds;
  }
  if (options.asymmetric) {
    FitOptions symmetric = options;
    symmetric.asymmetric = false;
    result.symmetric_model =
        fit_model(data, gains, options.kind, symmetric, derive_seed(seed, 2), data.joint, progress);
    result.symmetric_seconds = result.symmetric_model->seconds;
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

std::vector<JointFit> fit_joints(const std::vector<JointSeries>& data,
                                 const std::vector<observer::Gains>& gains,
                                 const FitOptions& options, int threads,
                                 const JointProgressCallback& progress) {
  return fit_joints(data, gains, std::vector<FitOptions>(data.size(), options), threads, progress);
}

std::vector<JointFit> fit_joints(const std::vector<JointSeries>& data,
                                 const std::vector<observer::Gains>& gains,
                                 const std::vector<FitOptions>& joint_options, int threads,
                                 const JointProgressCallback& progress) {
  if (gains.size() != data.size())
    throw std::invalid_argument("friction fit: one set of gains per joint needed");
  if (joint_options.size() != data.size())
    throw std::invalid_argument("friction fit: one set of options per joint needed");
  if (data.empty()) return {};
  std::string why;
  for (const auto& o : joint_options)
    if (!o.IsValid(&why)) throw std::invalid_argument("friction fit: " + why);
  const FitOptions& options = joint_options.front();  // the model and its comparisons: the same for every joint
  for (std::size_t i = 0; i < data.size(); ++i) {
    if (!gains[i].IsValid(&why)) throw std::invalid_argument("friction fit: observer gains: " + why);
    if (data[i].scored_count() == 0)
      throw Error("joint " + std::to_string(data[i].joint) + ": no sample to fit");
  }
  // One task per model and joint (the chosen models first: they take longest), so that three
  // joints with their static comparisons spread evenly over two cores. Each task's seed
  // depends only on the joint and the model, as in fit_joint.
  enum class Which { model, static_model, symmetric };
  struct Task {
    std::size_t joint;
    Which which;
  };
  std::vector<Task> tasks;
  for (std::size_t i = 0; i < data.size(); ++i) tasks.push_back({i, Which::model});
  if (options.asymmetric)
    for (std::size_t i = 0; i < data.size(); ++i) tasks.push_back({i, Which::symmetric});
  if (options.kind == Kind::lugre && options.compare_static)
    for (std::size_t i = 0; i < data.size(); ++i) tasks.push_back({i, Which::static_model});
  std::vector<JointFit> results(data.size());
  std::vector<std::exception_ptr> errors(tasks.size());
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    for (std::size_t n = next++; n < tasks.size(); n = next++) {
      const auto& task = tasks[n];
      const auto& d = data[task.joint];
      const std::uint64_t seed = derive_seed(options.global.genetic.seed, static_cast<std::uint64_t>(d.joint));
      try {
        const auto start = std::chrono::steady_clock::now();
        const bool is_static = task.which == Which::static_model;
        const bool is_symmetric = task.which == Which::symmetric;
        FitOptions own = joint_options[task.joint];
        if (is_symmetric) own.asymmetric = false;
        ModelFit fit = fit_model(d, gains[task.joint], is_static ? Kind::stribeck : own.kind, own,
                                 derive_seed(seed, is_static ? 1 : is_symmetric ? 2 : 0), d.joint, progress);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        auto& r = results[task.joint];  // each slot written by one task only
        if (is_static) {
          r.static_model = std::move(fit);
          r.static_seconds = seconds;
        } else if (is_symmetric) {
          r.symmetric_model = std::move(fit);
          r.symmetric_seconds = seconds;
        } else {
          r.joint = d.joint;
          r.model = std::move(fit);
          r.model_seconds = seconds;
        }
      } catch (...) {
        errors[n] = std::current_exception();
      }
    }
  };
  if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const auto count = std::min<std::size_t>(static_cast<std::size_t>(threads), tasks.size());
  std::vector<std::thread> pool;
  for (std::size_t i = 1; i < count; ++i) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
  for (auto& r : results) r.seconds = r.model_seconds + r.static_seconds + r.symmetric_seconds;
  return results;
}

}  // namespace momentum::fit
