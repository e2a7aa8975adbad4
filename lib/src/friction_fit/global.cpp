// NLopt's global algorithms behind the same interface as the genetic algorithm.
#include <nlopt.h>

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "momentum/core/error.hpp"
#include "momentum/friction_fit/genetic.hpp"

namespace momentum::friction_fit {

namespace {

struct Method {
  GlobalMethod method;
  const char* name;
};
constexpr Method kMethods[] = {{GlobalMethod::ga, "ga"},
                               {GlobalMethod::crs2, "crs2"},
                               {GlobalMethod::isres, "isres"},
                               {GlobalMethod::mlsl, "mlsl"},
                               {GlobalMethod::esch, "esch"}};

struct Context {
  const CostFunction* cost;
  const GeneticOptions* options;
  GlobalSummary* summary;
  std::size_t d;
};

// NLopt's objective: counts evaluations, keeps the best point, reports progress every
// `population` evaluations. Infinite or NaN costs become a huge finite value, which the
// NLopt algorithms handle better than infinities.
double objective(unsigned n, const double* x, double* gradient, void* data) {
  (void)gradient;  // derivative-free algorithms only
  auto& c = *static_cast<Context*>(data);
  double value = (*c.cost)(std::span<const double>(x, n));
  if (!std::isfinite(value)) value = std::numeric_limits<double>::infinity();
  auto& s = *c.summary;
  ++s.evaluations;
  if (value < s.cost || s.best.empty()) {
    s.cost = value;
    s.best.assign(x, x + n);
  }
  const auto population = static_cast<std::uint64_t>(c.options->population);
  if (s.evaluations % population == 0) {
    ++s.generations;
    if (c.options->on_generation)
      c.options->on_generation({0, s.generations, s.cost, s.evaluations});
  }
  return std::isfinite(value) ? value : 1e300;
}

GlobalSummary minimize_nlopt(const CostFunction& cost, const Bounds& bounds,
                             const GlobalOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const auto d = static_cast<unsigned>(bounds.size());
  nlopt_algorithm algorithm = NLOPT_GN_CRS2_LM;
  switch (options.method) {
    case GlobalMethod::crs2: algorithm = NLOPT_GN_CRS2_LM; break;
    case GlobalMethod::isres: algorithm = NLOPT_GN_ISRES; break;
    case GlobalMethod::mlsl: algorithm = NLOPT_G_MLSL_LDS; break;
    case GlobalMethod::esch: algorithm = NLOPT_GN_ESCH; break;
    case GlobalMethod::ga: break;
  }
  nlopt_opt opt = nlopt_create(algorithm, d);
  if (!opt) throw Error("nlopt: cannot create the optimiser (out of memory)");
  nlopt_opt local = nullptr;
  GlobalSummary summary;
  summary.runs = 1;
  Context context{&cost, &options.genetic, &summary, bounds.size()};
  std::vector<double> x(d);
  for (unsigned i = 0; i < d; ++i) x[i] = 0.5 * (bounds.lower[i] + bounds.upper[i]);
  nlopt_result result;
  {
    nlopt_set_lower_bounds(opt, bounds.lower.data());
    nlopt_set_upper_bounds(opt, bounds.upper.data());
    nlopt_set_min_objective(opt, objective, &context);
    nlopt_set_maxeval(opt, static_cast<int>(std::min<std::uint64_t>(options.nlopt_budget(), 2000000000)));
    if (options.method == GlobalMethod::mlsl) {
      // MLSL's population is its number of random starts per iteration; NLopt's default
      // suits it better than the genetic population. Local searches: BOBYQA.
      local = nlopt_create(NLOPT_LN_BOBYQA, d);
      nlopt_set_xtol_rel(local, 1e-8);
      nlopt_set_local_optimizer(opt, local);
    } else {
      nlopt_set_population(opt, static_cast<unsigned>(options.genetic.population));
    }
    nlopt_srand(static_cast<unsigned long>(options.genetic.seed));
    double minimum = 0;
    result = nlopt_optimize(opt, x.data(), &minimum);
  }
  if (local) nlopt_destroy(local);
  nlopt_destroy(opt);
  if (result == NLOPT_INVALID_ARGS || result == NLOPT_OUT_OF_MEMORY)
    throw Error(std::string("nlopt ") + method_name(options.method) + ": " + nlopt_result_to_string(result));
  if (summary.best.empty()) throw Error(std::string("nlopt ") + method_name(options.method) + ": no evaluation");
  summary.run_costs.push_back(summary.cost);
  summary.run_best.push_back(summary.best);
  summary.message = std::string("nlopt ") + nlopt_result_to_string(result) + " after " +
                    std::to_string(summary.evaluations) + " evaluations";
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace

const char* method_name(GlobalMethod method) {
  for (const auto& m : kMethods)
    if (m.method == method) return m.name;
  return "?";
}

bool parse_method(const std::string& name, GlobalMethod* method) {
  for (const auto& m : kMethods)
    if (name == m.name) {
      *method = m.method;
      return true;
    }
  return false;
}

bool GlobalOptions::IsValid(std::string* why) const { return genetic.IsValid(why); }

std::uint64_t GlobalOptions::nlopt_budget() const {
  if (max_evaluations > 0) return max_evaluations;
  return static_cast<std::uint64_t>(genetic.population) *
         static_cast<std::uint64_t>(genetic.generations) *
         static_cast<std::uint64_t>(genetic.restarts);
}

GlobalSummary minimize_global(const CostFunction& cost, const Bounds& bounds,
                              const GlobalOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument("global search: " + why);
  if (!bounds.IsValid(&why)) throw std::invalid_argument("global search: " + why);
  if (options.method == GlobalMethod::ga) return minimize_genetic(cost, bounds, options.genetic);
  return minimize_nlopt(cost, bounds, options);
}

}  // namespace momentum::friction_fit
