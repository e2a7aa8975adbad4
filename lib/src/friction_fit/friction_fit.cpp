#include "momentum/friction_fit/friction_fit.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <limits>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/core/random.hpp"
#include "momentum/friction_fit/notes.hpp"
#include "momentum/friction_fit/polish.hpp"
#include "momentum/friction_fit/problem.hpp"
#include "momentum/friction_fit/uncertainty.hpp"

namespace momentum::friction_fit {

using friction::Kind;
using Params = friction::Parameters<double>;

ParameterBounds paper_bounds() {
  ParameterBounds b;
  for (int i = 0; i < kParameterCount; ++i) {
    b.lower[static_cast<std::size_t>(i)] = friction::kDefaultSearchBox[i].lower;
    b.upper[static_cast<std::size_t>(i)] = friction::kDefaultSearchBox[i].upper;
  }
  return b;
}

int parameter_index(const std::string& name) {
  for (int i = 0; i < kParameterCount; ++i)
    if (name == friction::kParameterNames[i]) return i;
  return -1;
}

std::vector<int> model_parameters(Kind kind, bool asymmetric) { return friction::used_parameters(kind, asymmetric); }

GeneticOptions quick_search() {
  GeneticOptions o;
  o.population = 40;
  o.generations = 60;
  o.restarts = 2;
  o.stall_generations = 20;
  return o;
}

bool PolishOptions::IsValid(std::string* why) const {
  if (max_iterations < 1) return invalid(why, "polish: max iterations must be >= 1");
  if (!(function_tolerance > 0)) return invalid(why, "polish: function tolerance must be > 0");
  if (!(parameter_tolerance > 0)) return invalid(why, "polish: parameter tolerance must be > 0");
  return true;
}


bool FitOptions::IsValid(std::string* why) const {
  if (!friction.IsValid(why)) return false;
  if (!global.IsValid(why)) return false;
  if (!polish.IsValid(why)) return false;
  if (!search_subset.IsValid(why)) return false;
  if (!fit_subset.IsValid(why)) return false;
  if (!(identifiability_threshold > 0)) return invalid(why, "identifiability threshold must be > 0");
  std::vector<Kind> kinds{kind};
  if (kind == Kind::lugre && compare_static) kinds.push_back(Kind::stribeck);
  for (Kind k : kinds) {
    for (int i : model_parameters(k, asymmetric)) {
      const auto u = static_cast<std::size_t>(i);
      const std::string name = friction::kParameterNames[i];
      const bool signed_parameter = i >= friction::kFirstSignedParameter;
      if (fixed[u]) {
        const double v = *fixed[u];
        if (!std::isfinite(v) || (v < 0 && !signed_parameter) || (friction::must_be_positive(k, i) && v == 0))
          return invalid(why, name + " = " + std::to_string(v) + " is not a valid fixed value");
        continue;
      }
      const double lo = bounds.lower[u], hi = bounds.upper[u];
      if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi))
        return invalid(why, name + ": bounds must be finite with lower < upper");
      if ((lo < 0 && !signed_parameter) || (friction::must_be_positive(k, i) && lo <= 0))
        return invalid(why, name + ": lower bound must be " + (friction::must_be_positive(k, i) ? "> 0" : ">= 0"));
    }
    if (free_parameters(*this, k).empty()) return invalid(why, "every parameter is fixed: nothing to fit");
  }
  return true;
}

namespace {

// Fits model `kind` to one joint: the problem, the global search over the box (on a subset of
// the samples on long data), the polish, the uncertainty and the notes. `seed` seeds the search
// and the noise draws; `joint` names the joint in progress and errors.
// `starts` (physical units, free parameters): no global search: each start is polished as the
// search's runs are.
ModelFit fit_model(const JointSeries& data, const observer::Gains& gains, Kind kind,
                   const FitOptions& options, std::uint64_t seed, int joint,
                   const JointProgressCallback& progress, const std::vector<std::vector<double>>& starts = {}) {
  const auto start = std::chrono::steady_clock::now();
  Problem problem(data, gains, kind, options);
  ModelFit fit;
  fit.kind = kind;
  fit.asymmetric = options.asymmetric;
  fit.free = problem.free;

  // Windows of the data with the filter's slow state at each one's start solved for (subset.hpp):
  // the problem on them, or nullopt when the subset is all the data.
  auto subset_problem = [&](const SubsetOptions& subset_options, JointSeries& subset, SubsetSummary& summary) {
    std::vector<std::size_t> segment_start, origin;
    subset = search_subset(data, gains, subset_options, &segment_start, &summary, &origin);
    std::optional<Problem> on;
    if (summary.used) {
      on.emplace(subset, gains, kind, options);
      std::vector<std::size_t> unknown;
      for (std::size_t g : segment_start)
        if (data.restart[origin[g]] == 0) unknown.push_back(g);
      on->set_unknown_starts(unknown, gains.k2 > 0);
    }
    return on;
  };
  // The fit's samples (the last polish, the ranking of end points, the uncertainties): all of
  // them, or on long data a constant-size set of windows, so that the fit's cost is set by the
  // model and not by the hours of data.
  JointSeries fit_data;
  const std::optional<Problem> fit_problem = subset_problem(options.fit_subset, fit_data, fit.fit_subset);
  const Problem& fitting = fit_problem ? *fit_problem : problem;
  // The search's samples: fewer still. The polish from each run's best (or each given start)
  // goes there first, its end points are ranked on the fit's samples, and the best one is
  // polished again on them (polish_fit).
  JointSeries search_data;
  const std::optional<Problem> search_problem = subset_problem(options.search_subset, search_data, fit.subset);
  const Problem& search = search_problem ? *search_problem : fitting;
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
  if (starts.empty()) {
    fit.global = minimize_global(
        [&](std::span<const double> x) { return search.cost(search.assemble(x.data(), nullptr)); },
        box, global);
  } else {
    fit.global.run_best = starts;
    for (const auto& start : starts) {
      const double c = search.cost(search.assemble(start.data(), nullptr));
      if (!(c >= fit.global.cost)) fit.global.cost = c, fit.global.best = start;
    }
    fit.global.evaluations = starts.size();
    fit.global.message = "no search: " + std::to_string(starts.size()) + " given starts";
  }
  if (!std::isfinite(fit.global.cost))
    throw Error("joint " + std::to_string(joint) + ": " + friction::kind_name(kind) +
                " model: the cost is not finite anywhere in the bounds");
  fit.parameters = problem.assemble(fit.global.best.data(), nullptr);
  fit.global_metrics = metrics_of(problem, fit.parameters);
  fit.evaluations = fit.global.evaluations;

  // Polish on the fit's samples, then the uncertainty of the estimate from them, the metrics
  // from every sample and the notes on every parameter.
  const Eigen::MatrixXd jacobian = polish_fit(fitting, search, options, joint, progress, fit);
  fit.metrics = metrics_of(problem, fit.parameters);
  const double fitting_cost = fit_problem ? fitting.cost(fit.parameters) : fit.metrics.cost;
  const ParameterUncertainty uncertainty =
      estimate_uncertainty(fitting, fit_problem ? fit_data : data, gains, options, seed, jacobian, fitting_cost, fit);
  annotate_estimates(problem, options, uncertainty, fit);
  fit.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return fit;
}
}  // namespace

void refit_from_static(JointFit& r, const JointSeries& data, const observer::Gains& gains, const FitOptions& options,
                       std::uint64_t seed, const JointProgressCallback& progress) {
  if (r.model.kind != Kind::lugre || !r.static_model || !(r.static_model->metrics.rms < r.model.metrics.rms)) return;
  std::vector<std::vector<double>> starts;
  for (const auto& [sigma0, sigma1] : {std::pair{options.bounds.lower[0], options.bounds.upper[1]},
                                       std::pair{options.bounds.upper[0], options.bounds.lower[1]}}) {
      Params p = r.static_model->parameters;
      p.sigma0 = sigma0;
      p.sigma1 = sigma1;
      double x[kParameterCount];
      p.to_array(x);
      std::vector<double> start;
      for (int i : r.model.free) {
        const auto k = static_cast<std::size_t>(i);
        start.push_back(std::clamp(x[k], options.bounds.lower[k], options.bounds.upper[k]));
      }
      starts.push_back(std::move(start));
  }
  const double first_rms = r.model.metrics.rms;
  ModelFit again = fit_model(data, gains, Kind::lugre, options, seed, data.joint, progress, starts);
  if (!(again.metrics.cost < r.model.metrics.cost)) return;
  again.polish_message = "refitted from the Stribeck fit (the first LuGre fit, rms " + core::significant(first_rms, 4) +
                         " Nm, was worse than it): " + again.polish_message;
  r.model = std::move(again);
}

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
  result.model = fit_model(data, gains, options.kind, options, core::derive_seed(seed, 0), data.joint, progress);
  result.model_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (options.kind == Kind::lugre && options.compare_static) {
    result.static_model =
        fit_model(data, gains, Kind::stribeck, options, core::derive_seed(seed, 1), data.joint, progress);
    result.static_seconds = result.static_model->seconds;
    refit_from_static(result, data, gains, options, core::derive_seed(seed, 0), progress);
  }
  if (options.asymmetric) {
    FitOptions symmetric = options;
    symmetric.asymmetric = false;
    result.symmetric_model =
        fit_model(data, gains, options.kind, symmetric, core::derive_seed(seed, 2), data.joint, progress);
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
                                 const JointProgressCallback& progress, const FitAgain& again) {
  if (gains.size() != data.size())
    throw std::invalid_argument("friction fit: one set of gains per joint needed");
  if (joint_options.size() != data.size())
    throw std::invalid_argument("friction fit: one set of options per joint needed");
  if (data.empty()) return {};
  std::string why;
  for (const auto& o : joint_options)
    if (!o.IsValid(&why)) throw std::invalid_argument("friction fit: " + why);
  const FitOptions& first = joint_options.front();  // the model and its comparisons: the same for every joint
  for (std::size_t i = 0; i < data.size(); ++i) {
    if (!gains[i].IsValid(&why)) throw std::invalid_argument("friction fit: observer gains: " + why);
    if (data[i].scored_count() == 0)
      throw Error("joint " + std::to_string(data[i].joint) + ": no sample to fit");
  }
  // One task per model and joint, and one that refits a joint's LuGre from its Stribeck fit
  // (refit_from_static) once both are done, so that three joints with their static
  // comparisons spread evenly over two cores. A joint fitted again (`again`) queues its tasks
  // ahead of those waiting: a core that finishes early takes them instead of idling until the
  // other joints are done. Each task's seed depends only on the joint and the model, as in
  // fit_joint, so no result depends on the schedule.
  enum class Which { model, symmetric, static_model, refit };
  constexpr std::size_t kKinds = 4;
  struct Task {
    std::size_t joint;
    Which which;
  };
  std::vector<FitOptions> options = joint_options;
  std::vector<JointFit> results(data.size());
  std::vector<std::exception_ptr> errors(data.size() * kKinds);  // joint-major by kind
  std::vector<int> fits_left(data.size(), 0);                      // model tasks before the refit
  std::deque<Task> queue;
  auto fit_tasks = [&](std::size_t i) {
    std::vector<Task> t{{i, Which::model}};
    if (first.asymmetric) t.push_back({i, Which::symmetric});
    if (first.kind == Kind::lugre && first.compare_static) t.push_back({i, Which::static_model});
    fits_left[i] = static_cast<int>(t.size());
    return t;
  };
  {
    // The chosen models first: they take longest.
    std::vector<std::vector<Task>> per_joint;
    for (std::size_t i = 0; i < data.size(); ++i) per_joint.push_back(fit_tasks(i));
    for (std::size_t k = 0; k < per_joint.front().size(); ++k)
      for (const auto& t : per_joint) queue.push_back(t[k]);
  }
  std::size_t unfinished = queue.size();  // queued or running
  std::mutex mutex;
  std::condition_variable changed;
  auto run = [&](const Task& task) {
    const std::size_t i = task.joint;
    const auto& d = data[i];
    const std::uint64_t seed = core::derive_seed(first.global.genetic.seed, static_cast<std::uint64_t>(d.joint));
    auto& r = results[i];  // a joint's fits write their own fields; its refit runs after them
    const auto start = std::chrono::steady_clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
    switch (task.which) {
      case Which::model:
        r.joint = d.joint;
        r.model = fit_model(d, gains[i], options[i].kind, options[i], core::derive_seed(seed, 0), d.joint, progress);
        r.model_seconds = elapsed();
        break;
      case Which::symmetric: {
        FitOptions own = options[i];
        own.asymmetric = false;
        r.symmetric_model = fit_model(d, gains[i], own.kind, own, core::derive_seed(seed, 2), d.joint, progress);
        r.symmetric_seconds = elapsed();
        break;
      }
      case Which::static_model:
        r.static_model = fit_model(d, gains[i], Kind::stribeck, options[i], core::derive_seed(seed, 1), d.joint, progress);
        r.static_seconds = elapsed();
        break;
      case Which::refit:
        // LuGre fits worse than their joint's Stribeck fit, fitted again.
        refit_from_static(r, d, gains[i], options[i], core::derive_seed(seed, 0), progress);
        r.model_seconds += elapsed();
        r.seconds = r.model_seconds + r.static_seconds + r.symmetric_seconds;
        break;
    }
  };
  auto work = [&] {
    std::unique_lock lock(mutex);
    for (;;) {
      changed.wait(lock, [&] { return !queue.empty() || unfinished == 0; });
      if (queue.empty()) return;
      const Task task = queue.front();
      queue.pop_front();
      lock.unlock();
      std::exception_ptr error;
      try {
        run(task);
      } catch (...) {
        error = std::current_exception();
      }
      const std::size_t i = task.joint;
      std::vector<Task> next;
      if (!error && task.which == Which::refit && again) {
        try {
          if (again(i, results[i], options[i])) next = fit_tasks(i);
        } catch (...) {
          error = std::current_exception();
        }
      }
      lock.lock();
      if (error) {
        errors[i * kKinds + static_cast<std::size_t>(task.which)] = error;
      } else if (task.which != Which::refit && --fits_left[i] == 0) {
        next = {{i, Which::refit}};
      }
      // A joint's next step goes first: it is what the others may end up waiting for.
      for (auto t = next.rbegin(); t != next.rend(); ++t) queue.push_front(*t);
      unfinished += next.size();
      --unfinished;
      changed.notify_all();
    }
  };
  if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const auto count = std::min<std::size_t>(static_cast<std::size_t>(threads), queue.size());
  std::vector<std::thread> pool;
  for (std::size_t i = 1; i < count; ++i) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  // The first failure by kind, then joint: the order in which the tasks were queued.
  for (std::size_t k = 0; k < kKinds; ++k)
    for (std::size_t i = 0; i < data.size(); ++i)
      if (errors[i * kKinds + k]) std::rethrow_exception(errors[i * kKinds + k]);
  return results;
}

}  // namespace momentum::friction_fit
