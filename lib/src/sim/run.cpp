#include "momentum/sim/run.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/model/dynamics.hpp"

namespace momentum::sim {

using Eigen::VectorXd;

namespace {

constexpr std::uint64_t kTrajectoryStream = 1;
constexpr std::uint64_t kContactPlanStream = 2;
constexpr std::uint64_t kSensorStream = 3;
constexpr std::uint64_t kGlitchStream = 4;
// Contacts start at least this long after the entry blend (the observer's start-up).
constexpr double kContactGuard = 1.0;

// The slowest decay rate of the PD part of the loop e'' + Kd e' + Kp e = 0 (Kp = w^2,
// Kd = 2 zeta w): zeta w when underdamped or critical, the slow real pole when overdamped.
double controller_recovery_time(const ControllerOptions& o) {
  const double w = 2 * std::numbers::pi * o.bandwidth_hz;
  const double z = o.damping_ratio;
  const double rate = z <= 1 ? z * w : w * (z - std::sqrt(z * z - 1));
  return 10 / rate + o.integral_time;
}

}  // namespace

SimulationSection read_simulation_section(const model::Profile& profile, const model::Model& model) {
  SimulationSection out;
  const int n = model.nq;
  const std::string file = profile.path.string();
  auto error = [&](const std::string& message) { return Error(located(file, 0, message)); };
  out.home.resize(n);
  for (int j = 0; j < n; ++j) {
    const auto& lim = model.joints[j].limits;
    out.home[j] = std::isfinite(lim.lower) && std::isfinite(lim.upper) ? 0.5 * (lim.lower + lim.upper) : 0.0;
  }
  const auto it = profile.document.find("simulation");
  if (it == profile.document.end()) return out;
  const nlohmann::json& section = *it;
  if (!section.is_object()) throw error("\"simulation\" must be an object");
  for (const auto& item : section.items()) {
    const std::string& key = item.key();
    const nlohmann::json& value = item.value();
    if (key == "friction") {
      std::vector<std::string> warnings;
      try {
        out.friction = friction::friction_from_json(value, &warnings);
      } catch (const Error& e) {
        throw error(std::string("simulation.") + e.what());
      }
      for (const auto& w : warnings) warn(located(file, 0, "simulation." + w));
      if (out.friction.joints.size() != static_cast<std::size_t>(n))
        throw error("simulation.friction has " + std::to_string(out.friction.joints.size()) +
                    " joints, the chain has " + std::to_string(n));
      out.has_friction = true;
    } else if (key == "home") {
      if (!value.is_array() || value.size() != static_cast<std::size_t>(n))
        throw error("simulation.home must be an array of " + std::to_string(n) + " numbers (rad)");
      for (int j = 0; j < n; ++j) {
        if (!value[j].is_number()) throw error("simulation.home must hold numbers");
        out.home[j] = value[j].get<double>();
      }
    } else if (key == "link_radius") {
      if (value.is_number()) {
        out.link_radius = {value.get<double>()};
      } else if (value.is_array() && value.size() == static_cast<std::size_t>(n)) {
        for (const auto& r : value) {
          if (!r.is_number()) throw error("simulation.link_radius must hold numbers");
          out.link_radius.push_back(r.get<double>());
        }
      } else {
        throw error("simulation.link_radius must be a number or " + std::to_string(n) + " numbers (m)");
      }
      for (double r : out.link_radius)
        if (!(std::isfinite(r) && r >= 0)) throw error("simulation.link_radius must be >= 0");
    } else {
      warn(located(file, 0, "unknown key \"simulation." + key + "\" ignored"));
    }
  }
  return out;
}

bool RunOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(rate_hz) && rate_hz > 0)) return invalid(why, "rate must be > 0 Hz");
  if (!(std::isfinite(internal_rate_hz) && internal_rate_hz >= rate_hz))
    return invalid(why, "internal rate must be at least the output rate");
  std::string inner;
  if (!trajectory.IsValid(&inner)) return invalid(why, "trajectory: " + inner);
  if (!controller.IsValid(&inner)) return invalid(why, inner);
  if (!sensors.IsValid(&inner)) return invalid(why, "sensors: " + inner);
  if (!contacts.IsValid(&inner)) return invalid(why, "collisions: " + inner);
  if (!glitches.IsValid(&inner)) return invalid(why, inner);
  return true;
}

std::vector<Glitch> plan_glitches(const GlitchOptions& options, int nq, double begin, double end,
                                  const std::vector<Contact>& contacts, std::uint64_t seed) {
  std::vector<Glitch> out;
  if (options.count <= 0 || !(end > begin)) return out;
  core::Random random(seed);
  auto clear = [&](double t) {
    for (const Contact& c : contacts)
      if (t > c.t_onset - kGlitchClearance && t < c.t_end + kGlitchClearance) return false;
    for (const Glitch& g : out)
      if (std::fabs(t - g.t) < kGlitchClearance) return false;
    return true;
  };
  for (int k = 0; k < options.count; ++k) {
    Glitch glitch;
    glitch.kind = options.kinds[static_cast<std::size_t>(k) % options.kinds.size()];
    glitch.joint = glitch.kind == GlitchKind::stop ? -1 : random.integer(0, nq - 1);
    bool placed = false;
    for (int attempt = 0; attempt < 1000 && !placed; ++attempt) {
      glitch.t = random.uniform(begin, end);
      placed = clear(glitch.t);
    }
    if (placed) out.push_back(glitch);
  }
  std::sort(out.begin(), out.end(), [](const Glitch& a, const Glitch& b) { return a.t < b.t; });
  return out;
}

RunSummary simulate(const model::Model& model, const friction::FrictionModel* friction,
                    const Eigen::VectorXd& home, const RunOptions& options, std::uint64_t seed,
                    const RunCallbacks& callbacks) {
  std::string why;
  if (!options.IsValid(&why)) throw Error(why);
  const int n = model.nq;
  const long long substeps = std::max(1LL, std::llround(options.internal_rate_hz / options.rate_hz));
  const double f_int = options.rate_hz * static_cast<double>(substeps);
  const double h = 1.0 / f_int;
  const double duration = options.trajectory.duration;
  const long long total_steps = std::llround(duration * f_int);
  const long long control_every = std::max(1LL, std::llround(f_int / options.controller.rate_hz));

  Trajectory trajectory(options.trajectory, model, home, core::derive_seed(seed, kTrajectoryStream));
  const double begin = trajectory.steady_begin() +
                       std::min(kContactGuard, 0.1 * (trajectory.steady_end() - trajectory.steady_begin()));
  const std::vector<Contact> contacts =
      plan_contacts(options.contacts, model, begin, trajectory.steady_end(), core::derive_seed(seed, kContactPlanStream));

  const std::vector<Glitch> glitches = plan_glitches(options.glitches, n, begin, trajectory.steady_end(), contacts,
                                                     core::derive_seed(seed, kGlitchStream));
  if (static_cast<int>(glitches.size()) < options.glitches.count)
    warn("room for " + std::to_string(glitches.size()) + " of " + std::to_string(options.glitches.count) +
         " glitches " + core::short_number(kGlitchClearance) + " s away from the contacts and each other; lengthen --duration");
  std::size_t next_glitch = 0;

  Plant plant(model, friction, options.integrator);
  Controller controller(model, options.controller);
  Eigen::Array<bool, Eigen::Dynamic, 1> revolute(n);
  for (int j = 0; j < n; ++j) revolute[j] = model.joints[j].type == model::JointType::revolute;
  Sensors sensors(options.sensors, model.k_i, revolute, core::derive_seed(seed, kSensorStream));

  Eigen::VectorXd q_d(n), dq_d(n), ddq_d(n), tau_m = Eigen::VectorXd::Zero(n), generalized(n);
  trajectory.evaluate(0.0, q_d, dq_d, ddq_d);
  plant.reset(q_d, dq_d);

  RunSummary summary;
  summary.duration = duration;
  summary.internal_rate_hz = f_int;
  summary.contacts = static_cast<int>(contacts.size());

  Sample sample;
  sample.tau_f_true.setZero(n);
  sample.tau_c_true.setZero(n);
  const double period = 1.0 / options.rate_hz;
  long long k = 0;
  long long last_scheduled = -1;
  auto schedule = [&](long long index) {
    const double jitter = sensors.next_jitter(period);
    long long s = std::llround(static_cast<double>(index * substeps) + jitter * f_int);
    s = std::max(std::min(s, total_steps), last_scheduled + 1);
    last_scheduled = s;
    return s;
  };
  long long sample_step = schedule(0);
  if (callbacks.start) callbacks.start();

  std::size_t next_contact = 0;
  std::optional<ActiveContact> active;
  std::optional<ContactTruth> truth;
  // The time from a contact's end until its deflection has died away: ten time constants of
  // the position loop's slowest mode of its PD part (e^-10 with the polynomial factor of a
  // double pole: under 1e-3 of the deflection), and one integral time for the integrator's
  // windup, which unloads over about Ti (ControllerOptions::integral_time).
  const double recovery = controller_recovery_time(options.controller);
  double recovered_at = -INFINITY;
  auto finish_contact = [&] {
    recovered_at = active->contact().t_end + recovery;
    truth->force = active->peak_force_vector();
    truth->peak_force = active->peak_force();
    truth->peak_torque = active->peak_torque();
    if (callbacks.contact) callbacks.contact(*truth);
    active.reset();
    truth.reset();
  };

  for (long long step = 0;; ++step) {
    const double t = static_cast<double>(step) / f_int;
    if (step % control_every == 0) {
      trajectory.evaluate(t, q_d, dq_d, ddq_d);
      controller.compute(plant.q(), plant.dq(), q_d, dq_d, ddq_d, tau_m);
      // A contact pushes the arm off its trajectory, and the loop takes a while to bring it
      // back: that deflection is the contact's doing, not the controller's, and is kept apart.
      const double error = (q_d - plant.q()).cwiseAbs().maxCoeff();
      if (active || t < recovered_at) {
        summary.max_contact_deflection = std::max(summary.max_contact_deflection, error);
      } else {
        summary.max_tracking_error = std::max(summary.max_tracking_error, error);
      }
    }
    if (active && t >= active->contact().t_end) finish_contact();
    if (!active && next_contact < contacts.size() && t + h > contacts[next_contact].t_onset) {
      const Contact& c = contacts[next_contact++];
      std::optional<Eigen::Vector3d> heading;
      if (c.clamp) {
        // Where the trajectory takes the point by the end of the hold (a copy, so that a ptp
        // trajectory still advances in order).
        Trajectory ahead = trajectory;
        VectorXd q_goal(n), dq_goal(n), ddq_goal(n);
        ahead.evaluate(c.t_hold_end, q_goal, dq_goal, ddq_goal);
        heading = model::point_position(model, plant.data(), q_goal, c.link - 1, c.point);
      }
      active.emplace(c, model, plant.data(), plant.q(), plant.dq(), options.contacts,
                     heading ? &*heading : nullptr);
      truth.emplace();
      truth->contact = c;
      truth->point_world = model::point_position(model, plant.data(), plant.q(), c.link - 1, c.point);
    }
    if (step == sample_step) {
      sample.t = t;
      sample.tau_f_true = plant.friction_torque();
      generalized.setZero();
      if (active) active->add_joint_torque(t, plant.q(), plant.dq(), generalized, false);
      sample.tau_c_true.setZero();
      sample.tau_c_true -= generalized;  // -J^T F, and +0 rather than -0 without contact
      sensors.measure(t, plant.q(), plant.dq(), tau_m, sample.q, sample.dq, sample.i);
      if (sensors.next_dropped()) {
        ++summary.dropped;
      } else {
        const bool glitched = next_glitch < glitches.size() && t >= glitches[next_glitch].t;
        if (glitched) apply_glitch(glitches[next_glitch], options.glitches, plant.dq(), sample.q, sample.dq, sample.i);
        ++summary.samples;
        if (callbacks.sample) callbacks.sample(sample);
        if (glitched) {
          ++summary.glitches;
          if (callbacks.glitch) callbacks.glitch(t, glitches[next_glitch]);
          ++next_glitch;
        }
      }
      ++k;
      sample_step = k * substeps <= total_steps ? schedule(k) : -1;
    }
    if (step >= total_steps) break;
    plant.step(t, h, tau_m, active ? &*active : nullptr);
    ++summary.steps;
    if ((step & 1023) == 0) {
      if (!plant.q().allFinite() || !plant.dq().allFinite())
        throw Error("the simulation diverged at t = " + core::short_number(t) +
                    " s; raise --internal-rate or use --integrator rk4");
      if ((step & 16383) == 0 && callbacks.progress) callbacks.progress(t);
    }
  }
  if (active) finish_contact();
  return summary;
}

std::vector<std::string> sample_columns(int nq, bool with_truth) {
  std::vector<std::string> columns{"t"};
  for (const char* prefix : {"q", "dq", "i"})
    for (int j = 1; j <= nq; ++j) columns.push_back(prefix + std::to_string(j));
  if (with_truth)
    for (const char* prefix : {"tau_f_true", "tau_c_true"})
      for (int j = 1; j <= nq; ++j) columns.push_back(prefix + std::to_string(j));
  return columns;
}

void sample_row(const Sample& s, bool with_truth, std::vector<double>& row) {
  const auto n = s.q.size();
  row.resize(static_cast<std::size_t>(1 + n * (with_truth ? 5 : 3)));
  double* out = row.data();
  *out++ = s.t;
  for (const Eigen::VectorXd* v : {&s.q, &s.dq, &s.i})
    for (Eigen::Index j = 0; j < n; ++j) *out++ = (*v)[j];
  if (with_truth)
    for (const Eigen::VectorXd* v : {&s.tau_f_true, &s.tau_c_true})
      for (Eigen::Index j = 0; j < n; ++j) *out++ = (*v)[j];
}

std::vector<std::string> truth_columns(int nq) {
  std::vector<std::string> columns{"t_onset", "t_end", "link", "clamp", "px", "py", "pz", "wx", "wy", "wz",
                                   "fx", "fy", "fz", "f_peak"};
  for (int j = 1; j <= nq; ++j) columns.push_back("tau_peak" + std::to_string(j));
  return columns;
}

void truth_row(const ContactTruth& truth, std::vector<double>& row) {
  const Contact& c = truth.contact;
  row = {c.t_onset,          c.t_end,           static_cast<double>(c.link), c.clamp ? 1.0 : 0.0,
         c.point.x(),        c.point.y(),       c.point.z(),                 truth.point_world.x(),
         truth.point_world.y(), truth.point_world.z(), truth.force.x(),      truth.force.y(),
         truth.force.z(),    truth.peak_force};
  for (Eigen::Index j = 0; j < truth.peak_torque.size(); ++j) row.push_back(truth.peak_torque[j]);
}

}  // namespace momentum::sim
