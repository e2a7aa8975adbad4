// The friction fit's problem: one model on one joint's data, the model's residual r_model =
// H(s) tau_f(dq) simulated sample by sample exactly as the observer will see it, the cost
// J = 1/2 sum (r - r_model)^2 over the counted samples, and its residuals and Jacobian for
// Ceres and for the uncertainties. Shared by the stages of a model's fit (friction_fit.cpp: the
// global search; polish.cpp; uncertainty.cpp; notes.cpp); not a stable interface of its own.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "momentum/friction_fit/data.hpp"
#include "momentum/friction_fit/friction_fit.hpp"
#include "momentum/friction/friction.hpp"
#include "momentum/observer/filter.hpp"

namespace momentum::friction_fit {

// Indices of the parameters of `kind` that `o` leaves free (used by the model, not fixed).
std::vector<int> free_parameters(const FitOptions& o, friction::Kind kind);

// One model on one joint's data, with everything per sample precomputed: the interval and
// the observer filter's coefficients (identical consecutive intervals share them).
struct Problem {
  const JointSeries* data = nullptr;
  friction::Kind kind = friction::Kind::lugre;
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
  // Steps per interval where the motion is slow or reverses (simulate); 1: one step per sample.
  int resolve_slow = 1;

  // Precomputes the intervals and filter coefficients of `series` (which must outlive the
  // problem) for model `k` with the free parameters, fixed values and scales of `options`.
  Problem(const JointSeries& series, const observer::Gains& gains, friction::Kind k, const FitOptions& options);

  // A search subset's segments start where the observer had been running: the observer's filter
  // state there is unknown, and the model's starts at rest. The filter is linear, so the
  // difference in its slow state (the second-order observer's K2 pole, seconds long, too slow
  // for a short warm-up) adds a known response h to r, decaying with that pole, times an
  // unknown size per segment; the cost takes the best size for each segment (a linear least
  // squares in closed form), as if the filter had been warmed up for ever. The fast pole and
  // the friction state settle within the segment's uncounted warm-up. `starts`: first sample
  // of each such segment; `slow_pole`: false for a first-order observer (no slow state).
  void set_unknown_starts(const std::vector<std::size_t>& starts, bool slow_pole);
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
  // With resolve_slow > 1 (a finer discretisation of the same model, which the uncertainty uses
  // to measure how much the estimate rests on motion within the sample intervals) an interval
  // where the velocity changes sign or is slower than 4 w_s at either end is advanced in
  // resolve_slow equal steps, the velocity interpolated linearly between the samples, and the
  // filter sees the interval's mean friction (trapezoidal over the steps) as a constant: the
  // observer's r sees friction only through the change of momentum over the interval, which
  // is its integral. Elsewhere the Stribeck term is flat to 1e-7 and the bristles saturated
  // within a small part of the interval, so one step per sample is already that resolution.
  template <class T, class Sink>
  void simulate(const friction::Parameters<T>& p, Sink&& sink) const {
    if (resolve_slow > 1) return simulate_resolving_slow(p, sink);
    friction::JointFriction<T> model(kind, p, friction);
    observer::FilterState<T> filter;
    T previous = T(0);
    const auto& d = *data;
    for (std::size_t k = 0; k < d.size(); ++k) {
      if (d.restart[k] >= 2) model.reset();
      const T tau = model.step(T(d.dq[k]), dt[k]);
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
  // simulate() with resolve_slow > 1: a loop of its own, so that the one-step loop, which the
  // fit runs thousands of times, stays as the compiler made it without this one.
  template <class T, class Sink>
  void simulate_resolving_slow(const friction::Parameters<T>& p, Sink& sink) const {
    friction::JointFriction<T> model(kind, p, friction);
    observer::FilterState<T> filter;
    T previous = T(0);
    const auto& d = *data;
    const T slow = 4.0 * p.w_s;  // compared by value: a Jet by its scalar part
    for (std::size_t k = 0; k < d.size(); ++k) {
      if (d.restart[k] >= 2) model.reset();
      if (d.restart[k]) {
        previous = model.step(T(d.dq[k]), dt[k]);
        filter.reset();
        sink(k, T(0), previous);
        continue;
      }
      const auto& c = coefficients[coefficient_of[k]];
      const double v0 = d.dq[k - 1], v1 = d.dq[k];
      if (T(std::min(std::abs(v0), std::abs(v1))) < slow || (v0 < 0) != (v1 < 0)) {
        T sum = 0.5 * previous, tau = previous;
        const double h = dt[k] / resolve_slow;
        for (int s = 1; s <= resolve_slow; ++s) {
          tau = model.step(T(v0 + (v1 - v0) * s / resolve_slow), h);
          sum += s == resolve_slow ? 0.5 * tau : tau;
        }
        const T mean = sum / static_cast<double>(resolve_slow);
        filter.advance(c, mean, mean);
        previous = tau;
      } else {
        const T tau = model.step(T(v1), dt[k]);
        filter.advance(c, previous, tau);
        previous = tau;
      }
      sink(k, filter.output(c), previous);
    }
  }
  // 1/2 sum of squared errors over the counted samples, for parameters in physical units;
  // infinite where a direction's level is not positive.
  double cost(const friction::Parameters<double>& p) const;
};

// Ceres residuals r - r_model over the counted samples; parameter i is x * scale[i].
struct Residuals {
  const Problem* problem;
  std::array<double, kParameterCount> scale;
  template <class T>
  bool operator()(T const* const* x, T* residuals) const {
    const auto p = problem->assemble<T>(x[0], scale.data());
    if (!friction::feasible(problem->kind, p)) return false;  // Ceres rejects the step
    const auto& d = *problem->data;
    std::size_t m = 0;
    problem->simulate(p, [&](std::size_t k, const T& y, const T&) {
      if (d.scored[k]) residuals[m++] = T(d.r[k]) - y;
    });
    if (problem->has_nuisance()) problem->remove_nuisance(residuals);
    return true;
  }
};

// The counted residuals e = r - r_model and their Jacobian d e / d x at the scaled free
// parameters x (parameter free[j] = x[j] * scale[free[j]]), by one pass with dual numbers; false
// where the parameters are infeasible or more than 8 are free.
bool jacobian_at(const Problem& problem, const std::vector<double>& x,
                 const std::array<double, kParameterCount>& scale, Eigen::VectorXd& e,
                 Eigen::MatrixXd& jacobian);

// Metrics of parameters p (physical units) on the counted samples of the problem.
FitMetrics metrics_of(const Problem& problem, const friction::Parameters<double>& p);

}  // namespace momentum::friction_fit
