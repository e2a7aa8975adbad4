#include "momentum/inertia/identify.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <exception>
#include <limits>
#include <mutex>
#include <thread>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>

#include "momentum/core/error.hpp"
#include "momentum/core/random.hpp"
#include "momentum/core/statistics.hpp"
#include "momentum/inertia/regressor.hpp"
#include "momentum/model/inertial_corrections.hpp"
#include "momentum/observer/filter.hpp"

namespace momentum::inertia {

namespace {

constexpr int kMaxBlocks = 64;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

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

// argmin (d - d_hat)^T Q (d - d_hat) over corrections d whose bodies have pseudo-inertias J_k
// with eigenvalues >= floors[k]; Q symmetric positive definite. A convex problem (J is linear
// in the parameters), solved by the barrier method (Boyd and Vandenberghe, ch. 11): Newton's
// method on f - t sum_k log det(J_k - floor_k E) for t falling tenfold to a duality gap far
// below f, from the eigenvalue-clamped d_hat. Newton copes with Q's spread (the data's
// information next to a weak pull), and every iterate is strictly physical.
Eigen::VectorXd nearest_physical(const Eigen::VectorXd& theta_nominal, const Eigen::VectorXd& d_hat,
                                 const Eigen::MatrixXd& Q, const Eigen::VectorXd& floors, int* newton_steps) {
  const Eigen::Index p = d_hat.size();
  const int n = static_cast<int>(p / kBodyParameters);
  std::array<Eigen::Matrix4d, kBodyParameters> A;  // dJ / d theta_j, the same for every body
  for (int j = 0; j < kBodyParameters; ++j) A[static_cast<std::size_t>(j)] = pseudo_inertia(model::StandardParameters::Unit(j));
  auto slack = [&](const Eigen::VectorXd& d, int k) {  // J_k - floor_k E
    const model::StandardParameters theta = theta_nominal.segment<kBodyParameters>(kBodyParameters * k) +
                                            d.segment<kBodyParameters>(kBodyParameters * k);
    return Eigen::Matrix4d(pseudo_inertia(theta) - floors[k] * Eigen::Matrix4d::Identity());
  };
  // f_t(d), or +inf outside the domain.
  auto value = [&](const Eigen::VectorXd& d, double t) {
    double barrier = 0;
    for (int k = 0; k < n; ++k) {
      const Eigen::LLT<Eigen::Matrix4d> llt(slack(d, k));
      if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
      barrier += 2 * llt.matrixLLT().diagonal().array().log().sum();
    }
    const Eigen::VectorXd e = d - d_hat;
    return e.dot(Q * e) - t * barrier;
  };
  // Start strictly inside: each body's J with eigenvalues raised to at least twice its floor.
  Eigen::VectorXd d = d_hat;
  for (int k = 0; k < n; ++k) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(slack(d_hat, k) + floors[k] * Eigen::Matrix4d::Identity());
    const Eigen::Vector4d l = eig.eigenvalues().cwiseMax(2 * floors[k]);
    const Eigen::Matrix4d J = eig.eigenvectors() * l.asDiagonal() * eig.eigenvectors().transpose();
    // theta from J: the inverse of the linear map, on the basis A.
    Eigen::Matrix<double, 16, kBodyParameters> basis;
    for (int j = 0; j < kBodyParameters; ++j) basis.col(j) = Eigen::Map<const Eigen::Matrix<double, 16, 1>>(A[static_cast<std::size_t>(j)].data());
    const Eigen::Matrix<double, kBodyParameters, 1> theta =
        basis.colPivHouseholderQr().solve(Eigen::Map<const Eigen::Matrix<double, 16, 1>>(J.data()));
    d.segment<kBodyParameters>(kBodyParameters * k) = theta - theta_nominal.segment<kBodyParameters>(kBodyParameters * k);
  }
  const Eigen::VectorXd e0 = d - d_hat;
  double t = std::max(e0.dot(Q * e0), 1e-300) / (4.0 * n);
  const double t_final = 1e-12 * t;
  int steps = 0;
  for (; t >= t_final; t *= 0.1) {
    for (int inner = 0; inner < 100; ++inner) {
      Eigen::VectorXd g = 2 * Q * (d - d_hat);
      Eigen::MatrixXd H = 2 * Q;
      for (int k = 0; k < n; ++k) {
        const Eigen::Matrix4d X_inv = slack(d, k).inverse();
        std::array<Eigen::Matrix4d, kBodyParameters> XA;
        for (int j = 0; j < kBodyParameters; ++j) XA[static_cast<std::size_t>(j)] = X_inv * A[static_cast<std::size_t>(j)];
        for (int i = 0; i < kBodyParameters; ++i) {
          g[kBodyParameters * k + i] -= t * XA[static_cast<std::size_t>(i)].trace();
          for (int j = 0; j < kBodyParameters; ++j)
            H(kBodyParameters * k + i, kBodyParameters * k + j) +=
                t * (XA[static_cast<std::size_t>(i)] * XA[static_cast<std::size_t>(j)]).trace();
        }
      }
      const Eigen::VectorXd step = -H.ldlt().solve(g);
      const double decrement = -g.dot(step);  // Newton decrement squared
      if (!(decrement > 1e-14 * std::max(1e-300, std::abs(value(d, t))) + 1e-300)) break;
      ++steps;
      const double f0 = value(d, t);
      double alpha = 1;
      while (alpha > 1e-12 && !(value(d + alpha * step, t) <= f0 - 0.25 * alpha * decrement)) alpha *= 0.5;
      if (alpha <= 1e-12) break;
      d += alpha * step;
    }
  }
  if (newton_steps) *newton_steps = steps;
  return d;
}

double smallest_pseudo_eigenvalue(const model::StandardParameters& t) {
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(pseudo_inertia(t), Eigen::EigenvaluesOnly)
      .eigenvalues()[0];
}

}  // namespace

bool IdentifyOptions::IsValid(std::string* why) const {
  if (!(filter_gain > 0) || !std::isfinite(filter_gain)) return invalid(why, "filter gain must be > 0");
  if (!(coulomb_speed > 0) || !std::isfinite(coulomb_speed))
    return invalid(why, "coulomb speed must be > 0");
  if (!(rank_tolerance > 0 && rank_tolerance < 1))
    return invalid(why, "rank tolerance must be in (0, 1)");
  if (!(settle_time_constants >= 0) || !std::isfinite(settle_time_constants))
    return invalid(why, "settle time must be >= 0");
  if (!(gap_factor > 1) || !std::isfinite(gap_factor)) return invalid(why, "gap factor must be > 1");
  if (!(holdout_segment > 0) || !std::isfinite(holdout_segment))
    return invalid(why, "held-out segment length must be > 0");
  if (holdout_every != 0 && holdout_every < 2)
    return invalid(why, "held-out period must be 0 (none) or >= 2");
  if (!(block > 0) || !std::isfinite(block)) return invalid(why, "block length must be > 0");
  if (!(rows_per_time_constant >= 0) || !std::isfinite(rows_per_time_constant))
    return invalid(why, "rows per time constant must be >= 0");
  if (!(min_speed >= 0) || !std::isfinite(min_speed)) return invalid(why, "minimum speed must be >= 0");
  if (velocity_noise_draws < 0) return invalid(why, "velocity-noise draws must be >= 0");
  if (!(velocity_noise_seconds >= 0) || !std::isfinite(velocity_noise_seconds))
    return invalid(why, "velocity-noise seconds must be >= 0");
  if (velocity_noise_samples < 10) return invalid(why, "velocity-noise samples must be >= 10");
  if (threads < 1) return invalid(why, "threads must be >= 1");
  if (!(friction_probe_seconds >= 0) || !std::isfinite(friction_probe_seconds))
    return invalid(why, "friction-probe seconds must be >= 0");
  if (max_samples != 0 && max_samples < static_cast<std::uint64_t>(velocity_noise_samples))
    return invalid(why, "the sample budget must be 0 (all) or at least the velocity-noise samples (" +
                            std::to_string(velocity_noise_samples) + ")");
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
  block_joint_.assign(static_cast<std::size_t>(n_), empty);
  fit_rows_.resize(static_cast<std::size_t>(n_));
  held_rows_.resize(static_cast<std::size_t>(n_));
  block_length_ = options_.block;
  count_from_.assign(static_cast<std::size_t>(n_), std::numeric_limits<double>::infinity());
  slow_.assign(static_cast<std::size_t>(n_), false);
  // Thinned stretches are whole held-out periods, so that every kept stretch holds out its
  // share and the segments held out are those of the whole logs, and at least 20 settling
  // times of the filter long (the start of each does not count, settle_time_constants / K).
  {
    constexpr double kSettlingsPerStretch = 20;
    const double period = options_.holdout_segment * std::max(options_.holdout_every, 1);
    const double settle = options_.settle_time_constants / options_.filter_gain;
    stretch_ = period * std::max(1.0, std::ceil(kSettlingsPerStretch * settle / period));
  }
  if (options_.friction_probe && options_.fit_friction) {
    // A fit of its own (its rows restart where its joints pass its higher speed), fed every
    // sample taken; only its normal equations are used.
    IdentifyOptions probe = options_;
    probe.min_speed = std::max(2 * options_.min_speed, 0.1);
    probe.friction_probe = false;
    probe.velocity_noise_draws = 0;
    probe.threads = 1;
    probe.max_samples = 0;  // it is fed what this fit takes
    friction_probe_ = std::make_unique<Identifier>(nominal, probe);
    if (options_.threads > 1) probe_feed_ = std::make_unique<ProbeFeed>(*friction_probe_, n_);
  }
}

// The probe's samples and restarts, in order, in batches handed to a thread of its own. The
// probe does exactly what it would do fed here, so the results do not depend on the threads.
class Identifier::ProbeFeed {
 public:
  ProbeFeed(Identifier& probe, int n) : probe_(probe), n_(n), worker_([this] { run(); }) {}
  ~ProbeFeed() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    ready_.notify_all();
    worker_.join();
  }
  // Yp and Yb: the main fit's regressor at this sample (n x 10 n each, column-major), or null.
  void add(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq, const Eigen::VectorXd& tau_m,
           const double* Yp, const double* Yb, Eigen::Index size) {
    filling_.restart.push_back(Yp ? kSampleWithRegressor : kSample);
    filling_.values.push_back(t);
    filling_.values.insert(filling_.values.end(), q.data(), q.data() + n_);
    filling_.values.insert(filling_.values.end(), dq.data(), dq.data() + n_);
    filling_.values.insert(filling_.values.end(), tau_m.data(), tau_m.data() + n_);
    if (Yp) {
      filling_.regressors.insert(filling_.regressors.end(), Yp, Yp + size);
      filling_.regressors.insert(filling_.regressors.end(), Yb, Yb + size);
    }
    if (filling_.restart.size() >= kBatch) hand_over();
  }
  void restart() {
    filling_.restart.push_back(kRestart);
    if (filling_.restart.size() >= kBatch) hand_over();
  }
  void pass(double t) {
    filling_.restart.push_back(kPass);
    filling_.values.push_back(t);
    if (filling_.restart.size() >= kBatch) hand_over();
  }
  // Returns when the probe has seen every sample; rethrows what it threw.
  void drain() {
    hand_over();
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [&] { return queue_.empty() && !busy_; });
    if (error_) std::rethrow_exception(error_);
  }

 private:
  // About a second of a 1 kHz log: with the regressors of its counted rows (2 n x 10 n values
  // each, 200 a second at 1 kHz and K = 10), a batch of the 6-joint arm holds about 1.2 MB.
  static constexpr std::size_t kBatch = 1024;
  static constexpr std::size_t kQueued = 4;  // batches waiting at most (bounded memory)
  static constexpr std::uint8_t kSample = 0, kRestart = 1, kSampleWithRegressor = 2, kPass = 3;
  struct Batch {
    // per entry: kRestart, kPass (1 value: t) or a sample (1 + 3 n values)
    std::vector<std::uint8_t> restart;
    std::vector<double> values;
    std::vector<double> regressors;     // Y_p then Y_b of each kSampleWithRegressor entry
  };
  void hand_over() {
    if (filling_.restart.empty()) return;
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [&] { return queue_.size() < kQueued; });
    queue_.push_back(std::move(filling_));
    // A batch the probe is done with, its buffers kept: fresh megabytes for every batch cost
    // more in page faults than the probe's work on them.
    filling_ = Batch{};
    if (!spare_.empty()) {
      filling_ = std::move(spare_.back());
      spare_.pop_back();
    }
    lock.unlock();
    ready_.notify_one();
    filling_.restart.reserve(kBatch);
    filling_.values.reserve(kBatch * static_cast<std::size_t>(1 + 3 * n_));
  }
  void run() {
    Eigen::VectorXd q(n_), dq(n_), tau(n_);
    const Eigen::Index size = static_cast<Eigen::Index>(n_) * kBodyParameters * n_;
    for (;;) {
      Batch batch;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        ready_.wait(lock, [&] { return stop_ || !queue_.empty(); });
        if (queue_.empty()) return;
        batch = std::move(queue_.front());
        queue_.pop_front();
        busy_ = true;
      }
      done_.notify_all();  // room in the queue
      if (!error_) {
        try {
          const double* v = batch.values.data();
          const double* y = batch.regressors.data();
          for (const std::uint8_t kind : batch.restart) {
            if (kind == kRestart) {
              probe_.restart_sample();
              continue;
            }
            if (kind == kPass) {
              probe_.pass_sample(*v++);
              continue;
            }
            const double t = *v++;
            for (int j = 0; j < n_; ++j) q[j] = *v++;
            for (int j = 0; j < n_; ++j) dq[j] = *v++;
            for (int j = 0; j < n_; ++j) tau[j] = *v++;
            if (kind == kSampleWithRegressor) {
              probe_.add_sample(t, q, dq, tau, y, y + size);
              y += 2 * size;
            } else {
              probe_.add_sample(t, q, dq, tau);
            }
          }
        } catch (...) {
          std::lock_guard<std::mutex> lock(mutex_);
          error_ = std::current_exception();
        }
      }
      batch.restart.clear();
      batch.values.clear();
      batch.regressors.clear();
      {
        std::lock_guard<std::mutex> lock(mutex_);
        busy_ = false;
        if (spare_.size() < kQueued) spare_.push_back(std::move(batch));
      }
      done_.notify_all();
    }
  }
  Identifier& probe_;
  const int n_;
  Batch filling_;
  std::mutex mutex_;
  std::condition_variable ready_, done_;
  std::deque<Batch> queue_;
  std::vector<Batch> spare_;  // processed batches, emptied, for hand_over() to fill again
  bool busy_ = false, stop_ = false;
  std::exception_ptr error_;
  std::thread worker_;  // last: starts once everything above is in place
};

Identifier::~Identifier() = default;

void Identifier::probe_add(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq,
                           const Eigen::VectorXd& tau_m, bool regressed) {
  if (probe_reference_) return;
  const double* Yp = regressed ? Yp_.data() : nullptr;
  const double* Yb = regressed ? Yb_.data() : nullptr;
  if (probe_feed_) {
    probe_feed_->add(t, q, dq, tau_m, Yp, Yb, Yp_.size());
  } else if (friction_probe_) {
    friction_probe_->add_sample(t, q, dq, tau_m, Yp, Yb);
  }
}

void Identifier::probe_pass(double t) {
  if (probe_reference_) return;
  if (probe_feed_) {
    probe_feed_->pass(t);
  } else if (friction_probe_) {
    friction_probe_->pass_sample(t);
  }
}

void Identifier::probe_restart() {
  if (probe_reference_) return;
  if (probe_feed_) {
    probe_feed_->restart();
  } else if (friction_probe_) {
    friction_probe_->restart_sample();
  }
}

void Identifier::Grid::add(double k_, double t_) {
  n += 1;
  sk += k_;
  st += t_;
  skk += k_ * k_;
  skt += k_ * t_;
  const double d = n * skk - sk * sk;
  if (n >= 2 && d > 0) {
    const double p = (n * skt - sk * st) / d;
    if (p > 0 && std::isfinite(p)) {
      period = p;
      origin = (st - p * sk) / n;
    }
  }
}

double Identifier::cycle_start(double t) const {
  if (!(grid_.period > 0)) return t;
  // A sample up to 2% of a cycle before a tick counts as taken at the tick: the fitted grid's
  // own error, and a log without jitter whose times are rounded.
  const double x = t - grid_.t_first - grid_.origin;
  return grid_.t_first + grid_.origin + std::floor(x / grid_.period + 0.02) * grid_.period;
}

void Identifier::restart() {
  end_pass();  // the log's time runs to its last sample, thinned out or not
  restart_sample();
  if (copies_started_) {
    for (auto& copy : noisy_) copy->restart_sample();
  } else {
    restart_pending_ = true;
  }
}

void Identifier::plan(std::uint64_t samples) {
  if (samples_read_ > 0) throw Error("dynfit: plan() after the first sample");
  keep_share_ = options_.max_samples > 0 && samples > options_.max_samples
                    ? static_cast<double>(options_.max_samples) / static_cast<double>(samples)
                    : 0.0;
}

double Identifier::stretch_of(double t) const {
  // The log time of the sample (that fit_sample() gives it, up to rounding).
  double at = t_log_;
  if (have_time_ && t > t_previous_) at += t - t_previous_;
  return std::floor(at / stretch_);
}

bool Identifier::thinned_out(double t) const {
  if (samples_taken_ >= options_.max_samples) return true;  // the budget's guarantee
  // Stretch s is kept when (s + 1) share passes an integer: evenly spread, floor(S share) of
  // the first S (at most the share of the samples, when the stretches are full).
  const double s = stretch_of(t);
  return !(std::floor((s + 1) * keep_share_) > std::floor(s * keep_share_));
}

void Identifier::pass_sample(double t) {
  if (std::isfinite(t) && (!have_time_ || t > t_previous_)) {
    if (have_time_) {
      t_log_ += t - t_previous_;
      thinned_seconds_ += t - t_previous_;
    }
    have_time_ = true;
    t_previous_ = t;
  }
  started_ = false;
}

void Identifier::end_pass() {
  if (!passing_) return;
  passing_ = false;
  // This fit, its probe and its velocity-noise copies take the same time step, so that their
  // held-out segments stay the same.
  pass_sample(pass_t_);
  probe_pass(pass_t_);
  if (copies_started_) {
    if (!noise_reference_)
      for (auto& copy : noisy_) copy->pass_sample(pass_t_);
  } else if (options_.velocity_noise_draws > 0) {
    KeptSample pass;
    pass.t = pass_t_;
    pass.pass = true;
    pass.restart = restart_pending_;
    restart_pending_ = false;
    kept_.push_back(std::move(pass));
  }
}

void Identifier::restart_sample() {
  // A new log starts a new held-out segment period.
  t_log_ = options_.holdout_segment * std::ceil(t_log_ / options_.holdout_segment + 1e-9);
  started_ = false;
  have_time_ = false;
  probe_restart();
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

namespace {
constexpr int kRows = 128;  // rows per batch of a joint's normal equations
}  // namespace

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

void Identifier::flush_rows(std::size_t joint, bool held_out) const {
  RowBuffer& buffer = (held_out ? held_rows_ : fit_rows_)[joint];
  if (buffer.rows == 0) return;
  JointStats& sums = (held_out ? held_joint_ : block_joint_)[joint];
  const Eigen::Index m = columns_ - buffer.first;
  const auto Z = buffer.Z.topRows(buffer.rows).rightCols(m);
  const auto e = buffer.e.head(buffer.rows);
  // The lower triangle of Z^T Z, over the columns any of the rows has nonzero.
  sums.G.bottomRightCorner(m, m).selfadjointView<Eigen::Lower>().rankUpdate(Z.transpose());
  sums.c.tail(m).noalias() += Z.transpose() * e;
  sums.s += e.squaredNorm();
  buffer.rows = 0;
  buffer.first = columns_;
}

void Identifier::flush() const {
  for (std::size_t i = 0; i < held_rows_.size(); ++i) flush_rows(i, true);
  for (std::size_t i = 0; i < fit_rows_.size(); ++i) flush_rows(i, false);
  if (blocks_.empty()) return;
  Block& block = blocks_.back();
  for (std::size_t i = 0; i < block_joint_.size(); ++i) {
    JointStats& sums = block_joint_[i];
    if (sums.s == 0 && sums.c.isZero(0.0) && sums.G.isZero(0.0)) continue;
    block.A += sums.G;
    block.b += sums.c;
    fit_joint_[i].G += sums.G;
    fit_joint_[i].c += sums.c;
    fit_joint_[i].s += sums.s;
    sums.G.setZero();
    sums.c.setZero();
    sums.s = 0;
  }
}

void Identifier::accumulate(const Eigen::MatrixXd& Z, const Eigen::VectorXd& e, bool held_out) {
  auto& joints = held_out ? held_joint_ : fit_joint_;
  if (!held_out && (blocks_.empty() || t_log_ - block_start_ >= block_length_)) {
    flush();  // the rows so far belong to the block that ends here
    begin_block();
  }
  auto& buffers = held_out ? held_rows_ : fit_rows_;
  for (int i = 0; i < n_; ++i) {
    if (Z.row(i).isZero(0.0) && e[i] == 0.0) continue;  // a row that does not count
    const auto j = static_cast<std::size_t>(i);
    RowBuffer& buffer = buffers[j];
    if (buffer.Z.rows() == 0) {
      buffer.Z.setZero(kRows, columns_);
      buffer.e.setZero(kRows);
      buffer.first = columns_;
    }
    buffer.Z.row(buffer.rows) = Z.row(i);
    buffer.e[buffer.rows] = e[i];
    Eigen::Index first = 0;
    while (first < buffer.first && Z(i, first) == 0.0) ++first;
    buffer.first = std::min(buffer.first, first);
    ++buffer.rows;
    ++joints[j].count;
    if (buffer.rows == kRows) flush_rows(j, held_out);
  }
}

void Identifier::add(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq,
                     const Eigen::VectorXd& tau_m) {
  if (q.size() != n_ || dq.size() != n_ || tau_m.size() != n_) {
    throw Error("dynfit: a sample has the wrong number of joints");
  }
  ++samples_read_;
  if (keep_share_ > 0) {
    if (thinned_out(t)) {
      // Only the last of a run of samples thinned out is looked at (end_pass()): its time;
      // and the first of a log, which starts the log's time.
      if (std::isfinite(t)) {
        pass_t_ = t;
        passing_ = true;
        if (!have_time_) end_pass();
      }
      return;
    }
    end_pass();
    const auto stretch = static_cast<long long>(stretch_of(t));
    if (stretch != last_stretch_) ++stretches_kept_;
    last_stretch_ = stretch;
  }
  ++samples_taken_;
  add_sample(t, q, dq, tau_m);
  // The time limits below count the log time fitted: t_log_ itself without thinning.
  const double t_fitted = t_log_ - thinned_seconds_;
  if (friction_probe_ && !probe_reference_ && options_.friction_probe_seconds > 0 &&
      t_fitted >= options_.friction_probe_seconds)
    probe_reference_ = snapshot();  // the probe has seen its share of the log
  const std::uint64_t index = sample_index_++;
  if (options_.velocity_noise_draws == 0) return;
  if (!copies_started_) {
    kept_.push_back({index, t, q, dq, tau_m, restart_pending_});
    restart_pending_ = false;
    if (++kept_samples_ >= static_cast<std::size_t>(options_.velocity_noise_samples)) {
      noisy_ = replay_kept(&velocity_noise_);
      copies_started_ = true;
      kept_.clear();
      kept_.shrink_to_fit();
    }
    return;
  }
  if (noise_reference_) return;  // the copies have seen their share of the log
  for (std::size_t c = 0; c < noisy_.size(); ++c)
    add_to_copy(*noisy_[c], c, index, velocity_noise_, t, q, dq, tau_m, noisy_dq_);
  if (options_.velocity_noise_seconds > 0 && t_fitted >= options_.velocity_noise_seconds) noise_reference_ = snapshot();
}

std::unique_ptr<Identifier> Identifier::snapshot() const {
  IdentifyOptions options = options_;
  options.friction_probe = false;
  options.velocity_noise_draws = 0;
  options.max_samples = 0;
  flush();
  auto copy = std::make_unique<Identifier>(model_, options);
  copy->blocks_ = blocks_;
  copy->block_start_ = block_start_;
  copy->fit_joint_ = fit_joint_;
  copy->held_joint_ = held_joint_;
  copy->skipped_ = skipped_;
  copy->restarts_ = restarts_;
  copy->seconds_fit_ = seconds_fit_;
  copy->seconds_held_ = seconds_held_;
  copy->t_log_ = t_log_;
  return copy;
}

void Identifier::add_to_copy(Identifier& copy, std::size_t which, std::uint64_t index, const Eigen::VectorXd& noise,
                             double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq, const Eigen::VectorXd& tau_m,
                             Eigen::VectorXd& noisy) const {
  noisy = dq;
  // One independent stream per copy, one seed per sample in it, one key per joint: the same
  // draw whenever (seed, copy, sample, joint) is the same, however the samples arrive.
  const std::uint64_t sample_seed = core::derive_seed(core::derive_seed(options_.seed, which), index);
  for (int j = 0; j < n_; ++j)
    noisy[j] += noise[j] * core::normal_at(core::derive_seed(sample_seed, static_cast<std::uint64_t>(j)));
  copy.add_sample(t, q, noisy, tau_m);
}

std::vector<std::unique_ptr<Identifier>> Identifier::replay_kept(Eigen::VectorXd* noise_level) const {
  std::vector<std::unique_ptr<Identifier>> copies;
  Eigen::VectorXd& noise = *noise_level;
  noise = Eigen::VectorXd::Zero(n_);
  if (kept_.size() < 3) return copies;
  // The noise level per joint, from second differences of the measured velocity.
  for (int j = 0; j < n_; ++j) {
    std::vector<double> d2;
    for (std::size_t k = 1; k + 1 < kept_.size(); ++k) {
      // Three consecutive samples: no restart or samples thinned out between them.
      if (kept_[k - 1].pass || kept_[k].pass || kept_[k + 1].pass || kept_[k].restart || kept_[k + 1].restart)
        continue;
      const double d = kept_[k + 1].dq[j] - 2 * kept_[k].dq[j] + kept_[k - 1].dq[j];
      if (std::isfinite(d)) d2.push_back(std::abs(d));
    }
    noise[j] = core::white_noise_from_second_differences(d2);
  }
  if (!(noise.maxCoeff() > 0)) return copies;  // exact velocities: nothing to double
  IdentifyOptions copy_options = options_;
  copy_options.velocity_noise_draws = 0;
  copy_options.friction_probe = false;
  copy_options.max_samples = 0;  // fed what this fit takes
  Eigen::VectorXd scratch(n_);
  for (int c = 0; c < options_.velocity_noise_draws; ++c) {
    copies.push_back(std::make_unique<Identifier>(model_, copy_options));
    for (const KeptSample& k : kept_) {
      if (k.restart) copies.back()->restart_sample();
      if (k.pass) {
        copies.back()->pass_sample(k.t);
        continue;
      }
      add_to_copy(*copies.back(), static_cast<std::size_t>(c), k.index, noise, k.t, k.q, k.dq, k.tau_m, scratch);
    }
  }
  return copies;
}

const observer::FilterCoefficients& Identifier::coefficients(const observer::Gains& gains, double dt,
                                                            CachedCoefficients& cache) {
  if (dt != cache.dt) {
    cache.c = observer::discretize(gains, dt);
    cache.dt = dt;
  }
  return cache.c;
}

void Identifier::add_sample(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq,
                            const Eigen::VectorXd& tau_m, const double* Yp,
                            const double* Yb) {
  regressed_ = false;
  fit_sample(t, q, dq, tau_m, Yp, Yb);
  // The probe after this fit, so that it can take the regressor this fit evaluated (the same
  // function of the same q and dq: the probe's results are those of its own evaluation).
  probe_add(t, q, dq, tau_m, regressed_);
}

void Identifier::regressor(const Eigen::VectorXd& q, const Eigen::VectorXd& dq,
                           const double* Yp, const double* Yb) {
  if (Yp && Yb) {
    const Eigen::Index p = kBodyParameters * n_;
    Yp_ = Eigen::Map<const Eigen::MatrixXd>(Yp, n_, p);
    Yb_ = Eigen::Map<const Eigen::MatrixXd>(Yb, n_, p);
  } else {
    momentum_regressor(model_, data_, q, dq, Yp_, Yb_);
  }
  regressed_ = true;
}

void Identifier::fit_sample(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& dq,
                            const Eigen::VectorXd& tau_m, const double* Yp,
                            const double* Yb) {
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
  for (int j = 0; j < n_; ++j) {
    friction_(j, 0) = std::tanh(dq[j] / options_.coulomb_speed);
    friction_(j, 1) = dq[j];
  }
  y_ = tau_m;
  pk_ = model_.rotor_inertia.cwiseProduct(dq);
  if (!started_) {
    regressor(q, dq, Yp, Yb);
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
    // The filters start in steady state, wrong by the filtered dp/dt of this instant: rows
    // count after settle_time_constants / K (or from a joint's exact restart, below).
    std::fill(count_from_.begin(), count_from_.end(), t + options_.settle_time_constants / options_.filter_gain);
    std::fill(slow_.begin(), slow_.end(), false);
    grid_ = Grid{};
    grid_.t_first = t;
    grid_.add(0.0, 0.0);
    next_regression_ = t;
    since_regression_ = 0;
    return;
  }
  if (options_.torque_held) {
    // The control cycle: t against the sample's cycle number, by least squares over the log
    // so far. The number is the nearest tick of the grid fitted so far (so that a dropped
    // sample skips one, and no error accumulates), one more than the last for the first 50
    // samples, while the grid is still rough.
    const double x = t - grid_.t_first;
    grid_.k = grid_.n < 50 ? grid_.k + 1 : std::max(grid_.k + 1, std::round((x - grid_.origin) / grid_.period));
    grid_.add(grid_.k, x);
  }
  // The cheap signals (torque, friction terms, rotor momentum) are filtered at every sample;
  // the regressor (the chain's dynamics, most of the cost) only at the rows that count, with
  // the filter's first-order hold across the samples between: it varies with the motion, far
  // slower than the filter's time constant, so the hold's error is of the order of the motion's
  // curvature over a few milliseconds.
  const observer::Gains gains{options_.filter_gain, 0.0, 0.0};
  const observer::FilterCoefficients& c = coefficients(gains, dt, sample_coefficients_);
  auto advance = [](const observer::FilterCoefficients& c, auto& state, auto& previous, const auto& current) {
    state = c.a1 * state + c.b10 * previous + c.b11 * current;
    previous = current;
  };
  advance(c, Ff_, friction_prev_, friction_);
  if (options_.torque_held) {
    // The drive applies each torque from a tick of its control cycle to the next, and a sample
    // reports the torque in effect at its instant. Without jitter the ticks are the samples,
    // and the previous sample's torque holds over the whole interval. With jitter (a sample
    // late or early against its tick), the torque changes at the tick within the interval, a
    // sample taken just before its tick still reports the previous cycle's torque, and a cycle
    // between two such samples is not seen at all (taken as the mean of its neighbours).
    // Holding each sample's torque until the next sample instead shifts the torque in time by
    // a fraction of a cycle, and biased the inertial parameters by several standard errors.
    const double t0 = t - dt;
    const double tick1 = std::min(cycle_start(t0) + grid_.period, t);  // the first change
    const double tick2 = std::min(std::max(cycle_start(t), tick1), t);  // the last change
    const double k = options_.filter_gain;
    const double w1 = std::exp(-k * (t - tick1)) - c.a1;  // weights of the three pieces
    const double w2 = std::exp(-k * (t - tick2)) - std::exp(-k * (t - tick1));
    const double w3 = 1.0 - std::exp(-k * (t - tick2));
    Fy_ = c.a1 * Fy_ + w1 * y_prev_ + (0.5 * w2) * (y_prev_ + y_) + w3 * y_;
    y_prev_ = y_;
  } else {
    advance(c, Fy_, y_prev_, y_);
  }
  advance(c, Fpk_, pk_prev_, pk_);
  const double k = options_.filter_gain;
  const double g = c.gain;  // 1 for the first-order low-pass, whatever the interval
  // Rows count at rows_per_time_constant, and at once where a joint leaves slow motion (its
  // row's filters restart there, from the regressor of that sample).
  since_regression_ += dt;
  bool leaves_slow = false;
  for (int j = 0; j < n_; ++j)
    leaves_slow = leaves_slow || (slow_[static_cast<std::size_t>(j)] && std::abs(dq[j]) >= options_.min_speed);
  if (options_.rows_per_time_constant > 0 && !leaves_slow) {
    if (t < next_regression_ - 0.25 * dt) {
      for (int j = 0; j < n_; ++j)
        if (std::abs(dq[j]) < options_.min_speed) slow_[static_cast<std::size_t>(j)] = true;
      return;
    }
  }
  if (options_.rows_per_time_constant > 0) {
    const double interval = 1.0 / (options_.rows_per_time_constant * options_.filter_gain);
    next_regression_ = std::max(next_regression_ + interval, t + 0.5 * interval);
  }
  const double counted_dt = since_regression_;
  since_regression_ = 0;
  regressor(q, dq, Yp, Yb);
  const observer::FilterCoefficients& cr = coefficients(gains, counted_dt, regression_coefficients_);
  advance(cr, Fp_, Yp_prev_, Yp_);
  advance(cr, Fb_, Yb_prev_, Yb_);
  // A joint's equation does not count while the joint is slower than min_speed: friction there
  // sticks and shows Stribeck and presliding effects that the Coulomb + viscous model does not
  // have. Nor may their memory in the filtered equation count: when the joint is fast again,
  // its row's filters restart at rest (F[tau_m], F[beta], F[tau_f] at 0, F[p] at p, so that
  // K (p - F[p]) = F[dp/dt] = 0 too). The filtered equation then holds exactly from that sample
  // on, with nothing of the slow phase in it, and counts at once. (Restarting in steady state,
  // as at a log's start, or waiting a few time constants leaves a few percent of the sticking's
  // friction error, which biased the Coulomb levels by several standard errors.)
  bool any_counted = false;
  for (int j = 0; j < n_; ++j) {
    const auto i = static_cast<std::size_t>(j);
    if (std::abs(dq[j]) < options_.min_speed) {
      slow_[i] = true;
      continue;
    }
    if (slow_[i]) {
      slow_[i] = false;
      Fp_.row(j) = Yp_.row(j) / g;
      Fb_.row(j).setZero();
      Ff_.row(j).setZero();
      Fy_[j] = 0.0;
      Fpk_[j] = pk_[j] / g;
      count_from_[i] = std::min(count_from_[i], t);
    }
    any_counted = any_counted || t >= count_from_[i];
  }
  if (!any_counted) return;
  Eigen::MatrixXd& W = W_;
  W.noalias() = k * (Yp_ - g * Fp_) + g * Fb_;
  Eigen::VectorXd& e = e_;
  e.noalias() = g * Fy_ - k * (pk_ - g * Fpk_);
  e.noalias() -= W * theta_nominal_;
  Eigen::MatrixXd& Z = Z_;
  Z.setZero(n_, columns_);
  for (int j = 0; j < fitted_; ++j) Z.col(j) = W.col(selected_[static_cast<std::size_t>(j)]);
  if (options_.fit_friction) {
    for (int i = 0; i < n_; ++i) {
      Z(i, fitted_ + 2 * i) = g * Ff_(i, 0);
      Z(i, fitted_ + 2 * i + 1) = g * Ff_(i, 1);
    }
  }
  bool held_out = false;
  if (options_.holdout_every > 0) {
    const auto segment = static_cast<long long>(std::floor(t_log_ / options_.holdout_segment));
    held_out = segment % options_.holdout_every == options_.holdout_every - 1;
  }
  for (int j = 0; j < n_; ++j) {
    const auto i = static_cast<std::size_t>(j);
    if (slow_[i] || t < count_from_[i]) {
      Z.row(j).setZero();
      e[j] = 0.0;
    }
  }
  accumulate(Z, e, held_out);
  (held_out ? seconds_held_ : seconds_fit_) += counted_dt;
}

IdentifySummary Identifier::solve(const Eigen::VectorXd* current) const {
  IdentifySummary s = solve_one(current);
  // The velocity-noise term: the mean shift of the unprojected estimate when the noise doubles.
  std::vector<std::unique_ptr<Identifier>> short_log_copies;
  const std::vector<std::unique_ptr<Identifier>>* copies = &noisy_;
  Eigen::VectorXd noise = velocity_noise_;
  if (!copies_started_) {  // a log shorter than the noise estimate's samples
    short_log_copies = replay_kept(&noise);
    copies = &short_log_copies;
  }
  Eigen::VectorXd shift = Eigen::VectorXd::Zero(s.delta_unprojected.size());
  // The copies' shift is measured against the fit of the same rows: all of them, or the first
  // velocity_noise_seconds of a longer log (the bias is a property of the noise and of the
  // motion, not of how much of it there is).
  Eigen::VectorXd coulomb_shift = Eigen::VectorXd::Zero(n_), viscous_shift = Eigen::VectorXd::Zero(n_);
  if (!copies->empty()) {
    const IdentifySummary reference = noise_reference_ ? noise_reference_->solve_one(nullptr) : s;
    for (const auto& copy : *copies) {
      const IdentifySummary c = copy->solve_one(nullptr);
      const double share = 1.0 / static_cast<double>(copies->size());
      shift += (c.delta_unprojected - reference.delta_unprojected) * share;
      coulomb_shift += (c.coulomb - reference.coulomb) * share;
      viscous_shift += (c.viscous - reference.viscous) * share;
    }
  }
  s.velocity_noise = noise.size() == n_ ? noise : Eigen::VectorXd::Zero(n_);
  s.velocity_noise_draws = static_cast<int>(copies->size());
  // The friction-model term; a log with too little fast motion for the probe has none.
  Eigen::VectorXd friction_shift = Eigen::VectorXd::Zero(shift.size());
  Eigen::VectorXd coulomb_probe = Eigen::VectorXd::Zero(n_), viscous_probe = Eigen::VectorXd::Zero(n_);
  if (probe_feed_) probe_feed_->drain();
  if (friction_probe_ && friction_probe_->samples_fit() > 0) {
    const IdentifySummary probe = friction_probe_->solve_one(nullptr);
    const IdentifySummary reference = probe_reference_ ? probe_reference_->solve_one(nullptr) : s;
    friction_shift = probe.delta_unprojected - reference.delta_unprojected;
    coulomb_probe = probe.coulomb - reference.coulomb;
    viscous_probe = probe.viscous - reference.viscous;
    s.friction_probe_min_speed = friction_probe_->options_.min_speed;
  }
  // The friction levels' uncertainty, combined in the same way.
  s.coulomb_uncertainty = (s.coulomb_se.array().square() + coulomb_shift.array().square() +
                           coulomb_probe.array().square()).sqrt().matrix();
  s.viscous_uncertainty = (s.viscous_se.array().square() + viscous_shift.array().square() +
                           viscous_probe.array().square()).sqrt().matrix();
  for (BaseParameter& base : s.base) {
    base.velocity_noise_shift = base.direction.dot(shift);
    base.friction_shift = base.direction.dot(friction_shift);
    base.uncertainty = std::sqrt(base.standard_error * base.standard_error +
                                 base.velocity_noise_shift * base.velocity_noise_shift +
                                 base.friction_shift * base.friction_shift);
  }
  for (ParameterEstimate& e : s.parameters) {
    const Eigen::Index c = kBodyParameters * e.body + e.index;
    e.velocity_noise_shift = e.fitted ? shift[c] : 0.0;
    e.friction_shift = e.fitted ? friction_shift[c] : 0.0;
    e.uncertainty = std::sqrt(e.standard_error * e.standard_error + e.velocity_noise_shift * e.velocity_noise_shift +
                              e.friction_shift * e.friction_shift);
  }
  return s;
}

IdentifySummary Identifier::solve_one(const Eigen::VectorXd* current) const {
  const int n = n_, pi = fitted_, pf = columns_ - fitted_, p = kBodyParameters * n;
  flush();
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
  s.samples_read = samples_read_;
  s.samples_taken = samples_taken_;
  s.thinned = keep_share_ > 0;
  s.stretch_seconds = stretch_;
  s.stretches_kept = stretches_kept_;

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
  const Eigen::VectorXd retained = inv_lambda.cwiseInverse();  // the identified eigenvalues
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
  // Physical consistency. Where the minimum-norm correction is not physical, take the physical
  // correction nearest to it in the metric of the data: the truncated information matrix
  // (identified combinations cost what the data say they cost), plus a weak pull toward the
  // minimum-norm correction (1% of the weakest identified direction's, per scaled column) so
  // that what the data do not determine moves only as much as physics needs. A convex problem
  // (the physical set is convex in the pseudo-inertia J, which is linear in theta): see
  // nearest_physical().
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
    for (int k = 0; k < n; ++k)
      floors[k] = 1e-3 * smallest_pseudo_eigenvalue(theta_nominal_.segment<kBodyParameters>(body_offset(k)));
    std::string names;
    for (int k : unphysical) names += (names.empty() ? "" : ", ") + model_.bodies[static_cast<std::size_t>(k)].name;
    if (options_.gravity_only) {
      // The inertias about the centres of mass are nominal (physical), so only a mass that is
      // not positive can make a body unphysical; such a body keeps its nominal parameters.
      for (int k : unphysical) s.delta.segment<kBodyParameters>(body_offset(k)).setZero();
      s.bodies_reset = static_cast<int>(unphysical.size());
      s.projections.push_back(names + ": identified mass not positive; the body keeps its nominal parameters");
    } else {
      // Selected columns are all 10 nq parameters here.
      const Eigen::MatrixXd information = scale.asDiagonal() * V * retained.asDiagonal() * V.transpose() * scale.asDiagonal();
      const Eigen::VectorXd pull = 1e-2 * options_.rank_tolerance * options_.rank_tolerance * top * scale.cwiseAbs2();
      Eigen::MatrixXd metric = information;
      metric.diagonal() += pull;
      int steps = 0;
      s.delta = nearest_physical(theta_nominal_, s.delta_unprojected, metric, floors, &steps);
      // How far the identified combinations had to move, in their standard errors.
      double worst = 0;
      for (const BaseParameter& base : s.base) {
        const double moved = base.direction.dot(s.delta - s.delta_unprojected);
        if (base.standard_error > 0) worst = std::max(worst, std::abs(moved) / base.standard_error);
      }
      s.projection_shift = worst;
      char text[160];
      std::snprintf(text, sizeof text,
                    ": minimum-norm correction not physical; nearest physical correction taken "
                    "(%d Newton steps; identified combinations moved by at most %.3g standard errors)",
                    steps, worst);
      s.projections.push_back(names + text);
    }
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

}  // namespace momentum::inertia
