#include "momentum/friction_fit/polish.hpp"

#include <ceres/ceres.h>
#include <ceres/dynamic_autodiff_cost_function.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "momentum/core/number.hpp"

namespace momentum::friction_fit {

using Params = friction::Parameters<double>;

int refine_levenberg_marquardt(const Problem& problem, std::vector<double>& x, const std::vector<double>& lower,
                               const std::vector<double>& upper, Eigen::VectorXd& e, Eigen::MatrixXd& jacobian,
                               std::uint64_t* plain_passes, int max_iterations) {
  const auto n = static_cast<Eigen::Index>(x.size());
  auto physical_cost = [&](const std::vector<double>& v) {
    std::vector<double> p(v.size());
    for (std::size_t j = 0; j < v.size(); ++j) p[j] = v[j] * problem.scale[static_cast<std::size_t>(problem.free[j])];
    ++*plain_passes;
    return problem.cost(problem.assemble(p.data(), nullptr));
  };
  int passes = 0;
  double lambda = 1e-6;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
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

namespace {

// A start for the polish from `best` (physical units, free parameters) with the Stribeck
// effect where the data can see it, or nullopt when the model has no free w_s and tau_s. A w_s
// below every counted speed hides tau_s and w_s from the cost: there it is flat in both, the
// search lands in that corner as often as in the true basin (its subset tells them apart
// worse than all the data do), and a polish started there has no gradient to leave it. The
// start puts w_s at the lower quartile of the counted speeds (within its bounds), where the
// Stribeck term changes a quarter of the samples, and tau_s at tau_c: no bump yet, but the cost
// now depends on tau_s, and through it on w_s.
std::optional<std::vector<double>> stribeck_start(const Problem& problem, const FitOptions& options,
                                                  const std::vector<double>& best) {
  constexpr int kTauC = 3, kTauS = 4, kStribeckVelocity = 5;
  auto position = [&](int parameter) -> std::ptrdiff_t {
    const auto at = std::find(problem.free.begin(), problem.free.end(), parameter);
    return at == problem.free.end() ? -1 : at - problem.free.begin();
  };
  const std::ptrdiff_t tau_s = position(kTauS), w_s = position(kStribeckVelocity);
  if (tau_s < 0 || w_s < 0 || best.size() != problem.free.size()) return std::nullopt;
  const auto& d = *problem.data;
  std::vector<double> speed;
  for (std::size_t k = 0; k < d.size(); ++k)
    if (d.scored[k]) speed.push_back(std::abs(d.dq[k]));
  if (speed.empty()) return std::nullopt;
  const auto quartile = speed.begin() + static_cast<std::ptrdiff_t>(speed.size() / 4);
  std::nth_element(speed.begin(), quartile, speed.end());
  std::vector<double> start = best;
  const auto u = static_cast<std::size_t>(kStribeckVelocity), v = static_cast<std::size_t>(kTauS);
  start[static_cast<std::size_t>(w_s)] = std::clamp(*quartile, options.bounds.lower[u], options.bounds.upper[u]);
  const std::ptrdiff_t tau_c = position(kTauC);
  const double level = tau_c >= 0 ? best[static_cast<std::size_t>(tau_c)] : problem.fixed[static_cast<std::size_t>(kTauC)];
  start[static_cast<std::size_t>(tau_s)] = std::clamp(level, options.bounds.lower[v], options.bounds.upper[v]);
  return start;
}

}  // namespace

Eigen::MatrixXd polish_fit(const Problem& problem, const Problem& search, const FitOptions& options, int joint,
                           const JointProgressCallback& progress, ModelFit& fit) {
  const std::size_t nfree = problem.free.size();
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
    if (auto seen = stribeck_start(problem, options, fit.global.best)) starts.push_back(std::move(*seen));
    // The end points are ranked by the cost of every sample: a subset's few windows rank the
    // basins of the cost unreliably (on a 1 kHz arm the subset put a basin without the Stribeck
    // effect within 2% of the true one that all the data put at 2.7 times its cost), so which
    // one the fit kept followed the search's draws. Without a subset, `search` is `problem`.
    std::uint64_t judged = 0;  // plain passes over all the data to rank end points
    double best_cost = fit.subset.used ? (++judged, problem.cost(fit.parameters)) : fit.global.cost;
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
    // are polished on the subset, ranked on all the data, and the best one polished once more
    // on all of them.
    for (const auto& start_point : starts) {
      std::vector<double> v = scaled(start_point);
      ceres::Solver::Summary summary;
      if (!polish_from(v, search, summary)) continue;
      const Params candidate = physical(v);
      const double c = fit.subset.used ? (++judged, problem.cost(candidate)) : search.cost(candidate);
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
    fit.polish_residual_evaluations += judged;
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
    const int passes = refine_levenberg_marquardt(problem, v, lower, upper, final_residuals, jacobian, &plain);
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
    fit.polish_message += "; on all " + std::to_string(problem.scored) + " samples: cost " + core::significant(before, 6) +
                          " -> " + core::significant(std::min(before, after), 6) + " Nm^2 in " + std::to_string(passes) +
                          " passes with derivatives";
  }
  if (!have_jacobian) have_jacobian = jacobian_at(problem, x, problem.scale, final_residuals, jacobian);
  if (!have_jacobian) jacobian.resize(0, 0);
  return jacobian;
}

}  // namespace momentum::friction_fit
