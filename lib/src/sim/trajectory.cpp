#include "momentum/sim/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"

namespace momentum::sim {

namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;
// Velocity limit assumed for a joint whose URDF gives none, rad/s.
constexpr double kDefaultVelocityLimit = 2.0;
constexpr std::uint64_t kPtpStream = 11;
constexpr std::uint64_t kPhaseStream = 12;

}  // namespace

const char* trajectory_name(TrajectoryKind kind) {
  switch (kind) {
    case TrajectoryKind::paper: return "paper";
    case TrajectoryKind::multisine: return "multisine";
    case TrajectoryKind::excite: return "excite";
    case TrajectoryKind::ptp: return "ptp";
    case TrajectoryKind::hold: return "hold";
  }
  return "?";
}

bool parse_trajectory(const std::string& name, TrajectoryKind* kind) {
  for (TrajectoryKind k : {TrajectoryKind::paper, TrajectoryKind::multisine, TrajectoryKind::excite,
                           TrajectoryKind::ptp, TrajectoryKind::hold}) {
    if (name == trajectory_name(k)) {
      *kind = k;
      return true;
    }
  }
  return false;
}

bool TrajectoryOptions::IsValid(std::string* why) const {
  auto positive = [](double x) { return std::isfinite(x) && x > 0; };
  if (!positive(duration)) return invalid(why, "duration must be a positive number of seconds");
  // A bound keeps the step count (duration x internal rate) far inside a 64-bit integer: 1e20 s
  // overflowed it and ran until killed (issue 26's hostile test).
  if (duration > kMaxTrajectoryDuration)
    return invalid(why, "duration " + core::short_number(duration) + " s is longer than the " +
                         core::short_number(kMaxTrajectoryDuration) + " s (116 days) one run simulates");
  if (kind == TrajectoryKind::paper || kind == TrajectoryKind::multisine || kind == TrajectoryKind::excite) {
    if (!positive(blend)) return invalid(why, "blend must be a positive number of seconds");
    if (2 * blend > duration)
      return invalid(why, "duration " + core::short_number(duration) + " s is shorter than the two blends of " +
                           core::short_number(blend) + " s");
    if (!positive(amplitude)) return invalid(why, "amplitude must be positive");
  }
  if (kind == TrajectoryKind::paper && !positive(frequency))
    return invalid(why, "frequency must be positive");
  if (kind == TrajectoryKind::multisine || kind == TrajectoryKind::excite) {
    if (harmonics < 1 || harmonics > 100) return invalid(why, "harmonics must be within 1..100");
    if (!positive(base_frequency)) return invalid(why, "base frequency must be positive");
  }
  if (kind == TrajectoryKind::ptp) {
    if (!(limit_margin >= 0 && limit_margin < 0.5)) return invalid(why, "limit margin must be in [0, 0.5)");
    if (!(speed_fraction > 0 && speed_fraction <= 1)) return invalid(why, "speed fraction must be in (0, 1]");
    if (!(std::isfinite(min_move) && min_move > 0)) return invalid(why, "minimum move time must be positive");
    if (!(std::isfinite(max_dwell) && max_dwell >= 0)) return invalid(why, "maximum dwell must be >= 0");
    if (mirror) return invalid(why, "the ptp trajectory cannot be mirrored (its poses are drawn as time advances)");
  }
  return true;
}

Quintic Quintic::make(double t0, double T, double p0, double v0, double a0, double p1, double v1,
                      double a1) {
  Quintic q;
  q.t0 = t0;
  q.T = T;
  q.p1 = p1;
  const double h = p1 - p0, T2 = T * T, T3 = T2 * T;
  q.c[0] = p0;
  q.c[1] = v0;
  q.c[2] = a0 / 2;
  q.c[3] = (20 * h - (8 * v1 + 12 * v0) * T - (3 * a0 - a1) * T2) / (2 * T3);
  q.c[4] = (-30 * h + (14 * v1 + 16 * v0) * T + (3 * a0 - 2 * a1) * T2) / (2 * T3 * T);
  q.c[5] = (12 * h - 6 * (v1 + v0) * T + (a1 - a0) * T2) / (2 * T3 * T2);
  return q;
}

void Quintic::evaluate(double t, double& p, double& v, double& a) const {
  if (t <= t0) {
    p = c[0], v = 0, a = 0;
    if (t == t0) v = c[1], a = 2 * c[2];
    return;
  }
  if (t >= t0 + T) {
    p = p1, v = 0, a = 0;
    return;
  }
  const double s = t - t0;
  p = c[0] + s * (c[1] + s * (c[2] + s * (c[3] + s * (c[4] + s * c[5]))));
  v = c[1] + s * (2 * c[2] + s * (3 * c[3] + s * (4 * c[4] + s * 5 * c[5])));
  a = 2 * c[2] + s * (6 * c[3] + s * (12 * c[4] + s * 20 * c[5]));
}

Trajectory::Trajectory(const TrajectoryOptions& options, const model::Model& model,
                       const Eigen::VectorXd& home, std::uint64_t seed)
    : options_(options), n_(model.nq), random_(core::derive_seed(seed, kPtpStream)) {
  std::string why;
  if (!options.IsValid(&why)) throw Error("trajectory: " + why);
  if (home.size() != n_)
    throw Error("trajectory: home pose has " + std::to_string(home.size()) + " values, the chain has " +
                std::to_string(n_) + " joints");
  home_ = home;
  lower_.resize(n_);
  upper_.resize(n_);
  vmax_.resize(n_);
  for (int j = 0; j < n_; ++j) {
    const auto& lim = model.joints[j].limits;
    lower_[j] = lim.lower;
    upper_[j] = lim.upper;
    vmax_[j] = std::isfinite(lim.velocity) && lim.velocity > 0 ? lim.velocity : kDefaultVelocityLimit;
    if (!(home[j] >= lower_[j] && home[j] <= upper_[j]))
      throw Error("trajectory: home position " + core::short_number(home[j]) + " of joint " + std::to_string(j + 1) +
                  " is outside its limits [" + core::short_number(lower_[j]) + ", " + core::short_number(upper_[j]) + "]");
  }
  const double D = options.duration, Tb = options.blend;

  switch (options.kind) {
    case TrajectoryKind::hold:
      steady_begin_ = 0;
      steady_end_ = D;
      return;
    case TrajectoryKind::ptp:
      steady_begin_ = 0;
      steady_end_ = D;
      segment_.resize(n_);
      for (int j = 0; j < n_; ++j) segment_[j] = Quintic::make(0, 1, home_[j], 0, 0, home_[j], 0, 0);
      segment_end_ = 0;
      next_start_ = random_.uniform(0, options.max_dwell);
      return;
    case TrajectoryKind::paper:
      harmonics_.assign(n_, {Harmonic{options.amplitude, kTwoPi * options.frequency, 0.0}});
      break;
    case TrajectoryKind::multisine: {
      core::Random phases(core::derive_seed(seed, kPhaseStream));
      harmonics_.resize(n_);
      for (int j = 0; j < n_; ++j)
        for (int k = 1; k <= options.harmonics; ++k)
          harmonics_[j].push_back({1.0, kTwoPi * options.base_frequency * k, phases.uniform(0, kTwoPi)});
      scale_harmonics(1.0 / options.base_frequency);
      break;
    }
    case TrajectoryKind::excite: {
      // Interleaved frequency sets: sinusoids of distinct frequencies are orthogonal over the
      // common period, so every joint's motion (and its velocity and acceleration) is
      // uncorrelated with every other joint's, which is what separates the parameters of
      // different bodies. Schroeder's phases -pi i (i - 1) / H keep the peak of an equal-
      // amplitude sum near sqrt(2 H) instead of H, so the scaling to the limits leaves more power.
      harmonics_.resize(n_);
      const int H = options.harmonics;
      for (int j = 0; j < n_; ++j)
        for (int i = 1; i <= H; ++i) {
          const int k = j + 1 + n_ * (i - 1);
          harmonics_[j].push_back(
              {1.0, kTwoPi * options.base_frequency / n_ * k, -std::numbers::pi * i * (i - 1) / H});
        }
      scale_harmonics(n_ / options.base_frequency);
      break;
    }
  }

  // Entry blend from rest to the steady motion at tau = 0 (t = Tb); exit blend from the steady
  // motion at t = D - Tb to rest. The rest poses are chosen like a constant-jerk continuation,
  // so the blends are monotone for a smooth motion.
  entry_.resize(n_);
  exit_.resize(n_);
  for (int j = 0; j < n_; ++j) {
    double p, v, a;
    steady(j, 0, p, v, a);
    const double start = p - v * Tb / 2 + a * Tb * Tb / 12;
    entry_[j] = Quintic::make(0, Tb, start, 0, 0, p, v, a);
    steady(j, D - 2 * Tb, p, v, a);
    const double end = p + v * Tb / 2 + a * Tb * Tb / 12;
    exit_[j] = Quintic::make(D - Tb, Tb, p, v, a, end, 0, 0);
  }
  steady_begin_ = Tb;
  steady_end_ = D - Tb;

  // The steady part is periodic: checking the blends and one period covers the whole motion.
  const double period = options.kind == TrajectoryKind::paper       ? 1.0 / options.frequency
                        : options.kind == TrajectoryKind::multisine ? 1.0 / options.base_frequency
                                                                    : n_ / options.base_frequency;
  Eigen::VectorXd q(n_), dq(n_), ddq(n_);
  auto check = [&](double t) {
    evaluate(t, q, dq, ddq);
    for (int j = 0; j < n_; ++j) {
      if (q[j] < lower_[j] || q[j] > upper_[j])
        throw Error("trajectory " + std::string(trajectory_name(options.kind)) + ": joint " +
                    std::to_string(j + 1) + " would reach " + core::short_number(q[j]) + " at t = " + core::short_number(t) +
                    " s, outside its limits [" + core::short_number(lower_[j]) + ", " + core::short_number(upper_[j]) +
                    "]; move the home pose or lower the amplitude");
    }
  };
  const double step = std::min(0.005, period / 200);
  for (double t = 0; t <= std::min(D, Tb + period); t += step) check(t);
  for (double t = std::max(0.0, D - Tb); t <= D; t += step) check(t);
  check(D);
}

void Trajectory::scale_harmonics(double period) {
  const int grid = 4000 * std::max(1, n_);  // excite: n times the multisine's period
  for (int j = 0; j < n_; ++j) {
    auto& hs = harmonics_[j];
    double peak = 0, peak_v = 0;
    for (int s = 0; s < grid; ++s) {
      double p = 0, v = 0, a = 0;
      steady(j, period * s / grid, p, v, a);
      peak = std::max(peak, std::abs(p));
      peak_v = std::max(peak_v, std::abs(v));
    }
    const double room = std::min(home_[j] - lower_[j], upper_[j] - home_[j]);
    const double amplitude = std::min(options_.amplitude, 0.8 * room);
    double scale = amplitude / peak;
    scale = std::min(scale, 0.5 * vmax_[j] / peak_v);
    for (auto& h : hs) h.amplitude *= scale;
  }
}

void Trajectory::steady(int joint, double tau, double& p, double& v, double& a) const {
  p = v = a = 0;
  for (const auto& h : harmonics_[joint]) {
    const double s = std::sin(h.omega * tau + h.phase), c = std::cos(h.omega * tau + h.phase);
    p += h.amplitude * s;
    v += h.amplitude * h.omega * c;
    a -= h.amplitude * h.omega * h.omega * s;
  }
}

void Trajectory::next_ptp_segment() {
  const double start = next_start_;
  double T = options_.min_move;
  std::vector<double> target(n_);
  for (int j = 0; j < n_; ++j) {
    double lo = lower_[j], hi = upper_[j];
    if (!std::isfinite(lo) || !std::isfinite(hi)) lo = home_[j] - std::numbers::pi, hi = home_[j] + std::numbers::pi;
    const double m = options_.limit_margin * (hi - lo);
    target[j] = random_.uniform(lo + m, hi - m);
    const double distance = std::abs(target[j] - segment_[j].p1);
    T = std::max(T, 1.875 * distance / (options_.speed_fraction * vmax_[j]));
  }
  for (int j = 0; j < n_; ++j) segment_[j] = Quintic::make(start, T, segment_[j].p1, 0, 0, target[j], 0, 0);
  segment_end_ = start + T;
  next_start_ = segment_end_ + random_.uniform(0, options_.max_dwell);
}

void Trajectory::evaluate(double t, Eigen::VectorXd& q, Eigen::VectorXd& dq, Eigen::VectorXd& ddq) {
  if (!options_.mirror) return evaluate_forward(t, q, dq, ddq);
  evaluate_forward(options_.duration - t, q, dq, ddq);
  dq = Eigen::VectorXd::Zero(n_) - dq;  // +0 rather than -0 at rest
}

void Trajectory::evaluate_forward(double t, Eigen::VectorXd& q, Eigen::VectorXd& dq, Eigen::VectorXd& ddq) {
  q.resize(n_);
  dq.resize(n_);
  ddq.resize(n_);
  switch (options_.kind) {
    case TrajectoryKind::hold:
      q = home_;
      dq.setZero();
      ddq.setZero();
      return;
    case TrajectoryKind::ptp:
      while (t >= next_start_) next_ptp_segment();
      for (int j = 0; j < n_; ++j) segment_[j].evaluate(t, q[j], dq[j], ddq[j]);
      return;
    case TrajectoryKind::paper:
    case TrajectoryKind::multisine:
    case TrajectoryKind::excite:
      break;
  }
  const double Tb = options_.blend, D = options_.duration;
  for (int j = 0; j < n_; ++j) {
    double p, v, a;
    if (t < Tb) {
      entry_[j].evaluate(std::max(t, 0.0), p, v, a);
    } else if (t < D - Tb) {
      steady(j, t - Tb, p, v, a);
    } else {
      exit_[j].evaluate(t, p, v, a);
    }
    q[j] = home_[j] + p;
    dq[j] = v;
    ddq[j] = a;
  }
}

}  // namespace momentum::sim
