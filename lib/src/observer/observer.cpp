#include "momentum/observer/observer.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <set>
#include <stdexcept>
#include <type_traits>

#include "momentum/core/error.hpp"
#include "momentum/core/lanes.hpp"
#include "momentum/core/number.hpp"

namespace momentum::observer {
namespace {

[[noreturn]] void error(const std::string& message) { throw Error("observer: " + message); }

std::vector<double> number_or_list(const nlohmann::json& value, const char* key) {
  std::vector<double> out;
  auto take = [&](const nlohmann::json& x) {
    if (!x.is_number() || !std::isfinite(x.get<double>()))
      error(std::string("'") + key + "' must be a finite number or a list of them");
    out.push_back(x.get<double>());
  };
  if (value.is_array()) {
    if (value.empty()) error(std::string("'") + key + "' is an empty list");
    for (const auto& x : value) take(x);
  } else {
    take(value);
  }
  return out;
}

}  // namespace

bool ObserverOptions::IsValid(std::string* why) const {
  if (order != 1 && order != 2) return invalid(why, "order must be 1 or 2, not " + std::to_string(order));
  if (k1.empty() || k2.empty() || k3.empty()) return invalid(why, "a gain list is empty");
  if (!std::isfinite(gap_factor) || !(gap_factor > 1))
    return invalid(why, "gap_factor must be a finite number > 1");
  if (!std::isfinite(bridge_tolerance) || !(bridge_tolerance >= 0))
    return invalid(why, "bridge_tolerance must be a finite number >= 0");
  if (!signals.IsValid(why)) return false;
  const std::size_t n = std::max({k1.size(), k2.size(), k3.size()});
  for (std::size_t j = 0; j < n; ++j) {
    Gains g{k1[std::min(j, k1.size() - 1)], order == 2 ? k2[std::min(j, k2.size() - 1)] : 0.0,
            order == 2 ? k3[std::min(j, k3.size() - 1)] : 0.0};
    std::string reason;
    if (!g.IsValid(&reason)) {
      return invalid(why, (n > 1 ? "joint " + std::to_string(j + 1) + ": " : std::string()) + reason);
    }
  }
  return true;
}

std::vector<Gains> ObserverOptions::joint_gains(int joints) const {
  auto pick = [&](const std::vector<double>& list, const char* name, int j) {
    if (list.size() != 1 && list.size() != static_cast<std::size_t>(joints))
      error(std::string(name) + " has " + std::to_string(list.size()) + " values for " +
            std::to_string(joints) + " joints");
    return list.size() == 1 ? list[0] : list[static_cast<std::size_t>(j)];
  };
  std::vector<Gains> gains;
  for (int j = 0; j < joints; ++j) {
    Gains g;
    g.k1 = pick(k1, "k1", j);
    g.k2 = order == 2 ? pick(k2, "k2", j) : 0.0;
    g.k3 = order == 2 ? pick(k3, "k3", j) : 0.0;
    gains.push_back(g);
  }
  return gains;
}

ObserverOptions observer_options_from_json(const nlohmann::json& section,
                                           std::vector<std::string>* warnings) {
  if (!section.is_object()) error("the section is not an object");
  static const std::set<std::string> known = {"order", "k1", "k2", "k3", "cutoff_hz", "gap_factor",
                                                "bridge_tolerance", "signal_check", "signal_sigmas", "limit_factor"};
  for (const auto& item : section.items())
    if (!known.count(item.key()) && warnings) warnings->push_back("observer: unknown key '" + item.key() + "'");
  ObserverOptions options;
  if (const auto it = section.find("order"); it != section.end()) {
    if (!it->is_number_integer() || (it->get<int>() != 1 && it->get<int>() != 2))
      error("'order' must be 1 or 2");
    options.order = it->get<int>();
  }
  const auto k1 = section.find("k1");
  const auto cutoff = section.find("cutoff_hz");
  if (k1 != section.end() && cutoff != section.end()) error("give either 'k1' or 'cutoff_hz', not both");
  if (k1 != section.end()) options.k1 = number_or_list(*k1, "k1");
  if (cutoff != section.end()) {
    options.k1 = number_or_list(*cutoff, "cutoff_hz");
    for (double& k : options.k1) k *= 2 * std::numbers::pi;
  }
  if (const auto it = section.find("k2"); it != section.end()) options.k2 = number_or_list(*it, "k2");
  if (const auto it = section.find("k3"); it != section.end()) options.k3 = number_or_list(*it, "k3");
  if (const auto it = section.find("gap_factor"); it != section.end()) {
    if (!it->is_number()) error("'gap_factor' must be a number");
    options.gap_factor = it->get<double>();
  }
  if (const auto it = section.find("bridge_tolerance"); it != section.end()) {
    if (!it->is_number()) error("'bridge_tolerance' must be a number");
    options.bridge_tolerance = it->get<double>();
  }
  if (const auto it = section.find("signal_check"); it != section.end()) {
    if (!it->is_boolean()) error("'signal_check' must be true or false");
    options.signals.enabled = it->get<bool>();
  }
  if (const auto it = section.find("signal_sigmas"); it != section.end()) {
    if (!it->is_number()) error("'signal_sigmas' must be a number");
    options.signals.sigmas = it->get<double>();
  }
  if (const auto it = section.find("limit_factor"); it != section.end()) {
    if (!it->is_number()) error("'limit_factor' must be a number");
    options.signals.limit_factor = it->get<double>();
  }
  std::string why;
  if (!options.IsValid(&why)) error(why);
  return options;
}

ResidualObserver::ResidualObserver(std::vector<Gains> gains, const friction::FrictionModel* friction)
    : gains_(std::move(gains)), state_(kJointArrays * gains_.size()) {
  for (std::size_t j = 0; j < gains_.size(); ++j) {
    same_gains_as_previous_.push_back(j > 0 && gains_[j].k1 == gains_[j - 1].k1 &&
                                      gains_[j].k2 == gains_[j - 1].k2 &&
                                      gains_[j].k3 == gains_[j - 1].k3);
  }
  if (friction) {
    if (friction->joints.size() != gains_.size())
      throw std::invalid_argument("ResidualObserver: friction model has " +
                                  std::to_string(friction->joints.size()) + " joints, expected " +
                                  std::to_string(gains_.size()));
    friction_ = friction::make_joint_frictions(*friction);
  }
}

namespace {
// The number of a FilterCoefficients' members, and their order in the observer's arrays.
constexpr std::size_t kCoefficients = 8;

void store_coefficients(const FilterCoefficients& c, std::size_t n, std::size_t j, double* arrays) {
  const double members[kCoefficients] = {c.a1, c.b10, c.b11, c.a2, c.c21, c.b20, c.b21, c.gain};
  for (std::size_t k = 0; k < kCoefficients; ++k) arrays[k * n + j] = members[k];
}

template <class V>
FilterCoefficientLanes<V> load_coefficients(const double* arrays, std::size_t n, std::size_t j) {
  auto at = [&](std::size_t k) { return core::lanes::load<V>(arrays + k * n + j); };
  return {at(0), at(1), at(2), at(3), at(4), at(5), at(6), at(7)};
}
}  // namespace

void ResidualObserver::step(double dt, const double* p, const double* u, const double* dq,
                            double* r, double* tau_f, double* mu) {
  const std::size_t n = gains_.size();
  const bool with_friction = !friction_.empty();
  double* const arrays = state_.data();
  auto array = [arrays, n](JointArray which) { return arrays + which * n; };
  double* const previous_p = array(kPreviousP);
  double* const previous_u = array(kPreviousU);
  double* const previous_tau_f = array(kPreviousTauF);
  if (!started_) {
    started_ = true;
    std::fill(arrays, arrays + kPreviousP * n, 0.0);  // every filter at rest
    for (std::size_t j = 0; j < n; ++j) {
      previous_p[j] = p[j];
      previous_u[j] = u[j];
      r[j] = 0.0;
      if (with_friction) {
        friction_[j].reset();
        previous_tau_f[j] = friction_[j].step(dq[j], 0.0);
        tau_f[j] = previous_tau_f[j];
        mu[j] = 0.0;
      }
    }
    return;
  }
  const double inv_dt = 1.0 / dt;
  // Coefficients depend on the gains and dt only: joints with the gains of the joint before
  // share them, and an interval seen lately (bit for bit) finds them in the cache.
  const std::vector<double>* coefficients = coefficients_.find(dt);
  if (!coefficients) {
    std::vector<double>& fresh = coefficients_.insert(dt);
    fresh.resize(kCoefficients * n);
    FilterCoefficients c;
    for (std::size_t j = 0; j < n; ++j) {
      if (!same_gains_as_previous_[j]) c = discretize(gains_[j], dt);
      store_coefficients(c, n, j, fresh.data());
    }
    coefficients = &fresh;
  }
  // Joints j (and j + 1 for a Pair): the same operations in the same order for each lane as for
  // one double, so two joints at a time give the bits one at a time gives.
  auto step_joints = [&]<class V>(std::size_t j) {
    using core::lanes::load;
    using core::lanes::store;
    const FilterCoefficientLanes<V> c = load_coefficients<V>(coefficients->data(), n, j);
    // tau_d = u - dp/dt over the interval, with u linear and p linear between the samples.
    const V p_now = load<V>(p + j), u_now = load<V>(u + j);
    const V dp = (p_now - load<V>(previous_p + j)) * inv_dt;
    const V x_start = load<V>(previous_u + j) - dp;
    const V x_end = u_now - dp;
    FilterState<V> residual{load<V>(array(kResidualS1) + j), load<V>(array(kResidualS2) + j)};
    residual.advance(c, x_start, x_end);
    store(array(kResidualS1) + j, residual.s1);
    store(array(kResidualS2) + j, residual.s2);
    store(r + j, residual.output(c));
    if (with_friction) {
      V f;
      if constexpr (std::is_same_v<V, double>) {
        f = friction_[j].step(dq[j], dt);
      } else {
        f = V{friction_[j].step(dq[j], dt), friction_[j + 1].step(dq[j + 1], dt)};
      }
      FilterState<V> compensated{load<V>(array(kCompensatedS1) + j), load<V>(array(kCompensatedS2) + j)};
      compensated.advance(c, x_start - load<V>(previous_tau_f + j), x_end - f);
      store(array(kCompensatedS1) + j, compensated.s1);
      store(array(kCompensatedS2) + j, compensated.s2);
      store(mu + j, compensated.output(c));
      store(tau_f + j, f);
      store(previous_tau_f + j, f);
    }
    store(previous_p + j, p_now);
    store(previous_u + j, u_now);
  };
  core::lanes::for_joints(n, step_joints);
}

namespace {
std::vector<Gains> checked_gains(const ObserverOptions& options, int joints) {
  std::string why;
  if (!options.IsValid(&why)) error(why);
  return options.joint_gains(joints);
}
}  // namespace

MomentumObserver::MomentumObserver(const model::Model& model, const ObserverOptions& options,
                                   const friction::FrictionModel* friction)
    : model_(model),
      data_(model),
      gap_factor_(options.gap_factor),
      bridge_tolerance_(options.bridge_tolerance),
      residual_(checked_gains(options, model.nq), friction),
      q_(model.nq),
      dq_(model.nq),
      p_(model.nq),
      beta_(model.nq),
      u_(model.nq),
      batch_(model, data_) {
  const auto values = static_cast<std::size_t>(model::MomentumBatch::kLanes * model.nq);
  for (auto* v : {&ahead_p_, &ahead_beta_}) v->assign(values, 0.0);
}

void MomentumObserver::precompute(int count, const double* const q[], const double* const dq[]) {
  count = std::min(count, model::MomentumBatch::kLanes);
  if (count < 2 || !batch_.accelerated()) return;
  const int n = model_.nq;
  const double* lane_q[model::MomentumBatch::kLanes];
  const double* lane_dq[model::MomentumBatch::kLanes];
  double* lane_p[model::MomentumBatch::kLanes];
  double* lane_beta[model::MomentumBatch::kLanes];
  for (int k = 0; k < count; ++k) {
    // Kept: step() compares the samples it gets with these.
    ahead_q_[k] = lane_q[k] = q[k];
    ahead_dq_[k] = lane_dq[k] = dq[k];
    lane_p[k] = &ahead_p_[k * n];
    lane_beta[k] = &ahead_beta_[k * n];
  }
  batch_.run(count, lane_q, lane_dq, lane_p, lane_beta);
  ahead_next_ = 0;
  ahead_count_ = count;
}

namespace {
// Whether a and b hold the same n doubles bit for bit (memcmp's answer, inline and two at a
// time: the row path asks it twice a row for six values, where a call costs more than the
// comparison).
bool same_bits(const double* a, const double* b, int n) {
  using core::lanes::PairMask;
  PairMask differ{};
  int j = 0;
  for (; j + 2 <= n; j += 2) differ |= core::lanes::load<PairMask>(a + j) ^ core::lanes::load<PairMask>(b + j);
  std::uint64_t last = 0;
  if (j < n) last = std::bit_cast<std::uint64_t>(a[j]) ^ std::bit_cast<std::uint64_t>(b[j]);
  return (differ[0] | differ[1] | static_cast<std::int64_t>(last)) == 0;
}
}  // namespace

int MomentumObserver::take_precomputed(const double* q, const double* dq) {
  const int n = model_.nq;
  for (int k = ahead_next_; k < ahead_count_; ++k) {
    if (!same_bits(q, ahead_q_[k], n) || !same_bits(dq, ahead_dq_[k], n)) continue;
    ahead_next_ = k + 1;
    ++ahead_taken_;
    return k;
  }
  ahead_next_ = ahead_count_;
  return -1;
}

void MomentumObserver::record_interval(double dt, bool gap) {
  step_median_.push(dt);
  // The median moves slowly; recomputing it every 8 intervals keeps the hot path cheap. After
  // a gap it is recomputed at once, so that a change of sample rate stops counting as gaps as
  // soon as half the window holds the new rate.
  if (gap || !step_median_.full() || ++since_median_ >= 8) {
    since_median_ = 0;
    median_dt_ = step_median_.update();
  }
}

void MomentumObserver::measure_mismatch(double dt, const double* q, const double* dq) {
  mismatch_ = 0;
  mismatch_joint_ = 0;
  for (int j = 0; j < model_.nq; ++j) {
    const double e = std::abs(q[j] - q_[j] - 0.5 * dt * (dq[j] + dq_[j]));
    if (!(e <= mismatch_)) {
      mismatch_ = e;
      mismatch_joint_ = j;
    }
  }
}

SampleStatus MomentumObserver::step(double t, const double* q, const double* dq,
                                    const double* tau_m, double* r, double* tau_f, double* mu) {
  const int n = model_.nq;
  if (have_time_ && std::isfinite(t) && !(t > t_previous_)) return SampleStatus::time_not_increasing;
  const bool finite = std::isfinite(t) && core::all_finite(q, dq, tau_m, n);
  if (!finite) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    std::fill(r, r + n, nan);
    if (has_friction()) {
      std::fill(tau_f, tau_f + n, nan);
      std::fill(mu, mu + n, nan);
    }
    ++bad_run_;
    restart_pending_ = true;
    residual_.reset();
    return SampleStatus::invalid;
  }
  SampleStatus status = SampleStatus::ok;
  double dt = 0;
  if (!have_time_) {
    status = SampleStatus::started;
    have_time_ = true;
  } else {
    dt = t - t_previous_;
    if (restart_pending_) {
      status = SampleStatus::restarted_after_bad;
    } else {
      const bool gap = is_gap(t);
      if (gap) {
        last_gap_ = dt;
        last_gap_mismatched_ = false;
        if (dt > gap_factor_ * median_dt_) {
          status = SampleStatus::restarted_after_gap;
        } else {
          measure_mismatch(dt, q, dq);
          last_gap_mismatched_ = !(mismatch_ <= bridge_tolerance_);
          status = last_gap_mismatched_ ? SampleStatus::restarted_after_gap : SampleStatus::bridged;
        }
      }
      record_interval(dt, gap);
    }
  }
  if (restart_pending_) {
    last_bad_run_ = bad_run_;
    bad_run_ = 0;
    restart_pending_ = false;
  }
  t_previous_ = t;
  if (status != SampleStatus::ok && status != SampleStatus::bridged) residual_.reset();
  for (int j = 0; j < n; ++j) {
    q_[j] = q[j];
    dq_[j] = dq[j];
  }
  const double* p = p_.data();
  const double* beta = beta_.data();
  if (const int k = precomputed() == 0 ? -1 : take_precomputed(q, dq); k >= 0) {
    p = &ahead_p_[static_cast<std::size_t>(k * n)];
    beta = &ahead_beta_[static_cast<std::size_t>(k * n)];
  } else {
    model::momentum_and_beta(model_, data_, q_, dq_, p_, beta_);
  }
  for (int j = 0; j < n; ++j) u_[j] = tau_m[j] - beta[j];
  residual_.step(dt, p, u_.data(), dq, r, tau_f, mu);
  return status;
}

}  // namespace momentum::observer
