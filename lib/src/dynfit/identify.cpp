#include "momentum/dynfit/identify.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

#include "momentum/dynfit/regressor.hpp"
#include "momentum/model/inertial_corrections.hpp"
#include "momentum/observer/filter.hpp"
#include "momentum/stream/error.hpp"

namespace momentum::dynfit {

namespace {

constexpr int kMaxBlocks = 64;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool reject(std::string* why, const std::string& text) {
  if (why) *why = text;
  return false;
}

// Pseudo-inverse of a symmetric positive semi-definite matrix (eigenvalues below tol times the
// largest dropped).
Eigen::MatrixXd pseudo_inverse(const Eigen::MatrixXd& a, double tol) {
  if (a.rows() == 0) return a;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(a);
  const Eigen::VectorXd& l = eig.eigenvalues();
  const double top = std::max(l.maxCoeff(), 0.0);
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(l.size());
  for (Eigen::Index i = 0; i < l.size(); ++i) {
    if (top > 0 && l[i] > tol * top) inv[i] = 1.0 / l[i];
  }
  return eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
}

Eigen::MatrixXd symmetric(const Eigen::MatrixXd& lower) {
  Eigen::MatrixXd full = lower.selfadjointView<Eigen::Lower>();
  return full;
}

// The pseudo-inertia J = [[Sigma, h], [h^T, m]], Sigma = tr(I_O)/2 E - I_O, h = m c, of a
// body's standard parameters: the body is physical exactly when J is positive definite
// (Wensing, Kim, Slotine 2017), and the map is linear, so the physical set is convex.
Eigen::Matrix4d pseudo_inertia(const model::StandardParameters& t) {
  Eigen::Matrix3d origin;
  origin << t[4], t[5], t[6], t[5], t[7], t[8], t[6], t[8], t[9];
  Eigen::Matrix4d J;
  J.topLeftCorner<3, 3>() = 0.5 * origin.trace() * Eigen::Matrix3d::Identity() - origin;
  J.topRightCorner<3, 1>() = t.segment<3>(1);
  J.bottomLeftCorner<1, 3>() = t.segment<3>(1).transpose();
  J(3, 3) = t[0];
  return J;
}

model::StandardParameters from_pseudo_inertia(const Eigen::Matrix4d& J) {
  const Eigen::Matrix3d sigma = J.topLeftCorner<3, 3>();
  const Eigen::Matrix3d origin = sigma.trace() * Eigen::Matrix3d::Identity() - sigma;
  model::StandardParameters t;
  t << J(3, 3), J(0, 3), J(1, 3), J(2, 3), origin(0, 0), origin(0, 1), origin(0, 2), origin(1, 1),
      origin(1, 2), origin(2, 2);
  return t;
}

// Nearest (Frobenius norm of J) parameters whose pseudo-inertia has eigenvalues >= floor.
model::StandardParameters project_physical(const model::StandardParameters& t, double floor) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(pseudo_inertia(t));
  const Eigen::Vector4d l = eig.eigenvalues().cwiseMax(floor);
  return from_pseudo_inertia(eig.eigenvectors() * l.asDiagonal() * eig.eigenvectors().transpose());
}

double smallest_pseudo_eigenvalue(const model::StandardParameters& t) {
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(pseudo_inertia(t), Eigen::EigenvaluesOnly)
      .eigenvalues()[0];
}

}  // namespace

bool IdentifyOptions::IsValid(std::string* why) const {
  if (!(filter_gain > 0) || !std::isfinite(filter_gain)) return reject(why, "filter gain must be > 0");
  if (!(coulomb_speed > 0) || !std::isfinite(coulomb_speed))
    return reject(why, "coulomb speed must be > 0");
  if (!(rank_tolerance > 0 && rank_tolerance < 1))
    return reject(why, "rank tolerance must be in (0, 1)");
  if (!(settle_time_constants >= 0) || !std::isfinite(settle_time_constants))
    return reject(why, "settle time must be >= 0");
  if (!(gap_factor > 1) || !std::isfinite(gap_factor)) return reject(why, "gap factor must be > 1");
  if (!(holdout_segment > 0) || !std::isfinite(holdout_segment))
    return reject(why, "held-out segment length must be > 0");
  if (holdout_every != 0 && holdout_every < 2)
    return reject(why, "held-out period must be 0 (none) or >= 2");
  if (!(block > 0) || !std::isfinite(block)) return reject(why, "block length must be > 0");
  if (!(min_speed >= 0) || !std::isfinite(min_speed)) return reject(why, "minimum speed must be >= 0");
  if (!(slow_settle_time_constants >= 0) || !std::isfinite(slow_settle_time_constants))
    return reject(why, "settle time after slow motion must be >= 0");
  return true;
}

Identifier::Identifier(const model::Model& nominal, const IdentifyOptions& options)
    : model_(nominal), options_(options), data_(nominal), n_(nominal.nq) {
  std::string why;
  if (!options_.IsValid(&why)) throw Error("dynfit: " + why);
  for (int k = 0; k < n_; ++k) {
    const int count = options_.gravity_only ? 4 : kBodyParameters;
    for (int j = 0; j < count; ++j) selected_.push_back(body_offset(k) + j);
  }
  fitted_ = static_cast<int>(selected_.size());
  columns_ = fitted_ + (options_.fit_friction ? 2 * n_ : 0);
  theta_nominal_ = model_parameters(nominal);
  const int p = kBodyParameters * n_;
  for (auto* m : {&Yp_, &Yb_, &Fp_, &Fb_, &Yp_prev_, &Yb_prev_}) m->setZero(n_, p);
  for (auto* m : {&friction_, &friction_prev_, &Ff_}) m->setZero(n_, 2);
  for (auto* v : {&y_, &y_prev_, &Fy_, &pk_, &pk_prev_, &Fpk_}) v->setZero(n_);
  JointStats empty;
  empty.G.setZero(columns_, columns_);
  empty.c.setZero(columns_);
  fit_joint_.assign(static_cast<std::size_t>(n_), empty);
  held_joint_.assign(static_cast<std::size_t>(n_), empty);
  block_length_ = options_.block;
  slow_until_.assign(static_cast<std::size_t>(n_), -std::numeric_limits<double>::infinity());
}

void Identifier::restart() {
  // A new log starts a new held-out segment period.
  t_log_ = options_.holdout_segment * std::ceil(t_log_ / options_.holdout_segment + 1e-9);
  started_ = false;
  have_time_ = false;
}

std::uint64_t Identifier::samples_fit() const {
  std::uint64_t total = 0;
  for (const auto& j : fit_joint_) total += j.count;
  return n_ ? total / static_cast<std::uint64_t>(n_) : 0;
}

std::uint64_t Identifier::samples_held_out() const {
  std::uint64_t total = 0;
  for (const auto& j : held_joint_) total += j.count;
  return n_ ? total / static_cast<std::uint64_t>(n_) : 0;
}

void Identifier::begin_block() {
  if (static_cast<int>(blocks_.size()) == kMaxBlocks) {
    std::vector<Block> merged;
    for (std::size_t i = 0; i + 1 < blocks_.size(); i += 2) {
      merged.push_back({blocks_[i].A + blocks_[i + 1].A, blocks_[i].b + blocks_[i + 1].b});
    }
    blocks_ = std::move(merged);
    block_length_ *= 2;
  }
  blocks_.push_back({Eigen::MatrixXd::Zero(columns_, columns_), Eigen::VectorXd::Zero(columns_)});
  block_start_ = t_log_;
}

void Identifier::accumulate(const Eigen::MatrixXd& Z, const Eigen::VectorXd& e, bool held_out) {
  auto& joints = held_out ? held_joint_ : fit_joint_;
  for (int i = 0; i < n_; ++i) {
    if (Z.row(i).isZero(0.0) && e[i] == 0.0) continue;  // a row that does not count
    JointStats& s = joints[static_cast<std::size_t>(i)];
    s.G.selfadjointView<Eigen::Lower>().rankUpdate(Z.row(i).transpose());
    s.c.noalias() += Z.row(i).transpose() * e[i];
    s.s += e[i] * e[i];
    ++s.count;
  }
  if (held_out) return;
  if (blocks_.empty() || t_log_ - block_start_ >= block_length_) begin_block();
  Block& block = blocks_.back();
  block.A.selfadjointView<Eigen::Lower>().rankUpdate(Z.transpose());
  block.b.noalias() += Z.transpose() * e;
}

void Identifier::add(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq,
                     const Eigen::VectorXd& tau_m) {
  if (q.size() != n_ || dq.size() != n_ || tau_m.size() != n_) {
    throw Error("dynfit: a sample has the wrong number of joints");
  }
  if (!std::isfinite(t) || !q.allFinite() || !dq.allFinite() || !tau_m.allFinite()) {
    ++skipped_;
    started_ = false;
    return;
  }
  double dt = 0;
  if (have_time_) {
    dt = t - t_previous_;
    if (!(dt > 0)) {
      ++skipped_;
      started_ = false;
      return;
    }
    t_log_ += dt;  // time goes on through gaps and bad rows: held-out segments stay aligned
    t_previous_ = t;
    if (started_ && typical_dt_ > 0 && dt > options_.gap_factor * typical_dt_) {
      started_ = false;  // a gap: start again from this sample
    } else if (started_) {
      typical_dt_ = typical_dt_ > 0 ? 0.95 * typical_dt_ + 0.05 * std::min(dt, 2 * typical_dt_) : dt;
    }
  }
  have_time_ = true;
  t_previous_ = t;
  momentum_regressor(model_, data_, q, dq, Yp_, Yb_);
  for (int j = 0; j < n_; ++j) {
    friction_(j, 0) = std::tanh(dq[j] / options_.coulomb_speed);
    friction_(j, 1) = dq[j];
  }
  y_ = tau_m;
  pk_ = model_.rotor_inertia.cwiseProduct(dq);
  if (!started_) {
    Fp_ = Yp_;
    Fb_ = Yb_;
    Ff_ = friction_;
    Fy_ = y_;
    Fpk_ = pk_;
    Yp_prev_ = Yp_;
    Yb_prev_ = Yb_;
    friction_prev_ = friction_;
    y_prev_ = y_;
    pk_prev_ = pk_;
    started_ = true;
    t_start_ = t;
    typical_dt_ = 0;
    ++restarts_;
    return;
  }
  const observer::FilterCoefficients c =
      observer::discretize(observer::Gains{options_.filter_gain, 0.0, 0.0}, dt);
  auto advance = [&](auto& state, auto& previous, const auto& current) {
    state = c.a1 * state + c.b10 * previous + c.b11 * current;
    previous = current;
  };
  advance(Fp_, Yp_prev_, Yp_);
  advance(Fb_, Yb_prev_, Yb_);
  advance(Ff_, friction_prev_, friction_);
  if (options_.torque_held) {
    // The drive applied the torque reported at the start of the interval until its end.
    Fy_ = c.a1 * Fy_ + (c.b10 + c.b11) * y_prev_;
    y_prev_ = y_;
  } else {
    advance(Fy_, y_prev_, y_);
  }
  advance(Fpk_, pk_prev_, pk_);
  const double settle = options_.settle_time_constants / options_.filter_gain;
  for (int j = 0; j < n_; ++j) {
    if (std::abs(dq[j]) < options_.min_speed) {
      slow_until_[static_cast<std::size_t>(j)] = t + options_.slow_settle_time_constants / options_.filter_gain;
    }
  }
  if (t - t_start_ < settle) return;

  const double k = options_.filter_gain;
  const double g = c.gain;
  const Eigen::MatrixXd W = k * (Yp_ - g * Fp_) + g * Fb_;
  const Eigen::VectorXd y = g * Fy_ - k * (pk_ - g * Fpk_);
  Eigen::VectorXd e = y - W * theta_nominal_;
  Eigen::MatrixXd Z = Eigen::MatrixXd::Zero(n_, columns_);
  for (int j = 0; j < fitted_; ++j) Z.col(j) = W.col(selected_[static_cast<std::size_t>(j)]);
  if (options_.fit_friction) {
    for (int i = 0; i < n_; ++i) {
      Z(i, fitted_ + 2 * i) = g * Ff_(i, 0);
      Z(i, fitted_ + 2 * i + 1) = g * Ff_(i, 1);
    }
  }
  // Rows of joints that were slow within the filter's memory do not count (friction there is
  // presliding and Stribeck, which the Coulomb + viscous model cannot follow).
  bool any = false;
  for (int i = 0; i < n_; ++i) {
    if (t < slow_until_[static_cast<std::size_t>(i)]) {
      Z.row(i).setZero();
      e[i] = 0.0;
    } else {
      any = true;
    }
  }
  if (!any) return;
  bool held_out = false;
  if (options_.holdout_every > 0) {
    const auto segment = static_cast<long long>(std::floor(t_log_ / options_.holdout_segment));
    held_out = segment % options_.holdout_every == options_.holdout_every - 1;
  }
  accumulate(Z, e, held_out);
  (held_out ? seconds_held_ : seconds_fit_) += dt;
}

IdentifySummary Identifier::solve(const Eigen::VectorXd* current) const {
  const int n = n_, pi = fitted_, pf = columns_ - fitted_, p = kBodyParameters * n;
  if (samples_fit() == 0) {
    throw Error("dynfit: no sample to fit (the logs are shorter than the filter's settling time "
                "or every sample was held out)");
  }
  IdentifySummary s;
  s.nq = n;
  s.gravity_only = options_.gravity_only;
  s.fit_friction = options_.fit_friction;
  s.nominal = theta_nominal_;
  s.columns = pi;
  s.samples_fit = samples_fit();
  s.samples_held_out = samples_held_out();
  s.samples_skipped = skipped_;
  s.seconds_fit = seconds_fit_;
  s.seconds_held_out = seconds_held_;
  s.restarts = restarts_;
  s.blocks = static_cast<int>(blocks_.size());

  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(columns_, columns_);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(columns_);
  std::vector<Eigen::MatrixXd> block_A;
  for (const Block& block : blocks_) {
    block_A.push_back(symmetric(block.A));
    A += block_A.back();
    b += block.b;
  }
  const Eigen::MatrixXd Aii = A.topLeftCorner(pi, pi);
  const Eigen::MatrixXd Aif = A.topRightCorner(pi, pf);
  const Eigen::MatrixXd Aff = A.bottomRightCorner(pf, pf);
  const Eigen::MatrixXd Aff_inv = pseudo_inverse(Aff, 1e-12);
  const Eigen::MatrixXd schur = Aii - Aif * Aff_inv * Aif.transpose();

  // Column scaling and the identifiable combinations.
  Eigen::VectorXd scale(pi);
  const double largest = schur.diagonal().cwiseMax(0.0).maxCoeff();
  for (int j = 0; j < pi; ++j) {
    const double d = schur(j, j);
    scale[j] = d > 1e-20 * largest && d > 0 ? std::sqrt(d) : 1.0;
  }
  const Eigen::MatrixXd scaled = scale.cwiseInverse().asDiagonal() * schur * scale.cwiseInverse().asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled);
  const Eigen::VectorXd lambda = eig.eigenvalues().cwiseMax(0.0);
  const double top = lambda.size() ? lambda.maxCoeff() : 0.0;
  std::vector<int> kept;
  for (int r = pi - 1; r >= 0; --r) {
    if (top > 0 && std::sqrt(lambda[r] / top) > options_.rank_tolerance) kept.push_back(r);
  }
  s.rank = static_cast<int>(kept.size());
  s.smallest_singular_value = top > 0 && pi > 0 ? std::sqrt(lambda[0] / top) : 0.0;
  s.condition_number = kept.empty() ? kNaN : std::sqrt(top / lambda[kept.back()]);
  Eigen::MatrixXd V(pi, s.rank);
  Eigen::VectorXd inv_lambda(s.rank);
  for (int r = 0; r < s.rank; ++r) {
    V.col(r) = eig.eigenvectors().col(kept[static_cast<std::size_t>(r)]);
    inv_lambda[r] = 1.0 / lambda[kept[static_cast<std::size_t>(r)]];
  }
  const Eigen::MatrixXd H_inv = V * inv_lambda.asDiagonal() * V.transpose();
  // The estimator is linear in the right-hand side: delta = L_i b_i + L_f b_f.
  const Eigen::MatrixXd Si = scale.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd solve_i = Si * H_inv * Si;  // maps the Schur right-hand side to delta
  auto estimate = [&](const Eigen::VectorXd& rhs, Eigen::VectorXd& delta, Eigen::VectorXd& fric) {
    const Eigen::VectorXd bi = rhs.head(pi), bf = rhs.tail(pf);
    delta = solve_i * (bi - Aif * (Aff_inv * bf));
    fric = Aff_inv * (bf - Aif.transpose() * delta);
  };
  Eigen::VectorXd delta_sel, fric;
  estimate(b, delta_sel, fric);

  // Cluster-robust covariance: each block's score at the solution, mapped through the
  // (linear) estimator.
  Eigen::VectorXd x(columns_);
  x << delta_sel, fric;
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(columns_, columns_);
  const int nb = static_cast<int>(blocks_.size());
  for (int k = 0; k < nb; ++k) {
    const Eigen::VectorXd score = blocks_[static_cast<std::size_t>(k)].b - block_A[static_cast<std::size_t>(k)] * x;
    Eigen::VectorXd dd, df;
    estimate(score, dd, df);
    Eigen::VectorXd dx(columns_);
    dx << dd, df;
    cov.noalias() += dx * dx.transpose();
  }
  if (nb >= 2) cov *= static_cast<double>(nb) / (nb - 1);
  else cov.setConstant(kNaN);

  s.delta_unprojected = Eigen::VectorXd::Zero(p);
  s.covariance = Eigen::MatrixXd::Zero(p, p);
  for (int j = 0; j < pi; ++j) {
    s.delta_unprojected[selected_[static_cast<std::size_t>(j)]] = delta_sel[j];
    for (int l = 0; l < pi; ++l) {
      s.covariance(selected_[static_cast<std::size_t>(j)], selected_[static_cast<std::size_t>(l)]) = cov(j, l);
    }
  }
  s.coulomb = s.viscous = s.coulomb_se = s.viscous_se = Eigen::VectorXd::Zero(n);
  if (options_.fit_friction) {
    for (int i = 0; i < n; ++i) {
      s.coulomb[i] = fric[2 * i];
      s.viscous[i] = fric[2 * i + 1];
      s.coulomb_se[i] = std::sqrt(cov(pi + 2 * i, pi + 2 * i));
      s.viscous_se[i] = std::sqrt(cov(pi + 2 * i + 1, pi + 2 * i + 1));
    }
  }

  // Base parameters: beta_r = v_r . (scale .* delta), normalised to a largest coefficient 1.
  for (int r = 0; r < s.rank; ++r) {
    BaseParameter base;
    Eigen::VectorXd dir_sel = scale.cwiseProduct(V.col(r));
    Eigen::Index at = 0;
    const double big = dir_sel.cwiseAbs().maxCoeff(&at);
    dir_sel /= (dir_sel[at] < 0 ? -big : big);
    base.direction = Eigen::VectorXd::Zero(p);
    for (int j = 0; j < pi; ++j) base.direction[selected_[static_cast<std::size_t>(j)]] = dir_sel[j];
    base.nominal = base.direction.dot(theta_nominal_);
    base.value = base.direction.dot(theta_nominal_ + s.delta_unprojected);
    base.standard_error = std::sqrt(std::max(0.0, base.direction.dot(s.covariance * base.direction)));
    if (nb < 2) base.standard_error = kNaN;
    base.singular_value = std::sqrt(lambda[kept[static_cast<std::size_t>(r)]] / top);
    s.base.push_back(base);
  }

  // Gravity only: the inertias about the centres of mass stay nominal (the fit moved the
  // masses and centres of mass, so the inertias about the body origins follow).
  s.delta = s.delta_unprojected;
  if (options_.gravity_only) {
    for (int k = 0; k < n; ++k) {
      const model::StandardParameters nominal = theta_nominal_.segment<kBodyParameters>(body_offset(k));
      model::StandardParameters theta = nominal + s.delta.segment<kBodyParameters>(body_offset(k));
      model::Body body = model_.bodies[static_cast<std::size_t>(k)];
      if (theta[0] > 0) {
        body.mass = theta[0];
        body.com = theta.segment<3>(1) / theta[0];
        s.delta.segment<kBodyParameters>(body_offset(k)) = model::standard_parameters(body) - nominal;
      }
    }
  }
  // Physical consistency: where the minimum-norm correction is not physical, move along the
  // directions the data do not determine. Alternating projections between the affine set of
  // corrections with the identified combinations and the convex set of physical bodies
  // (pseudo-inertia positive definite, with a margin of 1e-3 of the nominal's smallest
  // eigenvalue); both contain the truth when the model is right.
  auto physical = [&](const Eigen::VectorXd& delta, std::vector<int>* bad) {
    bool ok = true;
    for (int k = 0; k < n; ++k) {
      const model::StandardParameters theta =
          (theta_nominal_ + delta).segment<kBodyParameters>(body_offset(k));
      model::Body probe;
      if (!model::set_standard_parameters(probe, theta, nullptr)) {
        ok = false;
        if (bad) bad->push_back(k);
      }
    }
    return ok;
  };
  std::vector<int> unphysical;
  if (!physical(s.delta, &unphysical)) {
    Eigen::VectorXd floors(n);
    for (int k = 0; k < n; ++k) {
      floors[k] = 1e-3 * smallest_pseudo_eigenvalue(theta_nominal_.segment<kBodyParameters>(body_offset(k)));
    }
    Eigen::VectorXd target_sel(pi);  // identified combinations in scaled coordinates
    const Eigen::VectorXd scaled_delta = scale.cwiseProduct(delta_sel);
    target_sel = V.transpose() * scaled_delta;
    Eigen::VectorXd d = s.delta;
    int iterations = 0;
    for (; iterations < 20000; ++iterations) {
      for (int k = 0; k < n; ++k) {
        const model::StandardParameters nominal = theta_nominal_.segment<kBodyParameters>(body_offset(k));
        const model::StandardParameters theta = nominal + d.segment<kBodyParameters>(body_offset(k));
        d.segment<kBodyParameters>(body_offset(k)) = project_physical(theta, floors[k]) - nominal;
      }
      Eigen::VectorXd ds(pi);
      for (int j = 0; j < pi; ++j) ds[j] = scale[j] * d[selected_[static_cast<std::size_t>(j)]];
      const Eigen::VectorXd miss = target_sel.head(s.rank) - V.transpose() * ds;
      const bool kept_all = miss.norm() <= 1e-9 * (1.0 + target_sel.norm());
      if (kept_all && physical(d, nullptr)) break;
      ds += V * miss;
      for (int j = 0; j < pi; ++j) d[selected_[static_cast<std::size_t>(j)]] = ds[j] / scale[j];
    }
    std::string names;
    for (int k : unphysical) names += (names.empty() ? "" : ", ") + model_.bodies[static_cast<std::size_t>(k)].name;
    if (!physical(d, nullptr)) {
      // No physical point keeps every identified combination (the data or the model are
      // inconsistent with a rigid body): of the nearest physical points to where the iteration
      // ended and to the minimum-norm correction, take the one that fits the data better.
      auto project_all = [&](Eigen::VectorXd delta) {
        for (int k = 0; k < n; ++k) {
          const model::StandardParameters nominal = theta_nominal_.segment<kBodyParameters>(body_offset(k));
          delta.segment<kBodyParameters>(body_offset(k)) =
              project_physical(nominal + delta.segment<kBodyParameters>(body_offset(k)), floors[k]) - nominal;
        }
        return delta;
      };
      auto cost = [&](const Eigen::VectorXd& delta) {
        Eigen::VectorXd xs(columns_);
        Eigen::VectorXd dsel(pi);
        for (int j = 0; j < pi; ++j) dsel[j] = delta[selected_[static_cast<std::size_t>(j)]];
        xs << dsel, Aff_inv * (b.tail(pf) - Aif.transpose() * dsel);
        return xs.dot(A * xs) - 2 * b.dot(xs);
      };
      const Eigen::VectorXd from_iteration = project_all(d);
      const Eigen::VectorXd from_minimum_norm = project_all(s.delta);
      d = cost(from_iteration) <= cost(from_minimum_norm) ? from_iteration : from_minimum_norm;
      s.projections.push_back(names + ": not physical, and no physical body keeps every identified combination; "
                              "projected to nearby physical parameters (the fit is worse for it)");
    } else {
      s.projections.push_back(names + ": minimum-norm correction not physical; moved along unidentified "
                              "directions (" + std::to_string(iterations) + " iterations), identified combinations kept");
    }
    s.delta = d;
  }

  // Per-parameter estimates.
  for (int k = 0; k < n; ++k) {
    for (int j = 0; j < kBodyParameters; ++j) {
      ParameterEstimate e;
      e.body = k;
      e.index = j;
      const int c = body_offset(k) + j;
      e.nominal = theta_nominal_[c];
      e.value = theta_nominal_[c] + s.delta[c];
      const auto it = std::find(selected_.begin(), selected_.end(), c);
      e.fitted = it != selected_.end();
      if (e.fitted) {
        const auto col = static_cast<int>(it - selected_.begin());
        e.identifiability = s.rank ? V.row(col).squaredNorm() : 0.0;
        e.standard_error = std::sqrt(std::max(0.0, s.covariance(c, c)));
        if (nb < 2) e.standard_error = kNaN;
      }
      s.parameters.push_back(e);
    }
  }

  // Residual RMS per joint, before / after / current.
  const auto& stats = samples_held_out() > 0 ? held_joint_ : fit_joint_;
  s.held_out = samples_held_out() > 0;
  auto rms = [&](const Eigen::VectorXd& full_delta) {
    Eigen::VectorXd d(pi);
    for (int j = 0; j < pi; ++j) d[j] = full_delta[selected_[static_cast<std::size_t>(j)]];
    const Eigen::VectorXd f = Aff_inv * (b.tail(pf) - Aif.transpose() * d);
    Eigen::VectorXd xx(columns_);
    xx << d, f;
    Eigen::VectorXd out(n);
    for (int i = 0; i < n; ++i) {
      const JointStats& js = stats[static_cast<std::size_t>(i)];
      const Eigen::MatrixXd G = symmetric(js.G);
      const double ms = (js.s - 2 * xx.dot(js.c) + xx.dot(G * xx)) / static_cast<double>(std::max<std::uint64_t>(js.count, 1));
      out[i] = std::sqrt(std::max(ms, 0.0));
    }
    return out;
  };
  s.rms_before = rms(Eigen::VectorXd::Zero(p));
  s.rms_after = rms(s.delta);
  s.rms_unprojected = rms(s.delta_unprojected);
  if (current && current->size() == p) s.rms_current = rms(*current);
  return s;
}

}  // namespace momentum::dynfit
