#include "momentum/friction_fit/genetic.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>

#include "momentum/core/error.hpp"
#include "momentum/core/random.hpp"

namespace momentum::friction_fit {

bool Bounds::IsValid(std::string* why) const {
  if (lower.size() != upper.size()) return invalid(why, "bounds: lower and upper differ in size");
  if (lower.empty()) return invalid(why, "bounds: no parameters");
  for (std::size_t i = 0; i < lower.size(); ++i) {
    if (!std::isfinite(lower[i]) || !std::isfinite(upper[i]))
      return invalid(why, "bounds: parameter " + std::to_string(i) + ": not finite");
    if (!(lower[i] < upper[i]))
      return invalid(why, "bounds: parameter " + std::to_string(i) + ": lower bound not below upper bound");
  }
  return true;
}

void Bounds::clamp(std::span<double> x) const {
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = std::clamp(x[i], lower[i], upper[i]);
}

bool Bounds::contains(std::span<const double> x) const {
  for (std::size_t i = 0; i < x.size(); ++i)
    if (!(x[i] >= lower[i] && x[i] <= upper[i])) return false;
  return true;
}

bool GeneticOptions::IsValid(std::string* why) const {
  if (population < 4) return invalid(why, "population must be at least 4");
  if (generations < 1) return invalid(why, "generations must be at least 1");
  if (!(crossover >= 0 && crossover <= 1)) return invalid(why, "crossover probability must be in [0, 1]");
  if (!(mutation >= 0 && mutation <= 1)) return invalid(why, "mutation probability must be in [0, 1]");
  if (elite < 0 || elite >= population) return invalid(why, "elite must be in [0, population)");
  if (restarts < 1) return invalid(why, "restarts must be at least 1");
  if (stall_generations < 0) return invalid(why, "stall generations must be >= 0");
  if (!(stall_tolerance >= 0)) return invalid(why, "stall tolerance must be >= 0");
  if (!(crossover_eta > 0) || !std::isfinite(crossover_eta)) return invalid(why, "crossover eta must be > 0");
  if (!(mutation_eta > 0) || !std::isfinite(mutation_eta)) return invalid(why, "mutation eta must be > 0");
  return true;
}

namespace {

double clean(double c) { return std::isnan(c) ? std::numeric_limits<double>::infinity() : c; }

// Bounded simulated binary crossover of one gene (Deb & Agrawal 1995; the bounded form of
// Deb's NSGA-II code). Children stay in [lo, hi].
void sbx_gene(double& a, double& b, double lo, double hi, double eta, core::Random& rng) {
  if (std::abs(a - b) <= 1e-14 * (hi - lo)) return;
  const double y1 = std::min(a, b), y2 = std::max(a, b);
  const double span = y2 - y1;
  const double r = rng.uniform();
  auto betaq = [&](double beta) {
    const double alpha = 2.0 - std::pow(beta, -(eta + 1.0));
    return r <= 1.0 / alpha ? std::pow(r * alpha, 1.0 / (eta + 1.0))
                            : std::pow(1.0 / (2.0 - r * alpha), 1.0 / (eta + 1.0));
  };
  double c1 = 0.5 * ((y1 + y2) - betaq(1.0 + 2.0 * (y1 - lo) / span) * span);
  double c2 = 0.5 * ((y1 + y2) + betaq(1.0 + 2.0 * (hi - y2) / span) * span);
  c1 = std::clamp(c1, lo, hi);
  c2 = std::clamp(c2, lo, hi);
  if (rng.uniform() < 0.5) std::swap(c1, c2);
  a = c1;
  b = c2;
}

// Bounded polynomial mutation of one gene (Deb & Goyal 1996).
double mutate_gene(double y, double lo, double hi, double eta, core::Random& rng) {
  const double width = hi - lo;
  const double d1 = (y - lo) / width, d2 = (hi - y) / width;
  const double r = rng.uniform();
  const double power = 1.0 / (eta + 1.0);
  double delta;
  if (r < 0.5) {
    const double v = 2.0 * r + (1.0 - 2.0 * r) * std::pow(1.0 - d1, eta + 1.0);
    delta = std::pow(v, power) - 1.0;
  } else {
    const double v = 2.0 * (1.0 - r) + 2.0 * (r - 0.5) * std::pow(1.0 - d2, eta + 1.0);
    delta = 1.0 - std::pow(v, power);
  }
  return std::clamp(y + delta * width, lo, hi);
}

}  // namespace

GlobalSummary minimize_genetic(const CostFunction& cost, const Bounds& bounds,
                               const GeneticOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument("genetic algorithm: " + why);
  if (!bounds.IsValid(&why)) throw std::invalid_argument("genetic algorithm: " + why);
  const auto start = std::chrono::steady_clock::now();
  const std::size_t d = bounds.size();
  const auto P = static_cast<std::size_t>(options.population);
  const auto elite = static_cast<std::size_t>(options.elite);
  core::Random rng(core::derive_seed(options.seed, 0));

  GlobalSummary summary;
  std::vector<double> pop(P * d), next(P * d), costs(P), next_costs(P);
  std::vector<std::size_t> order(P);
  auto individual = [&](std::vector<double>& v, std::size_t i) {
    return std::span<double>(v.data() + i * d, d);
  };
  auto evaluate = [&](std::span<const double> x) {
    ++summary.evaluations;
    return clean(cost(x));
  };
  auto report = [&](int run, int generation) {
    if (options.on_generation)
      options.on_generation({run, generation, summary.cost, summary.evaluations});
  };
  auto note_best = [&](std::span<const double> x, double c) {
    if (c < summary.cost || summary.best.empty()) {
      summary.cost = c;
      summary.best.assign(x.begin(), x.end());
    }
  };
  // Binary tournament; ties go to the lower index, which after sorting is the better one.
  auto tournament = [&]() {
    const std::size_t a = rng.below(P), b = rng.below(P);
    return costs[a] <= costs[b] ? a : b;
  };

  for (int run = 0; run < options.restarts; ++run) {
    ++summary.runs;
    for (std::size_t i = 0; i < P; ++i) {
      auto x = individual(pop, i);
      for (std::size_t k = 0; k < d; ++k)
        x[k] = bounds.lower[k] + rng.uniform() * (bounds.upper[k] - bounds.lower[k]);
      costs[i] = evaluate(x);
    }
    double run_best = std::numeric_limits<double>::infinity();
    std::vector<double> run_best_x;
    double stall_reference = std::numeric_limits<double>::infinity();
    int stalled = 0;
    int generation = 1;
    std::string ended = std::to_string(options.generations) + " generations";
    for (;; ++generation) {
      // Sort by cost (index breaks ties, so the order is fully determined).
      std::iota(order.begin(), order.end(), std::size_t{0});
      std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return costs[a] < costs[b] || (costs[a] == costs[b] && a < b);
      });
      for (std::size_t i = 0; i < P; ++i) {
        std::copy_n(pop.data() + order[i] * d, d, next.data() + i * d);
        next_costs[i] = costs[order[i]];
      }
      pop.swap(next);
      costs.swap(next_costs);
      if (costs[0] < run_best || run_best_x.empty()) {
        run_best = costs[0];
        run_best_x.assign(pop.begin(), pop.begin() + static_cast<std::ptrdiff_t>(d));
      }
      note_best(individual(pop, 0), costs[0]);
      ++summary.generations;
      report(run, generation);

      if (options.stall_generations > 0) {
        const double tol = options.stall_tolerance * std::abs(stall_reference);
        if (run_best < stall_reference - tol || !std::isfinite(stall_reference)) {
          stall_reference = run_best;
          stalled = 0;
        } else if (++stalled >= options.stall_generations) {
          ended = "stalled for " + std::to_string(stalled) + " generations";
          break;
        }
      }
      if (generation >= options.generations) break;

      // Breed the next generation into `next`; the sorted population stays in `pop`.
      for (std::size_t i = 0; i < elite; ++i) {
        std::copy_n(pop.data() + i * d, d, next.data() + i * d);
        next_costs[i] = costs[i];
      }
      for (std::size_t i = elite; i < P; i += 2) {
        const std::size_t pa = tournament(), pb = tournament();
        auto a = individual(next, i);
        std::copy_n(pop.data() + pa * d, d, a.begin());
        const bool pair = i + 1 < P;
        std::vector<double> spare;
        std::span<double> b;
        if (pair) {
          b = individual(next, i + 1);
        } else {
          spare.resize(d);
          b = spare;
        }
        std::copy_n(pop.data() + pb * d, d, b.begin());
        if (rng.uniform() < options.crossover)
          for (std::size_t k = 0; k < d; ++k)
            if (rng.uniform() < 0.5)
              sbx_gene(a[k], b[k], bounds.lower[k], bounds.upper[k], options.crossover_eta, rng);
        for (auto child : {a, b})
          for (std::size_t k = 0; k < d; ++k)
            if (rng.uniform() < options.mutation)
              child[k] = mutate_gene(child[k], bounds.lower[k], bounds.upper[k],
                                     options.mutation_eta, rng);
        next_costs[i] = evaluate(a);
        if (pair) next_costs[i + 1] = evaluate(b);
      }
      pop.swap(next);
      costs.swap(next_costs);
    }
    summary.run_costs.push_back(run_best);
    summary.run_best.push_back(run_best_x);
    summary.message = ended;
  }
  if (summary.runs > 1) summary.message += " (best of " + std::to_string(summary.runs) + " runs)";
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace momentum::friction_fit
