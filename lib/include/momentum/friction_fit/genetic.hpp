// Global minimisation of a cost over a box: a real-coded genetic algorithm (the method of
// Zhang et al. 2020, section 3, with its defaults), and NLopt's global algorithms for
// comparison. Both are generic: a cost function of a parameter vector and box bounds; nothing
// here knows about friction.
//
// Reproducibility: every random choice comes from one 64-bit Mersenne Twister seeded from
// Options::seed, with the library's own uniform/normal transforms (not std::*_distribution,
// whose output is implementation-defined), and costs are evaluated in a fixed order. So a run
// with a fixed seed gives the same bits on every run of the same binary, whatever else runs in
// parallel. Callers fitting several problems at once derive one seed per problem with
// core::derive_seed().
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <string>
#include <vector>

namespace momentum::friction_fit {

// A box: lower[i] <= x[i] <= upper[i], both finite, lower[i] < upper[i] (a parameter held
// fixed is removed from the problem by the caller, not given an empty interval).
struct Bounds {
  std::vector<double> lower;
  std::vector<double> upper;

  std::size_t size() const { return lower.size(); }
  // Same sizes, at least one dimension, every pair finite with lower < upper; otherwise false
  // with the reason (naming the 0-based index) in `why`, when non-null.
  bool IsValid(std::string* why) const;
  // x clamped into the box (x must have size() entries).
  void clamp(std::span<double> x) const;
  // True when every x[i] lies in [lower[i], upper[i]].
  bool contains(std::span<const double> x) const;
};

// The function minimised: any real function of size() parameters; NaN counts as +infinity.
// Called from one thread at a time per minimisation, but several minimisations may run in
// parallel threads, so it must not share mutable state between them.
using CostFunction = std::function<double(std::span<const double> x)>;

// Progress of a global search, handed to the per-generation callback.
struct SearchProgress {
  int restart = 0;                 // 0-based run (genetic) or 0 (NLopt)
  int generation = 0;              // 1-based within the run; NLopt: evaluations / population
  double best_cost = std::numeric_limits<double>::infinity();  // best over all runs so far
  std::uint64_t evaluations = 0;   // cost evaluations so far, all runs
};
// Called once per generation (NLopt: every `population` evaluations), in the thread running
// the search. Must not throw.
using ProgressCallback = std::function<void(const SearchProgress&)>;

// The real-coded genetic algorithm. Defaults are the paper's settings (population 200, 300
// generations, crossover probability 0.8, mutation probability 0.2) with elitism, a single run
// and no early stop.
//
// One generation: the `elite` best individuals pass unchanged; the rest of the new population
// comes in pairs from binary tournaments; with probability `crossover` a pair is recombined by
// bounded simulated binary crossover (SBX, Deb & Agrawal 1995, index `crossover_eta`), and each
// gene of each child is then mutated with probability `mutation` by bounded polynomial mutation
// (index `mutation_eta`). A run stops after `generations` generations, or earlier when the
// best cost has not improved by more than `stall_tolerance` (relative) for `stall_generations`
// generations. `restarts` runs start from independent uniformly random populations (the paper's
// "different initial parent populations"); the result is the best over all runs.
struct GeneticOptions {
  int population = 200;          // individuals per generation, >= 4
  int generations = 300;         // generations per run (the initial population is the first), >= 1
  double crossover = 0.8;        // probability that a pair is recombined, [0, 1]
  double mutation = 0.2;         // probability that a gene is mutated, [0, 1]
  int elite = 2;                 // best individuals copied unchanged, [0, population)
  int restarts = 1;              // independent runs, >= 1
  int stall_generations = 0;     // early stop after this many generations without improvement; 0: never
  double stall_tolerance = 1e-9; // relative improvement that counts, >= 0
  double crossover_eta = 15.0;   // SBX distribution index, > 0 (larger: children nearer parents)
  double mutation_eta = 20.0;    // polynomial mutation index, > 0
  std::uint64_t seed = 1;        // every random choice derives from it
  ProgressCallback on_generation;  // optional

  // False with the reason in `why` (when non-null) for a value outside the ranges above.
  bool IsValid(std::string* why) const;
};

// What a global search returns.
struct GlobalSummary {
  std::vector<double> best;        // best parameters found, inside the bounds
  double cost = std::numeric_limits<double>::infinity();  // cost(best)
  std::uint64_t evaluations = 0;   // cost evaluations, all runs
  int generations = 0;             // generations run, all runs (NLopt: evaluations / population)
  int runs = 0;                    // runs started (genetic restarts), 1 for NLopt
  std::vector<double> run_costs;   // best cost of each run (genetic)
  std::vector<std::vector<double>> run_best;  // best parameters of each run (NLopt: best)
  double seconds = 0;              // wall time
  std::string message;             // how it ended, e.g. "300 generations" or "stalled for 20 generations"
};

// Minimises `cost` over `bounds` with the genetic algorithm. Throws std::invalid_argument when
// the options or bounds are invalid. When every cost is NaN or infinite the summary's cost is
// +infinity and best is the first individual of the last generation.
GlobalSummary minimize_genetic(const CostFunction& cost, const Bounds& bounds,
                               const GeneticOptions& options = {});

// Which global algorithm minimize_global() runs.
enum class GlobalMethod {
  ga,     // minimize_genetic
  crs2,   // NLopt GN_CRS2_LM: controlled random search with local mutation
  isres,  // NLopt GN_ISRES: improved stochastic ranking evolution strategy
  mlsl,   // NLopt G_MLSL_LDS: multi-level single linkage (low-discrepancy starts) + BOBYQA
  esch,   // NLopt GN_ESCH: evolutionary strategy of da Silva Santos et al.
};
// "ga", "crs2", "isres", "mlsl", "esch".
const char* method_name(GlobalMethod method);
// Inverse of method_name; false when unknown.
bool parse_method(const std::string& name, GlobalMethod* method);

// A global search: the method, the genetic options (used by ga; NLopt methods use its
// population, seed and callback, and a budget of population * generations * restarts
// evaluations unless max_evaluations is set).
struct GlobalOptions {
  GlobalMethod method = GlobalMethod::ga;
  GeneticOptions genetic;
  std::uint64_t max_evaluations = 0;  // NLopt budget; 0: population * generations * restarts

  bool IsValid(std::string* why) const;
  // The NLopt evaluation budget these options give.
  std::uint64_t nlopt_budget() const;
};

// Runs the chosen method. NLopt's random numbers are seeded with nlopt_srand(seed) in the
// calling thread (NLopt keeps its generator per thread), so NLopt runs are reproducible too.
// Throws std::invalid_argument for invalid options or bounds, momentum::Error when NLopt fails
// outright (out of memory, invalid arguments).
GlobalSummary minimize_global(const CostFunction& cost, const Bounds& bounds,
                              const GlobalOptions& options = {});

}  // namespace momentum::friction_fit
