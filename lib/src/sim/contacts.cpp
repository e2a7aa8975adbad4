#include "momentum/sim/contacts.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "momentum/core/error.hpp"
#include "momentum/core/random.hpp"
#include "momentum/stream/format.hpp"

namespace momentum::sim {

namespace {

constexpr std::uint64_t kContactStream = 21;
constexpr double kDefaultRadius = 0.05;
// Below this point speed (m/s) a clamp has no motion to oppose and uses the drawn normal.
constexpr double kRestSpeed = 1e-3;

bool range_ok(double lo, double hi, bool allow_zero) {
  return std::isfinite(lo) && std::isfinite(hi) && (allow_zero ? lo >= 0 : lo > 0) && lo <= hi;
}

// 0 -> 1 over [a, b] as a raised cosine (C1: zero slope at both ends).
double ramp(double t, double a, double b) {
  if (t <= a) return 0;
  if (t >= b) return 1;
  return 0.5 - 0.5 * std::cos(std::numbers::pi * (t - a) / (b - a));
}

Eigen::Vector3d random_unit(core::Random& random) {
  const double z = random.uniform(-1, 1);
  const double phi = random.uniform(0, 2 * std::numbers::pi);
  const double s = std::sqrt(std::max(0.0, 1 - z * z));
  return {s * std::cos(phi), s * std::sin(phi), z};
}

}  // namespace

bool parse_range(const std::string& text, double* min, double* max) {
  const auto colon = text.find(':');
  const auto lo = stream::parse_double(text.substr(0, colon));
  const auto hi = colon == std::string::npos ? lo : stream::parse_double(text.substr(colon + 1));
  if (!lo || !hi || !std::isfinite(*lo) || !std::isfinite(*hi) || *lo > *hi) return false;
  *min = *lo;
  *max = *hi;
  return true;
}

const char* direction_name(ContactDirection direction) {
  return direction == ContactDirection::normal ? "normal" : "any";
}

bool parse_direction(const std::string& name, ContactDirection* direction) {
  if (name == "normal") *direction = ContactDirection::normal;
  else if (name == "any") *direction = ContactDirection::any;
  else return false;
  return true;
}

bool ContactOptions::IsValid(std::string* why) const {
  if (count < 0) return invalid(why, "the number of collisions must be >= 0");
  if (!range_ok(force_min, force_max, false)) return invalid(why, "force range must be 0 < MIN <= MAX");
  if (!range_ok(rise_min, rise_max, false)) return invalid(why, "rise time range must be 0 < MIN <= MAX");
  if (!range_ok(hold_min, hold_max, true)) return invalid(why, "hold time range must be 0 <= MIN <= MAX");
  if (!range_ok(release_min, release_max, false))
    return invalid(why, "release time range must be 0 < MIN <= MAX");
  if (!(std::isfinite(min_spacing) && min_spacing >= 0)) return invalid(why, "minimum spacing must be >= 0");
  if (!(clamp_fraction >= 0 && clamp_fraction <= 1)) return invalid(why, "clamping fraction must be in [0, 1]");
  if (!range_ok(clamp_hold_min, clamp_hold_max, false))
    return invalid(why, "clamp hold range must be 0 < MIN <= MAX");
  if (!(std::isfinite(clamp_stiffness) && clamp_stiffness > 0)) return invalid(why, "clamp stiffness must be > 0");
  if (!(std::isfinite(clamp_damping) && clamp_damping >= 0)) return invalid(why, "clamp damping must be >= 0");
  for (double r : link_radius)
    if (!(std::isfinite(r) && r >= 0)) return invalid(why, "link radius must be >= 0");
  return true;
}

double push_envelope(const Contact& c, double t) {
  if (t <= c.t_onset || t >= c.t_end) return 0;
  if (t < c.t_rise_end) return ramp(t, c.t_onset, c.t_rise_end);
  if (t <= c.t_hold_end) return 1;
  return 1 - ramp(t, c.t_hold_end, c.t_end);
}

double campaign_length(const ContactOptions& o) {
  const double push = o.rise_max + o.hold_max + o.release_max;
  const double clamp = o.clamp_fraction > 0 ? o.clamp_hold_max + o.release_max : 0;
  return o.count * std::max(push, clamp) + std::max(0, o.count - 1) * o.min_spacing;
}

std::vector<Contact> plan_contacts(const ContactOptions& options, const model::Model& model,
                                   double t_begin, double t_end, std::uint64_t seed) {
  std::string why;
  if (!options.IsValid(&why)) throw Error("collisions: " + why);
  const int n = model.nq;
  std::vector<int> links = options.links;
  if (links.empty()) {
    for (int i = std::min(2, n); i <= n; ++i) links.push_back(i);
  }
  for (int link : links)
    if (link < 1 || link > n)
      throw Error("collisions: link " + std::to_string(link) + " does not exist (the chain has links 1.." +
                  std::to_string(n) + ")");
  if (!options.link_radius.empty() && options.link_radius.size() != 1 &&
      options.link_radius.size() != static_cast<std::size_t>(n))
    throw Error("collisions: " + std::to_string(options.link_radius.size()) + " link radii for " +
                std::to_string(n) + " links");

  core::Random random(core::derive_seed(seed, kContactStream));
  std::vector<Contact> contacts(options.count);
  double busy = 0;
  for (auto& c : contacts) {
    c.link = links[random.integer(0, static_cast<int>(links.size()) - 1)];
    c.clamp = random.chance(options.clamp_fraction);
    c.peak = random.uniform(options.force_min, options.force_max);
    double rise, hold, release;
    if (c.clamp) {
      rise = 0;
      hold = random.uniform(options.clamp_hold_min, options.clamp_hold_max);
    } else {
      rise = random.uniform(options.rise_min, options.rise_max);
      hold = random.uniform(options.hold_min, options.hold_max);
    }
    release = random.uniform(options.release_min, options.release_max);
    c.t_rise_end = rise;  // relative for now
    c.t_hold_end = rise + hold;
    c.t_end = rise + hold + release;
    busy += c.t_end;

    // Point on the link cylinder and the inward normal there, in the body frame.
    const int b = c.link - 1;
    const Eigen::Vector3d segment =
        b + 1 < n ? model.joints[b + 1].placement.translation : model.tip_placement.translation;
    Eigen::Vector3d along = segment;
    if (along.norm() < 1e-6) along = 2.0 * model.bodies[b].com;
    double radius = kDefaultRadius;
    if (options.link_radius.size() == 1) radius = options.link_radius[0];
    else if (!options.link_radius.empty()) radius = options.link_radius[b];
    Eigen::Vector3d outward;
    if (along.norm() < 1e-6) {
      outward = random_unit(random);
      c.point = radius * outward;
    } else {
      const Eigen::Vector3d e = along.normalized();
      Eigen::Vector3d e1 = e.unitOrthogonal();
      Eigen::Vector3d e2 = e.cross(e1);
      const double u = random.uniform();
      const double theta = random.uniform(0, 2 * std::numbers::pi);
      outward = std::cos(theta) * e1 + std::sin(theta) * e2;
      c.point = u * along + radius * outward;
    }
    if (options.direction == ContactDirection::normal) {
      c.direction = -outward;
      c.direction_in_body = true;
    } else {
      c.direction = random_unit(random);
      c.direction_in_body = false;
    }
  }

  const double span = t_end - t_begin;
  const double needed = busy + std::max(0, options.count - 1) * options.min_spacing;
  if (options.count > 0 && !(needed <= span))
    throw Error("collisions: " + std::to_string(options.count) + " contacts need " + core::short_number(needed) +
                " s of steady motion with a spacing of " + core::short_number(options.min_spacing) + " s, the run has " +
                core::short_number(std::max(0.0, span)) + " s; raise --duration or lower --min-spacing");
  // Uniform placement: N sorted uniform draws of the slack, then the contacts in order.
  std::vector<double> slack(options.count);
  for (auto& s : slack) s = random.uniform(0, span - needed);
  std::sort(slack.begin(), slack.end());
  double offset = t_begin;
  for (int k = 0; k < options.count; ++k) {
    auto& c = contacts[k];
    const double onset = offset + slack[k];
    c.t_onset = onset;
    c.t_rise_end += onset;
    c.t_hold_end += onset;
    c.t_end += onset;
    offset += (c.t_end - onset) + options.min_spacing;
  }
  return contacts;
}

ActiveContact::ActiveContact(const Contact& contact, const model::Model& model, model::Data& data,
                             const Eigen::VectorXd& q, const Eigen::VectorXd& dq,
                             const ContactOptions& options, const Eigen::Vector3d* heading)
    : contact_(contact), model_(&model), data_(&data), stiffness_(options.clamp_stiffness),
      damping_(options.clamp_damping), peak_torque_(Eigen::VectorXd::Zero(model.nq)),
      generalized_(model.nq) {
  const int b = contact.link - 1;
  model::point_jacobian(model, data, q, b, contact.point, J_);
  direction_ = contact.direction_in_body ? Eigen::Vector3d(data.rotation[b] * contact.direction)
                                         : contact.direction;
  direction_.normalize();
  if (contact.clamp) {
    anchor_ = data.position[b] + data.rotation[b] * contact.point;
    const Eigen::Vector3d v = J_ * dq;
    if (heading && (*heading - anchor_).norm() > 1e-3) direction_ = -(*heading - anchor_).normalized();
    else if (v.norm() > kRestSpeed) direction_ = -v.normalized();
  }
}

Eigen::Vector3d ActiveContact::force(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq) {
  const Contact& c = contact_;
  if (t < c.t_onset || t >= c.t_end) return Eigen::Vector3d::Zero();
  if (!c.clamp) return push_envelope(c, t) * c.peak * direction_;
  const int b = c.link - 1;
  model::point_jacobian(*model_, *data_, q, b, c.point, J_);
  const Eigen::Vector3d x = data_->position[b] + data_->rotation[b] * c.point;
  const double depth = (anchor_ - x).dot(direction_);
  if (depth <= 0) return Eigen::Vector3d::Zero();
  const double depth_rate = -(J_ * dq).dot(direction_);
  double f = std::clamp(stiffness_ * depth + damping_ * depth_rate, 0.0, c.peak);
  if (t > c.t_hold_end) f *= 1 - ramp(t, c.t_hold_end, c.t_end);
  return f * direction_;
}

Eigen::Vector3d ActiveContact::add_joint_torque(double t, const Eigen::VectorXd& q,
                                                const Eigen::VectorXd& dq, Eigen::VectorXd& tau,
                                                bool record) {
  const Eigen::Vector3d f = force(t, q, dq);
  if (f.isZero(0.0) && !record) return f;
  model::point_jacobian(*model_, *data_, q, contact_.link - 1, contact_.point, J_);
  generalized_.noalias() = J_.transpose() * f;
  tau += generalized_;
  const Eigen::VectorXd& generalized = generalized_;
  if (record) {
    const double magnitude = f.norm();
    if (magnitude > peak_force_) peak_force_ = magnitude, peak_vector_ = f;
    for (int j = 0; j < generalized.size(); ++j)
      if (std::abs(generalized[j]) > std::abs(peak_torque_[j])) peak_torque_[j] = -generalized[j];
  }
  return f;
}

}  // namespace momentum::sim
