#include "momentum/sim/sensors.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "momentum/core/error.hpp"

namespace momentum::sim {

namespace {
constexpr std::uint64_t kNoiseStream = 31;
constexpr std::uint64_t kTimingStream = 32;

}  // namespace

const char* glitch_kind_name(GlitchKind kind) {
  switch (kind) {
    case GlitchKind::stop: return "stop";
    case GlitchKind::velocity: return "velocity";
    case GlitchKind::encoder: return "encoder";
    case GlitchKind::current: return "current";
  }
  return "?";
}

bool parse_glitch_kind(const std::string& name, GlitchKind* kind) {
  for (GlitchKind k : {GlitchKind::stop, GlitchKind::velocity, GlitchKind::encoder, GlitchKind::current}) {
    if (name == glitch_kind_name(k)) {
      *kind = k;
      return true;
    }
  }
  return false;
}

bool GlitchOptions::IsValid(std::string* why) const {
  if (count < 0) return invalid(why, "glitch count must be >= 0");
  if (count > 0 && kinds.empty()) return invalid(why, "no glitch kinds");
  if (!(std::isfinite(velocity_jump) && velocity_jump > 0)) return invalid(why, "glitch velocity jump must be > 0");
  if (!std::isfinite(current)) return invalid(why, "glitch current must be finite");
  if (!std::isfinite(position)) return invalid(why, "glitch position must be finite");
  return true;
}

void apply_glitch(const Glitch& glitch, const GlitchOptions& options, const Eigen::VectorXd& dq_true,
                  Eigen::VectorXd& q, Eigen::VectorXd& dq, Eigen::VectorXd& i) {
  // Against the motion: -1 for a joint moving forward (and at rest).
  auto against = [&](Eigen::Index j) { return dq_true[j] > 0 ? -1.0 : 1.0; };
  switch (glitch.kind) {
    case GlitchKind::stop:
      for (Eigen::Index j = 0; j < dq.size(); ++j) {
        dq[j] = against(j) * (std::fabs(dq[j]) + options.velocity_jump);
        i[j] = against(j) * options.current;
      }
      break;
    case GlitchKind::velocity:
      dq[glitch.joint] += against(glitch.joint) * options.velocity_jump;
      break;
    case GlitchKind::encoder:
      q[glitch.joint] = options.position;
      break;
    case GlitchKind::current:
      i[glitch.joint] += options.current;
      break;
  }
}

const char* velocity_source_name(VelocitySource source) {
  return source == VelocitySource::measured ? "measured" : "difference";
}

bool parse_velocity_source(const std::string& name, VelocitySource* source) {
  if (name == "measured") *source = VelocitySource::measured;
  else if (name == "difference") *source = VelocitySource::difference;
  else return false;
  return true;
}

bool SensorOptions::IsValid(std::string* why) const {
  if (encoder_bits < 0 || encoder_bits > 52) return invalid(why, "encoder bits must be within 0..52");
  if (!(std::isfinite(current_noise) && current_noise >= 0)) return invalid(why, "current noise must be >= 0");
  if (!(std::isfinite(velocity_noise) && velocity_noise >= 0)) return invalid(why, "velocity noise must be >= 0");
  if (!(std::isnan(time_jitter) || (std::isfinite(time_jitter) && time_jitter >= 0)))
    return invalid(why, "time jitter must be >= 0");
  if (!(std::isfinite(velocity_resolution) && velocity_resolution >= 0))
    return invalid(why, "velocity resolution must be >= 0");
  if (!(drop_rate >= 0 && drop_rate < 1)) return invalid(why, "drop rate must be in [0, 1)");
  return true;
}

Sensors::Sensors(const SensorOptions& options, const Eigen::VectorXd& k_i,
                 const Eigen::Array<bool, Eigen::Dynamic, 1>& revolute, std::uint64_t seed)
    : options_(options), k_i_(k_i), noise_(core::derive_seed(seed, kNoiseStream)),
      timing_(core::derive_seed(seed, kTimingStream)) {
  std::string why;
  if (!options.IsValid(&why)) throw Error("sensors: " + why);
  resolution_.setZero(k_i.size());
  for (Eigen::Index j = 0; j < k_i.size(); ++j) {
    if (!(std::isfinite(k_i[j]) && k_i[j] != 0))
      throw Error("sensors: joint " + std::to_string(j + 1) + " has torque constant k_i = " +
                  std::to_string(k_i[j]) + "; the current i = tau_m / k_i needs a nonzero k_i");
    if (options.encoder_bits > 0)
      resolution_[j] = (revolute[j] ? 2 * std::numbers::pi : 1.0) / std::ldexp(1.0, options.encoder_bits);
  }
}

void Sensors::measure(double t, const Eigen::VectorXd& q_true, const Eigen::VectorXd& dq_true,
                      const Eigen::VectorXd& tau_m, Eigen::VectorXd& q, Eigen::VectorXd& dq,
                      Eigen::VectorXd& i) {
  const Eigen::Index n = q_true.size();
  q.resize(n);
  dq.resize(n);
  i.resize(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const double r = resolution_[j];
    q[j] = r > 0 ? std::round(q_true[j] / r) * r : q_true[j];
  }
  if (options_.velocity == VelocitySource::measured) {
    for (Eigen::Index j = 0; j < n; ++j) dq[j] = dq_true[j] + options_.velocity_noise * noise_.normal();
  } else if (!started_ || !(t > previous_t_)) {
    dq.setZero();
  } else {
    dq = (q - previous_q_) / (t - previous_t_);
  }
  if (const double step = options_.velocity_resolution; step > 0)
    for (Eigen::Index j = 0; j < n; ++j) dq[j] = std::round(dq[j] / step) * step;
  for (Eigen::Index j = 0; j < n; ++j) i[j] = tau_m[j] / k_i_[j] + options_.current_noise * noise_.normal();
  previous_q_ = q;
  previous_t_ = t;
  started_ = true;
}

double Sensors::next_jitter(double period) {
  const double sigma = std::isnan(options_.time_jitter) ? 0.1 * period : options_.time_jitter;
  if (sigma <= 0) return 0;
  const double limit = 0.45 * period;
  return std::clamp(sigma * timing_.normal(), -limit, limit);
}

bool Sensors::next_dropped() { return timing_.chance(options_.drop_rate); }

}  // namespace momentum::sim
