#include "momentum/model/log_check.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <stdexcept>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/model/dynamics.hpp"
#include "momentum/stream/columns.hpp"

namespace momentum::model {

namespace {

using core::significant;
constexpr double kDegree = std::numbers::pi / 180;

// One row kept for the fits.
struct Record {
  Eigen::VectorXd q, dq, ddq, tau;  // tau: the torque column as read (a current: unscaled)
  bool rest = false;
};

// Least squares y = X b; the first coefficient's scale fit. `spread`: the spread of the
// predicted torque the scale multiplies, for the model's error.
ScaleFit fit_scale(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, double model_error, double spread) {
  ScaleFit fit;
  fit.rows = static_cast<std::size_t>(X.rows());
  fit.spread = spread;
  fit.model_error = model_error;
  const Eigen::Index p = X.cols();
  fit.uncertainty = std::numeric_limits<double>::infinity();
  if (X.rows() <= p + 2) return fit;
  const Eigen::MatrixXd normal = X.transpose() * X;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(normal);
  if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-12)) return fit;
  const Eigen::VectorXd b = ldlt.solve(X.transpose() * y);
  const Eigen::VectorXd residual = y - X * b;
  const double rss = residual.squaredNorm();
  const double centred = (y.array() - y.mean()).square().sum();
  fit.scale = b[0];
  fit.unexplained = centred > 0 ? std::min(1.0, rss / centred) : 1.0;
  const Eigen::VectorXd unit = Eigen::VectorXd::Unit(p, 0);
  // The residuals of a model that is not exact are correlated from row to row: the rows count
  // as fewer independent ones, m (1 - rho) / (1 + rho) with rho their lag-one correlation.
  double lag = 0;
  for (Eigen::Index k = 1; k < residual.size(); ++k) lag += residual[k] * residual[k - 1];
  const double rho = rss > 0 ? std::clamp(lag / rss, 0.0, 0.999) : 0.0;
  const double inflation = (1 + rho) / (1 - rho);
  const double variance = inflation * rss / static_cast<double>(X.rows() - p) * ldlt.solve(unit)[0];
  const double relative_model = spread > 0 ? model_error / spread : std::numeric_limits<double>::infinity();
  fit.uncertainty = std::sqrt(std::max(0.0, variance) + relative_model * relative_model);
  if (!std::isfinite(fit.scale)) fit.uncertainty = std::numeric_limits<double>::infinity();
  return fit;
}

double spread_of(const Eigen::VectorXd& x, bool about_mean) {
  if (x.size() == 0) return 0;
  const double centre = about_mean ? x.mean() : 0.0;
  return std::sqrt((x.array() - centre).square().mean());
}

struct Fits {
  std::vector<ScaleFit> gravity, torque;
  double unexplained = 0;  // sum over joints of the torque fits'
  // With the profile's constants taken at their word (scale 1, the friction terms fitted):
  // the mean square residual over the model's error squared, summed over the joints. What
  // tells the joints' orders apart, at rest (gravity) as in motion.
  double misfit = 0;
  // The same with every scale free (a sign, a unit or a constant of its own per joint).
  double free_misfit = 0;
};

// The residual sum of squares of y - X.col(0) on the friction columns of X (1, 2: viscous and
// Coulomb; not the offset, which at a pose held still would absorb gravity itself).
double fixed_scale_rss(const Eigen::MatrixXd& X, const Eigen::VectorXd& y) {
  const Eigen::MatrixXd others = X.middleCols(1, 2);
  const Eigen::VectorXd target = y - X.col(0);
  const Eigen::VectorXd b = others.colPivHouseholderQr().solve(target);
  return (target - others * b).squaredNorm();
}

// The fits with chain joint j taking the stream's joint order[j], its torque column times
// the chain joint's torque_scale[j] (its k_i for a current: the constant belongs to the drive).
Fits fit_all(const Model& model, const std::vector<Record>& records, const std::vector<int>& order,
             const std::vector<double>& torque_scale, const std::vector<double>& model_error, double rest_speed) {
  const int n = model.nq;
  Data data(model);
  Eigen::VectorXd q(n), dq(n), ddq(n), tau_id(n), g(n);
  const auto m = static_cast<Eigen::Index>(records.size());
  std::size_t resting = 0;
  for (const auto& r : records) resting += r.rest;
  std::vector<Eigen::MatrixXd> X(static_cast<std::size_t>(n), Eigen::MatrixXd(m, 4));
  std::vector<Eigen::VectorXd> y(static_cast<std::size_t>(n), Eigen::VectorXd(m));
  std::vector<Eigen::VectorXd> gx(static_cast<std::size_t>(n), Eigen::VectorXd(static_cast<Eigen::Index>(resting)));
  std::vector<Eigen::VectorXd> gy(static_cast<std::size_t>(n), Eigen::VectorXd(static_cast<Eigen::Index>(resting)));
  Eigen::Index k = 0, rk = 0;
  for (const auto& r : records) {
    for (int j = 0; j < n; ++j) {
      q[j] = r.q[order[j]];
      dq[j] = r.dq[order[j]];
      ddq[j] = r.ddq[order[j]];
    }
    inverse_dynamics(model, data, q, dq, ddq, tau_id);
    if (r.rest) gravity_torque(model, data, q, g);
    for (int j = 0; j < n; ++j) {
      const auto J = static_cast<std::size_t>(j);
      const double v = dq[j];
      // Friction, unknown: viscous, Coulomb (a sign softened over the resting speeds), offset.
      X[J](k, 0) = tau_id[j];
      X[J](k, 1) = v;
      X[J](k, 2) = v / std::max(std::abs(v), rest_speed);
      X[J](k, 3) = 1.0;
      y[J][k] = torque_scale[J] * r.tau[order[j]];
      if (r.rest) {
        gx[J][rk] = g[j];
        gy[J][rk] = torque_scale[J] * r.tau[order[j]];
      }
    }
    ++k;
    rk += r.rest;
  }
  Fits fits;
  for (int j = 0; j < n; ++j) {
    const auto J = static_cast<std::size_t>(j);
    fits.torque.push_back(fit_scale(X[J], y[J], model_error[J], spread_of(X[J].col(0), true)));
    fits.unexplained += fits.torque.back().unexplained;
    if (m > 0) {
      const double error2 = std::max(model_error[J] * model_error[J], 1e-12) * static_cast<double>(m);
      fits.misfit += fixed_scale_rss(X[J], y[J]) / error2;
      const Eigen::MatrixXd friction_and_scale = X[J].leftCols(3);
      const Eigen::VectorXd b = friction_and_scale.colPivHouseholderQr().solve(y[J]);
      fits.free_misfit += (y[J] - friction_and_scale * b).squaredNorm() / error2;
    }
    fits.gravity.push_back(fit_scale(gx[J], gy[J], model_error[J], spread_of(gx[J], false)));
  }
  return fits;
}

bool near(double value, double target, double tolerance) {
  return std::abs(value / target - 1) <= tolerance;
}

// What a torque scale means, and what to change.
std::string scale_advice(const ScaleFit& fit, int joint, bool from_current, double k_i) {
  const std::string j = std::to_string(joint);
  const std::string constant = from_current ? "the torque constant k_i of joint " + j : "the sign or unit of tau_m" + j;
  const double a = fit.scale;
  if (a < 0 && near(-a, 1, 0.5))
    return from_current ? "the torque constant's sign is flipped: set k_i of joint " + j + " to " + significant(-k_i, 6)
                        : "tau_m" + j + " has the opposite sign: negate the column";
  if (near(std::abs(a), 1000, 0.5))
    return from_current ? "the current is in mA or k_i in Nm/mA: convert i" + j + " to A (x 0.001) or set k_i to " +
                              significant(a * k_i, 6)
                        : "tau_m" + j + " is in Nm x 1000 (mNm?): convert it to Nm";
  if (near(std::abs(a), 0.001, 0.5))
    return from_current ? "k_i of joint " + j + " is 1000 times too large (Nm/mA given as Nm/A?): set it to " +
                              significant(a * k_i, 6)
                        : "tau_m" + j + " is 1000 times too small: check its unit";
  return from_current ? constant + " is off by that factor: set it to " + significant(a * k_i, 6) + " Nm/A" +
                            (a < 0 ? " (negative: the sign too)" : "")
                      : constant + " is off by that factor";
}

std::string order_text(const std::vector<int>& order) {
  std::string s;
  for (std::size_t j = 0; j < order.size(); ++j) s += (j ? "," : "") + std::to_string(order[j] + 1);
  return s;
}

}  // namespace

bool LogCheckOptions::IsValid(std::string* why) const {
  if (max_samples < 50) return invalid(why, "max_samples must be >= 50");
  if (!(rest_speed > 0 && std::isfinite(rest_speed))) return invalid(why, "rest_speed must be > 0");
  if (!(model_error_share >= 0 && std::isfinite(model_error_share))) return invalid(why, "model_error_share must be >= 0");
  if (!(model_error_torque >= 0 && std::isfinite(model_error_torque))) return invalid(why, "model_error_torque must be >= 0");
  if (max_permuted_joints < 0 || max_permuted_joints > 8) return invalid(why, "max_permuted_joints must be 0 to 8");
  return true;
}

bool ScaleFit::implausible() const {
  if (!determined()) return false;
  const double margin = 3 * uncertainty;
  return scale < 0.5 - margin || scale > 2 + margin;
}

LogCheckSummary check_log(stream::Reader& in, const Model& model, const LogCheckOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  const int n = model.nq;
  LogCheckSummary summary;
  // Joint columns numbered from 1, or from 0 (a finding, then read as joints 1..n).
  const int base = in.find("q0") && !in.find("q" + std::to_string(n)) ? 0 : 1;
  summary.first_joint_column = base;
  const std::size_t t_index = in.require("t");
  std::vector<std::size_t> qi(n), dqi(n), taui(n);
  std::vector<double> scale(n, 1.0);
  std::vector<bool> from_current(n, false);
  for (int j = 0; j < n; ++j) {
    const std::string k = std::to_string(j + base);
    qi[j] = in.require("q" + k);
    dqi[j] = in.require("dq" + k);
    if (auto tau = in.find("tau_m" + k)) {
      taui[j] = *tau;
    } else if (auto current = in.find("i" + k)) {
      taui[j] = *current;
      scale[j] = model.k_i.size() == n ? model.k_i[j] : 1.0;
      from_current[j] = true;
    } else {
      throw Error(located(in.name(), 0, "missing column 'tau_m" + k + "' (or 'i" + k + "' with the profile's k_i)"));
    }
  }
  if (base == 0) {
    const std::string last = std::to_string(n - 1);
    summary.findings.push_back(
        {"columns", 0,
         "the joint columns are numbered from 0 (q0..q" + last + ", dq0..dq" + last +
             "): the suite numbers joints from 1, base to tip; read the log with --rename " +
             stream::zero_based_joint_rename(in.columns()) + " (read here as joints 1.." + std::to_string(n) + ")"});
  }

  // The velocity check on every row; the rows for the fits decimated to max_samples.
  std::vector<double> integrated_product(n, 0.0), integrated_square(n, 0.0), moved(n, 0.0), largest(n, 0.0),
      strongest(n, 0.0);
  std::vector<Record> records;
  std::size_t stride = 1, candidate = 0;
  Record previous2, previous;
  double t_previous2 = 0, t_previous = 0;
  auto make = [&](const double* row, Record& r) {
    r.q.resize(n);
    r.dq.resize(n);
    r.tau.resize(n);
    r.rest = true;
    for (int j = 0; j < n; ++j) {
      r.q[j] = row[qi[j]];
      r.dq[j] = row[dqi[j]];
      r.tau[j] = row[taui[j]];
      r.rest = r.rest && std::abs(r.dq[j]) < options.rest_speed;
    }
  };
  Record current;
  while (const double* row = in.next()) {
    const double t = row[t_index];
    make(row, current);
    const bool finite = std::isfinite(t) && current.q.allFinite() && current.dq.allFinite() && current.tau.allFinite();
    if (!finite) continue;
    if (summary.rows > 0 && !(t > t_previous)) continue;
    for (int j = 0; j < n; ++j) {
      largest[j] = std::max(largest[j], std::abs(current.q[j]));
      strongest[j] = std::max(strongest[j], std::abs(scale[j] * current.tau[j]));
    }
    if (summary.rows >= 1) {
      const double dt = t - t_previous;
      for (int j = 0; j < n; ++j) {
        if (std::abs(current.dq[j]) < options.rest_speed || std::abs(previous.dq[j]) < options.rest_speed) continue;
        const double integral = 0.5 * dt * (current.dq[j] + previous.dq[j]);
        integrated_product[j] += integral * (current.q[j] - previous.q[j]);
        integrated_square[j] += integral * integral;
        moved[j] += std::abs(integral);
      }
    }
    if (summary.rows >= 2 && candidate++ % stride == 0) {
      Record r = previous;
      r.ddq = (current.dq - previous2.dq) / (t - t_previous2);
      records.push_back(std::move(r));
      if (records.size() >= 2 * options.max_samples) {
        std::vector<Record> kept;
        for (std::size_t k = 0; k < records.size(); k += 2) kept.push_back(std::move(records[k]));
        records = std::move(kept);
        stride *= 2;
      }
    }
    previous2 = std::move(previous);
    t_previous2 = t_previous;
    previous = current;
    t_previous = t;
    ++summary.rows;
    summary.resting_rows += current.rest;
  }
  if (summary.rows < 10) throw Error(located(in.name(), 0, "fewer than 10 rows to check"));

  // Units: velocity against the change of position, positions against the limits.
  bool units_wrong = false;
  summary.velocity_scale.assign(n, std::numeric_limits<double>::quiet_NaN());
  for (int j = 0; j < n; ++j) {
    const std::string name = std::to_string(j + 1);
    const bool revolute = model.joints[j].type == JointType::revolute;
    if (moved[j] > 0.1 && integrated_square[j] > 0) {
      const double s = integrated_product[j] / integrated_square[j];
      summary.velocity_scale[j] = s;
      std::string message;
      if (revolute && near(s, 1 / kDegree, 0.1)) {
        message = "q" + name + " is in degrees against dq" + name + " in rad/s: convert q to rad (x pi/180)";
      } else if (revolute && near(s, kDegree, 0.1)) {
        message = "dq" + name + " is in deg/s against q" + name + " in rad: convert dq to rad/s (x pi/180)";
      } else if (!(std::abs(s - 1) <= 0.2)) {
        message = "dq" + name + " is not the derivative of q" + name + ": check its unit, and that it is this joint's";
      }
      if (!message.empty()) {
        units_wrong = true;
        summary.findings.push_back({"units", j + 1,
                                    "joint " + name + ": the position changes " + significant(s, 3) +
                                        " times what the velocity integrates to: " + message});
      }
    }
    const JointLimits& limits = model.joints[j].limits;
    const double bound = std::max(std::abs(limits.lower), std::abs(limits.upper));
    if (revolute && std::isfinite(bound) && bound > 0 && largest[j] > 1.5 * bound) {
      units_wrong = true;
      const bool degrees = largest[j] * kDegree <= 1.05 * bound;
      summary.findings.push_back(
          {"units", j + 1,
           "joint " + name + ": positions up to " + significant(largest[j], 4) + " beyond the URDF's limits [" +
               significant(limits.lower, 4) + ", " + significant(limits.upper, 4) + "] rad" +
               (degrees ? ": in degrees they would fit: convert q" + name + " and dq" + name + " to rad (x pi/180)"
                        : ": check the joint's unit and zero")});
    }
  }
  // A motor torque ten times the joint's effort limit is no torque the drive made: a unit.
  std::vector<bool> beyond_effort(n, false);
  for (int j = 0; j < n; ++j) {
    const double effort = model.joints[j].limits.effort;
    if (units_wrong || !(std::isfinite(effort) && effort > 0) || !(strongest[j] > 10 * effort)) continue;
    beyond_effort[j] = true;
    const double ratio = strongest[j] / effort;
    const std::string name = std::to_string(j + 1);
    const bool milli = ratio > 100;
    summary.findings.push_back(
        {"torque", j + 1,
         "joint " + name + ": the motor torque reaches " + significant(strongest[j], 4) + " Nm, " +
             significant(ratio, 3) + " times the URDF's effort limit of " + significant(effort, 4) + " Nm: " +
             (from_current[j] ? (milli ? "the current is in mA (convert i" + name + " to A, x 0.001)"
                                       : "k_i or the current's unit is wrong")
                              : (milli ? "tau_m" + name + " is in mNm or a current (convert it to Nm)"
                                       : "tau_m" + name + "'s unit is wrong"))});
  }
  if (records.size() < 20) {
    summary.findings.push_back({"torque", 0, "too few rows to fit the torques (" + std::to_string(records.size()) + ")"});
    return summary;
  }

  std::vector<double> model_error(n);
  for (int j = 0; j < n; ++j) {
    const double effort = model.joints[j].limits.effort;
    model_error[j] = std::isfinite(effort) && effort > 0 ? options.model_error_share * effort : options.model_error_torque;
  }
  std::vector<int> identity(n);
  std::iota(identity.begin(), identity.end(), 0);
  Fits fits = fit_all(model, records, identity, scale, model_error, options.rest_speed);
  std::vector<int> order = identity;
  const bool any_beyond_effort = std::find(beyond_effort.begin(), beyond_effort.end(), true) != beyond_effort.end();
  if (!units_wrong && !any_beyond_effort && n <= options.max_permuted_joints && n > 1) {
    // Every order of the stream's joints, on at most 400 of the rows kept.
    std::vector<Record> few;
    const std::size_t step = std::max<std::size_t>(1, records.size() / 400);
    for (std::size_t k = 0; k < records.size(); k += step) few.push_back(records[k]);
    const double identity_score = fit_all(model, few, identity, scale, model_error, options.rest_speed).misfit;
    std::vector<std::pair<double, std::vector<int>>> scored;
    std::vector<int> candidate_order = identity;
    double best_score = identity_score;
    while (std::next_permutation(candidate_order.begin(), candidate_order.end())) {
      const double misfit = fit_all(model, few, candidate_order, scale, model_error, options.rest_speed).misfit;
      best_score = std::min(best_score, misfit);
      scored.emplace_back(misfit, candidate_order);
    }
    // Of the orders within 20% of the best, the one that moves the fewest joints: a wrist
    // whose torques the model barely predicts should not ride along with a real swap.
    std::vector<int> best = identity;
    int fewest = n + 1;
    for (const auto& [misfit, candidate] : scored) {
      if (misfit > 1.2 * best_score) continue;
      int displaced = 0;
      for (int j = 0; j < n; ++j) displaced += candidate[j] != j;
      if (displaced < fewest) {
        fewest = displaced;
        best = candidate;
        best_score = std::min(best_score, misfit);
      }
    }
    if (best != identity && best_score <= 0.5 * identity_score) {
      const Fits better = fit_all(model, records, best, scale, model_error, options.rest_speed);
      bool plausible = true;
      for (const auto& fit : better.torque) plausible = plausible && !fit.implausible();
      // When a scale of the chain's order is implausible, better than it even with its
      // scales free: a sign or a constant of one joint is no reason to reorder the others.
      bool identity_plausible = true;
      for (std::size_t j = 0; j < fits.torque.size(); ++j)
        identity_plausible = identity_plausible && !fits.torque[j].implausible() && !fits.gravity[j].implausible();
      if (plausible && better.misfit <= 0.5 * fits.misfit &&
          (identity_plausible || better.misfit <= 0.5 * fits.free_misfit)) {
        order = best;
        summary.better_order.assign(best.begin(), best.end());
        for (int& o : summary.better_order) ++o;
        std::string moved_joints;
        for (int j = 0; j < n; ++j)
          if (best[j] != j)
            moved_joints += (moved_joints.empty() ? "" : ", ") + std::to_string(j + 1) + " from the stream's " +
                            std::to_string(best[j] + 1);
        summary.findings.push_back(
            {"order", 0,
             "the stream's joints are not in the chain's order: the order " + order_text(best) +
                 " explains the torques (RMS misfit " + significant(std::sqrt(better.misfit / n), 2) +
                 " times the model's error per joint, against " + significant(std::sqrt(fits.misfit / n), 2) +
                 "): reorder the columns so that chain joint " + moved_joints +
                 " (the joint names of a ROS JointState or a vendor export are often not in chain order)"});
        fits = better;
      }
    }
  }
  summary.gravity = fits.gravity;
  summary.torque = fits.torque;
  if (units_wrong) {
    summary.findings.push_back({"torque", 0, "torques not checked until the units above are right"});
    return summary;
  }
  const std::string in_order = order == identity ? "" : " (in the order found)";
  for (int j = 0; j < n; ++j) {
    const double k_i = model.k_i.size() == n ? model.k_i[j] : 1.0;
    const ScaleFit& g = fits.gravity[static_cast<std::size_t>(j)];
    const ScaleFit& d = fits.torque[static_cast<std::size_t>(j)];
    if (beyond_effort[static_cast<std::size_t>(j)]) continue;  // said above, with its unit
    if (g.implausible()) {
      summary.findings.push_back(
          {"gravity", j + 1,
           "joint " + std::to_string(j + 1) + in_order + ": at rest the motor torque is " + significant(g.scale, 3) +
               " +- " + significant(g.uncertainty, 2) + " times the model's gravity: " +
               scale_advice(g, j + 1, from_current[j], k_i)});
    }
    if (d.implausible()) {
      summary.findings.push_back(
          {"torque", j + 1,
           "joint " + std::to_string(j + 1) + in_order + ": the motor torque is " + significant(d.scale, 3) + " +- " +
               significant(d.uncertainty, 2) + " times the model's inverse dynamics: " +
               scale_advice(d, j + 1, from_current[j], k_i)});
    }
  }
  return summary;
}

std::string describe_log_check(const LogCheckSummary& s) {
  std::string text = "# " + std::to_string(s.rows) + " rows, " + std::to_string(s.resting_rows) + " at rest\n";
  if (!s.better_order.empty()) {
    std::string order;
    for (int o : s.better_order) order += (order.empty() ? "" : ",") + std::to_string(o);
    text += "# the scales below take the stream's joints in the order found: " + order + "\n";
  }
  text += "joint  dq_scale  gravity_scale  +-      torque_scale  +-      unexplained\n";
  auto cell = [](double value, int width) {
    std::string v = std::isfinite(value) ? significant(value, 4) : std::string("-");
    if (static_cast<int>(v.size()) < width) v += std::string(static_cast<std::size_t>(width) - v.size(), ' ');
    return v + " ";
  };
  for (std::size_t j = 0; j < s.velocity_scale.size(); ++j) {
    text += cell(static_cast<double>(j + 1), 6) + cell(s.velocity_scale[j], 9);
    if (j < s.torque.size()) {
      const ScaleFit& g = s.gravity[j];
      const ScaleFit& d = s.torque[j];
      text += cell(g.determined() ? g.scale : NAN, 14) + cell(g.determined() ? g.uncertainty : NAN, 7) +
              cell(d.determined() ? d.scale : NAN, 13) + cell(d.determined() ? d.uncertainty : NAN, 7) +
              cell(d.unexplained, 6);
    }
    while (!text.empty() && text.back() == ' ') text.pop_back();
    text += "\n";
  }
  if (s.findings.empty()) text += "no finding: the profile and the log agree\n";
  for (const auto& f : s.findings) text += f.kind + ": " + f.message + "\n";
  return text;
}

}  // namespace momentum::model
