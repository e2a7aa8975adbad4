#include "momentum/contact/locate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <set>
#include <string>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "momentum/core/error.hpp"
#include "momentum/model/collision.hpp"

namespace momentum::contact {

namespace {

// Directions a joint set sees at least this well (relative to the strongest) count as seen.
constexpr double kRankTolerance = 1e-6;

int seen_unknowns(int body) { return std::min(3, body + 1); }

// The probability within one standard deviation of a normal variable's mean.
constexpr double kOneSigmaMass = 0.6827;

// The sd of |F| for a force of covariance `covariance` times the variance scale `scale`: its
// variance along F's direction (any direction for F = 0).
double norm_sd(const Eigen::Vector3d& force, const Eigen::Matrix3d& covariance, double scale) {
  const double norm = force.norm();
  const Eigen::Vector3d direction = norm > 0 ? Eigen::Vector3d(force / norm) : Eigen::Vector3d::UnitX();
  return std::sqrt(std::max(0.0, scale * direction.dot(covariance * direction)));
}

// `s` with its disturbance (ResidualSample::tau) in place of r, weighed by tau's noise, into
// `d` (its storage reused); `s` itself when it carries no disturbance.
const ResidualSample& disturbance(const ResidualSample& s, ResidualSample& d) {
  if (s.tau.size() != s.r.size()) return s;
  d.t = s.t;
  d.q = s.q;
  d.r = s.tau;
  d.weight = s.tau_weight.size() == s.tau.size() ? s.tau_weight : s.weight;
  return d;
}

// Candidate points around each axial position of a link's cylinder (and, for collision shapes,
// the same density per axial position). For a whole contact 16: 2 cm apart on a 5 cm link. At
// 8 (4 cm) a 100 N push found a grid point up to 2 cm off, a lever error of 2 Nm against
// residual noise of a tenth of that, and a neighbouring link whose grid happened to fall
// nearer won: on 12 simulated campaigns and the MuJoCo UR5 isolation went from 325 to 331 of
// 386 and the median point error on the UR5 from 0.070 to 0.050 m (12: 328, 24: 333), for
// twice the points. At detection 8: its few samples name the link as well either way (215
// and 214 of 386), and the onset row waits for the fit (bench_contact: 2.6 against 5.6 ms).
constexpr int kPointsAround = 16;
constexpr int kPointsAroundAtDetection = 8;

// The pseudo-inverse of a symmetric positive semi-definite 3 x 3 matrix: directions whose
// eigenvalue is under kRankTolerance of the largest are left out (the minimum-norm solution).
Eigen::Matrix3d pseudo_inverse(const Eigen::Matrix3d& normal) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
  eigen.computeDirect(normal);
  const Eigen::Vector3d& values = eigen.eigenvalues();
  Eigen::Vector3d inverse = Eigen::Vector3d::Zero();
  for (int i = 0; i < 3; ++i)
    if (values[i] > kRankTolerance * values[2]) inverse[i] = 1.0 / values[i];
  return eigen.eigenvectors() * inverse.asDiagonal() * eigen.eigenvectors().transpose();
}

// z with P(N(0, 1) > z) = p, for 0 < p < 0.5 (bisection on erfc).
double upper_normal_quantile(double p) {
  double lo = 0, hi = 40;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(mid / std::sqrt(2.0)) > p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// The (1 - alpha) quantile of a chi-square variable with `dof` degrees of freedom
// (Wilson-Hilferty: within 1% for dof >= 2 at these levels).
double chi_square_quantile(double dof, double alpha) {
  if (dof == 1) return std::pow(upper_normal_quantile(alpha / 2), 2);  // the square of a two-sided normal
  const double h = 2 / (9 * dof);
  return dof * std::pow(std::max(0.0, 1 - h + upper_normal_quantile(alpha) * std::sqrt(h)), 3);
}

}  // namespace

std::vector<Segment> link_segments(const model::Model& model) {
  std::vector<Segment> segments(static_cast<std::size_t>(model.nq));
  for (int b = 0; b < model.nq; ++b) {
    Segment& s = segments[static_cast<std::size_t>(b)];
    s.body = b;
    s.to = b + 1 < model.nq ? model.joints[static_cast<std::size_t>(b + 1)].placement.translation
                            : model.tip_placement.translation;
  }
  return segments;
}

namespace {

double triangle_area(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  return 0.5 * (b - a).cross(c - a).norm();
}

double shape_area(const model::CollisionShape& shape) {
  using Kind = model::CollisionShape::Kind;
  const Eigen::Vector3d& d = shape.size;
  switch (shape.kind) {
    case Kind::sphere: return 4 * M_PI * d.x() * d.x();
    case Kind::box: return 2 * (d.x() * d.y() + d.y() * d.z() + d.x() * d.z());
    case Kind::cylinder: return 2 * M_PI * d.x() * d.y() + 2 * M_PI * d.x() * d.x();
    case Kind::mesh: {
      double area = 0;
      for (std::size_t t = 0; t + 2 < shape.triangles.size(); t += 3)
        area += triangle_area(shape.triangles[t], shape.triangles[t + 1], shape.triangles[t + 2]);
      return area;
    }
  }
  return 0;
}

int count_over(double length, double spacing) { return std::max(1, static_cast<int>(std::lround(length / spacing))); }

// Points of one shape, in its own frame.
void shape_points(const model::CollisionShape& shape, double spacing, std::vector<Eigen::Vector3d>& out) {
  using Kind = model::CollisionShape::Kind;
  const Eigen::Vector3d& d = shape.size;
  switch (shape.kind) {
    case Kind::sphere: {
      const int n = count_over(shape_area(shape), spacing * spacing);
      const double golden = M_PI * (3 - std::sqrt(5.0));
      for (int i = 0; i < n; ++i) {
        const double z = 1 - (2 * i + 1.0) / n, rho = std::sqrt(1 - z * z);
        out.emplace_back(d.x() * rho * std::cos(golden * i), d.x() * rho * std::sin(golden * i), d.x() * z);
      }
      return;
    }
    case Kind::box:
      for (int axis = 0; axis < 3; ++axis) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        const int nu = count_over(d[u], spacing), nv = count_over(d[v], spacing);
        for (const double side : {-0.5, 0.5})
          for (int i = 0; i < nu; ++i)
            for (int k = 0; k < nv; ++k) {
              Eigen::Vector3d p;
              p[axis] = side * d[axis];
              p[u] = ((i + 0.5) / nu - 0.5) * d[u];
              p[v] = ((k + 0.5) / nv - 0.5) * d[v];
              out.push_back(p);
            }
      }
      return;
    case Kind::cylinder: {
      const double r = d.x(), length = d.y();
      const int around = std::max(4, count_over(2 * M_PI * r, spacing)), along = count_over(length, spacing);
      for (int a = 0; a < along; ++a)
        for (int k = 0; k < around; ++k) {
          const double angle = 2 * M_PI * k / around;
          out.emplace_back(r * std::cos(angle), r * std::sin(angle), ((a + 0.5) / along - 0.5) * length);
        }
      const int rings = count_over(r, spacing);
      for (const double side : {-0.5, 0.5})
        for (int ring = 0; ring < rings; ++ring) {
          const double rho = r * (ring + 0.5) / rings;
          const int n = std::max(1, count_over(2 * M_PI * rho, spacing));
          for (int k = 0; k < n; ++k)
            out.emplace_back(rho * std::cos(2 * M_PI * k / n), rho * std::sin(2 * M_PI * k / n), side * length);
        }
      return;
    }
    case Kind::mesh: {
      // Systematic sampling by area: the triangle under each of n evenly spaced marks of the
      // cumulative area gives its centroid.
      const double area = shape_area(shape);
      if (!(area > 0)) return;
      const int n = count_over(area, spacing * spacing);
      double cumulative = 0;
      int next = 0;
      for (std::size_t t = 0; t + 2 < shape.triangles.size() && next < n; t += 3) {
        const auto &a = shape.triangles[t], &b = shape.triangles[t + 1], &c = shape.triangles[t + 2];
        cumulative += triangle_area(a, b, c);
        bool taken = false;
        while (next < n && (next + 0.5) * area / n <= cumulative) {
          if (!taken) out.push_back((a + b + c) / 3);
          taken = true;
          ++next;
        }
      }
      return;
    }
  }
}

}  // namespace

double surface_area(const std::vector<model::CollisionShape>& shapes) {
  double area = 0;
  for (const auto& shape : shapes) area += shape_area(shape);
  return area;
}

std::vector<Eigen::Vector3d> surface_points(const std::vector<model::CollisionShape>& shapes, double spacing) {
  std::vector<Eigen::Vector3d> points, local;
  for (const auto& shape : shapes) {
    local.clear();
    shape_points(shape, spacing, local);
    for (const auto& p : local) points.push_back(shape.placement.rotation * p + shape.placement.translation);
  }
  return points;
}

bool LocatorOptions::IsValid(std::string* why) const {
  if (points_per_link < 2) return invalid(why, "points per link must be at least 2");
  if (!(link_radius >= 0) || !std::isfinite(link_radius)) return invalid(why, "the link radius must be >= 0 m");
  if (max_fit_samples < 1) return invalid(why, "the fit needs at least 1 sample");
  if (!(penalty_per_unknown > 0) || !std::isfinite(penalty_per_unknown))
    return invalid(why, "the penalty per unknown must be positive");
  if (!(proximal_alpha > 0 && proximal_alpha < 0.5)) return invalid(why, "the proximal level must be in (0, 0.5)");
  if (!(link_confidence > 0 && link_confidence <= 1)) return invalid(why, "the link set's confidence must be in (0, 1]");
  if (!(link_temperature > 0) || !std::isfinite(link_temperature)) return invalid(why, "the link temperature must be positive");
  for (double k : observer_k1)
    if (!(k > 0) || !std::isfinite(k)) return invalid(why, "an observer gain must be a finite number > 0");
  return true;
}

Locator::Locator(const model::Model& model, Eigen::VectorXd sigma, LocatorOptions options)
    : model_(&model), data_(model), options_(options), segments_(link_segments(model)) {
  std::string why;
  if (!options_.IsValid(&why)) throw Error("contact locator: " + why);
  if (sigma.size() != model.nq)
    throw Error("contact locator: " + std::to_string(sigma.size()) + " noise scales for " +
                std::to_string(model.nq) + " joints");
  for (Eigen::Index j = 0; j < sigma.size(); ++j)
    if (!(sigma[j] > 0) || !std::isfinite(sigma[j]))
      throw Error("contact locator: the noise scale of joint " + std::to_string(j + 1) + " must be positive");
  weight_ = sigma.cwiseInverse();
  JT_.resize(model.nq, 3);
  weighted_residual_.resize(model.nq);
  for (int body = 0; body < model.nq; ++body) {
    candidates_.push_back(candidates(body, kPointsAround));
    coarse_candidates_.push_back(candidates(body, kPointsAroundAtDetection));
  }
  // Meshes that could not be read cost location precision, which the user can fix (a
  // package:// without ROS_PACKAGE_PATH): say so once per process, not once per locator.
  if (const std::string text = model::unread_meshes_warning(model); !text.empty()) {
    static std::mutex mutex;
    static std::set<std::string> said;
    const std::lock_guard<std::mutex> lock(mutex);
    if (said.insert(text).second) warn(text);
  }
}

void Locator::jacobian_transpose(const Kinematics& k, int body, const Eigen::Vector3d& point,
                                 const Eigen::VectorXd& weight, Eigen::MatrixXd& JT) const {
  const auto b = static_cast<std::size_t>(body);
  const Eigen::Vector3d x = k.rotation[b] * point + k.position[b];
  JT.setZero();
  for (std::size_t j = 0; j <= b; ++j) {
    const Eigen::Vector3d column =
        data_.revolute[j] ? Eigen::Vector3d(k.axis[j].cross(x - k.position[j])) : k.axis[j];
    // Row j of W J^T: the weighted lever of joint j.
    JT.row(static_cast<Eigen::Index>(j)) = weight[static_cast<Eigen::Index>(j)] * column.transpose();
  }
}

Eigen::Vector3d Locator::solve_force(const Kinematics& k, const ResidualSample& s, int body,
                                     const Eigen::Vector3d& point, Eigen::Matrix3d* covariance, double* cost) {
  const Eigen::VectorXd& weight = weight_of(s);
  jacobian_transpose(k, body, point, weight, JT_);
  const Eigen::VectorXd y = weight.cwiseProduct(s.r);
  // W r = -W J^T F: least squares through the 3 x 3 normal equations, minimum norm where the
  // joints do not see a direction (their eigenvalues are under the tolerance).
  const Eigen::Matrix3d inverse = pseudo_inverse(JT_.transpose() * JT_);
  const Eigen::Vector3d force = -inverse * (JT_.transpose() * y);
  if (cost) *cost = (y + JT_ * force).squaredNorm();
  if (covariance) *covariance = inverse;
  return force;
}

Locator::Candidates Locator::candidates(int body, int around) const {
  const auto b = static_cast<std::size_t>(body);
  Candidates c;
  const int axial = options_.points_per_link;
  // On the URDF's collision shapes, when all of them could be read (a part of the body's
  // surface would be left out otherwise): as many points as the segment gets, evenly spread.
  const auto& shapes = model_->bodies[b].collision;
  if (const double area = surface_area(shapes); area > 0 && model_->bodies[b].unread_meshes.empty()) {
    c.spacing = std::sqrt(area / (axial * (around + 1)));
    c.points = surface_points(shapes, c.spacing);
    if (!c.points.empty()) return c;
  }
  const Segment& seg = segments_[b];
  const Eigen::Vector3d along = seg.to - seg.from;
  // Two directions across the segment (across the joint axis for a segment of no length).
  const Eigen::Vector3d axis = along.norm() > 1e-9 ? Eigen::Vector3d(along.normalized()) : model_->joints[b].axis;
  const Eigen::Vector3d across = axis.unitOrthogonal(), across2 = axis.cross(across);
  for (int p = 0; p < axial; ++p) {
    const Eigen::Vector3d centre = seg.from + static_cast<double>(p) / (axial - 1) * along;
    c.points.push_back(centre);
    if (options_.link_radius > 0)
      for (int a = 0; a < around; ++a) {
        const double angle = 2 * M_PI * a / around;
        c.points.push_back(centre + options_.link_radius * (std::cos(angle) * across + std::sin(angle) * across2));
      }
  }
  c.spacing = std::max(along.norm() / (axial - 1), options_.link_radius * 2 * std::sin(M_PI / around));
  return c;
}

double Locator::point_cost(const std::vector<Kinematics>& kin, const std::vector<const ResidualSample*>& fit, int body,
                           const Eigen::Vector3d& point, std::vector<Eigen::VectorXd>* misfits) {
  // Alternating least squares from the principal direction of the per-sample forces: the
  // magnitudes for the direction (one division each), then the direction for the magnitudes
  // (a 3 x 3 system). A handful of rounds settle it: the start is already the direction of
  // the strongest samples. Each sample enters through its normal equations only (A = W J^T:
  // A^T A, A^T W r and |W r|^2), so a round costs a few 3 x 3 products per sample.
  constexpr int kRounds = 4;
  const std::size_t n = fit.size();
  normals_.resize(n);
  projections_.resize(n);
  squares_.resize(n);
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::VectorXd& weight = weight_of(*fit[i]);
    jacobian_transpose(kin[i], body, point, weight, JT_);
    weighted_residual_ = weight.cwiseProduct(fit[i]->r);  // sized once: no allocation per point
    normals_[i].noalias() = JT_.transpose() * JT_;  // noalias: no temporary for the product
    projections_[i].noalias() = JT_.transpose() * weighted_residual_;
    squares_[i] = weighted_residual_.squaredNorm();
    const Eigen::Vector3d force = -pseudo_inverse(normals_[i]) * projections_[i];
    scatter += force * force.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
  eigen.computeDirect(scatter);
  Eigen::Vector3d direction = eigen.eigenvectors().col(2);
  double cost = 0;
  for (int round = 0;; ++round) {
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    cost = 0;
    for (std::size_t i = 0; i < n; ++i) {
      // |A u|^2 and (A u) . W r: the residual of a unit force along the direction.
      const double lever2 = direction.dot(normals_[i] * direction);
      const double along = direction.dot(projections_[i]);
      const double magnitude = lever2 > 0 ? -along / lever2 : 0.0;
      cost += squares_[i] + magnitude * along;  // |W r + m A u|^2 at the best m
      normal += magnitude * magnitude * normals_[i];
      rhs -= magnitude * projections_[i];
    }
    if (round + 1 == kRounds) break;
    const Eigen::Vector3d next = pseudo_inverse(normal) * rhs;
    if (!(next.norm() > 0)) break;
    direction = next.normalized();
  }
  if (misfits) {
    misfits->resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::VectorXd& weight = weight_of(*fit[i]);
      jacobian_transpose(kin[i], body, point, weight, JT_);
      const double lever2 = direction.dot(normals_[i] * direction);
      const double magnitude = lever2 > 0 ? -direction.dot(projections_[i]) / lever2 : 0.0;
      (*misfits)[i] = weight.cwiseProduct(fit[i]->r) + magnitude * (JT_ * direction);
    }
  }
  return std::max(0.0, cost);
}

double dependence_factor(const std::vector<Eigen::VectorXd>& misfits) {
  // An AR(1) reading of their dependence: n samples weigh as n (1 - rho) / (1 + rho)
  // independent ones, at least one.
  const std::size_t n = misfits.size();
  if (n < 3) return 1;
  double lagged = 0, total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    total += misfits[i].squaredNorm();
    if (i + 1 < n) lagged += misfits[i].dot(misfits[i + 1]);
  }
  if (!(total > 0)) return 1;
  const double rho = std::clamp(lagged / total, 0.0, 1.0);
  return std::min((1 + rho) / std::max(1 - rho, 1e-12), static_cast<double>(n));
}

void candidate_probabilities(std::vector<CandidateFit>& candidates, double observations, double noise_scale,
                             double temperature) {
  if (candidates.empty()) return;
  // Log evidence per body: -cost / (2 s) - unknowns / 2 log n, then normalised (the largest
  // first subtracted so that the exponentials do not underflow together).
  std::vector<double> log_evidence(candidates.size());
  double best = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const int unknowns = candidates[i].unknowns - (candidates[i].point_unknown ? 1 : 0);
    log_evidence[i] = (-0.5 * candidates[i].cost / noise_scale - 0.5 * unknowns * std::log(std::max(observations, 1.0))) /
                          temperature +
                      candidates[i].log_point_share;
    best = std::max(best, log_evidence[i]);
  }
  double sum = 0;
  for (std::size_t i = 0; i < candidates.size(); ++i) sum += candidates[i].probability = std::exp(log_evidence[i] - best);
  for (auto& c : candidates) c.probability /= sum;
}

LinkSet link_set(const std::vector<CandidateFit>& candidates, double confidence, int chosen) {
  std::vector<const CandidateFit*> order;
  for (const auto& c : candidates) order.push_back(&c);
  std::stable_sort(order.begin(), order.end(), [chosen](const CandidateFit* a, const CandidateFit* b) {
    if ((a->link == chosen) != (b->link == chosen)) return a->link == chosen;
    return a->probability > b->probability || (a->probability == b->probability && a->link < b->link);
  });
  LinkSet set;
  // The last link is taken even when rounding leaves the sum a hair under the confidence.
  for (const CandidateFit* c : order) {
    if (set.probability >= confidence * (1 - 1e-12)) break;
    set.links.push_back(c->link);
    set.probability += c->probability;
  }
  std::sort(set.links.begin(), set.links.end());
  return set;
}

Location Locator::locate(std::span<const ResidualSample> samples, int first_link, int signature_link,
                         LinkChoice choice) {
  Location out;
  const int nq = model_->nq;
  first_link = std::max(first_link, 1);
  if (samples.empty() || first_link > nq) return out;

  // The strongest samples carry the contact; evenly chosen among those of at least half the peak.
  std::vector<double> strength(samples.size());
  std::size_t strongest = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    strength[i] = weight_of(samples[i]).cwiseProduct(samples[i].r).norm();
    if (strength[i] > strength[strongest]) strongest = i;
  }
  // Before and after the peak: a held push has most of its rows after it, and each row brings
  // noise of its own to average. (Up to the peak only, for fear of the arm's reaction after it:
  // on the MuJoCo UR5 campaigns crosswise 49 of 78 links right against 52 with, on the suite's
  // campaigns 312 of 358 against 313.)
  std::vector<std::size_t> strong;
  for (std::size_t i = 0; i < samples.size(); ++i)
    if (strength[i] >= 0.5 * strength[strongest]) strong.push_back(i);
  std::vector<const ResidualSample*> fit;
  const auto limit = static_cast<std::size_t>(options_.max_fit_samples);
  if (strong.size() <= limit) {
    for (std::size_t i : strong) fit.push_back(&samples[i]);
  } else {
    for (std::size_t k = 0; k < limit; ++k) fit.push_back(&samples[strong[k * (strong.size() - 1) / (limit - 1 ? limit - 1 : 1)]]);
  }

  auto kinematics = [&](const ResidualSample& s) {
    model::forward_kinematics(*model_, data_, s.q);
    return Kinematics{data_.rotation, data_.position, data_.axis};
  };
  std::vector<Kinematics> kin;
  kin.reserve(fit.size());
  for (const ResidualSample* s : fit) kin.push_back(kinematics(*s));

  // Best point per candidate body: its cost at every candidate point.
  struct BodyFit {
    int body = 0;
    double cost = 0;
    int unknowns = 0;
    const std::vector<Eigen::Vector3d>* points = nullptr;  // the body's candidates, made once
    std::vector<double> costs;
    std::size_t best = 0;
  };
  const std::vector<Candidates>& pool = choice == LinkChoice::best_fit ? coarse_candidates_ : candidates_;
  std::vector<BodyFit> fits;
  auto fit_bodies = [&] {
    fits.clear();
    for (int body = first_link - 1; body < nq; ++body) {
      // Beyond first_link, only the signature's link and bodies that fewer than all 3 force
      // components reach through every joint: one that sees every joint with as many components
      // as joints explains each row's residual exactly with a direction of the row's own. With
      // one direction for the contact it could be refuted, but taking such bodies in took the
      // paper arm's isolation at 125 Hz from 28 to 23 of 30: the calibrated thresholds (the
      // signature) name them.
      if (body > first_link - 1 && body + 1 != signature_link && seen_unknowns(body) >= nq) continue;
      BodyFit f;
      f.body = body;
      f.points = &pool[static_cast<std::size_t>(body)].points;
      f.costs.resize(f.points->size());
      for (std::size_t p = 0; p < f.points->size(); ++p) {
        f.costs[p] = point_cost(kin, fit, body, (*f.points)[p]);
        if (f.costs[p] < f.costs[f.best]) f.best = p;
      }
      f.cost = f.costs[f.best];
      // A magnitude per sample, the direction within what the joints see, the point along the link.
      f.unknowns = static_cast<int>(fit.size()) + seen_unknowns(body) - 1 + (body + 1 >= 4 ? 1 : 0);
      fits.push_back(std::move(f));
    }
  };
  fit_bodies();

  // The calibrated noise is that of free motion. A contact's reaction (the arm brakes, backs off)
  // brings the model's errors in accelerations that free motion does not reach, joint by joint:
  // on the MuJoCo UR5's obstacle collisions, every body fitted left 30 to 70 times its
  // calibrated noise on joint 5, and the costs' common scale then drowned what joints 1 to 3
  // told. What no candidate body explains on a joint is that joint's noise in this event: its
  // least mean square weighted misfit over the bodies (at least 1, the calibrated noise) scales
  // the joint's variance, and the bodies are fitted again. Not at detection: its window holds
  // the rise, before most of the reaction, and the identified row is awaited live.
  std::vector<ResidualSample> reweighted;
  if (choice != LinkChoice::best_fit && fit.size() > 1 && !fits.empty()) {
    Eigen::VectorXd inflation = Eigen::VectorXd::Constant(nq, std::numeric_limits<double>::infinity());
    std::vector<Eigen::VectorXd> body_misfits;
    for (const BodyFit& g : fits) {
      point_cost(kin, fit, g.body, (*g.points)[g.best], &body_misfits);
      Eigen::VectorXd squares = Eigen::VectorXd::Zero(nq);
      for (const Eigen::VectorXd& m : body_misfits) squares += m.cwiseAbs2();
      inflation = inflation.cwiseMin(squares / static_cast<double>(fit.size()));
    }
    inflation = inflation.cwiseMax(1.0);
    if (inflation.maxCoeff() > 1) {
      const Eigen::VectorXd divisor = inflation.cwiseSqrt();
      reweighted.reserve(fit.size());
      for (const ResidualSample* s : fit) {
        reweighted.push_back(*s);
        reweighted.back().weight = weight_of(*s).cwiseQuotient(divisor);
      }
      for (std::size_t i = 0; i < fit.size(); ++i) fit[i] = &reweighted[i];
      fit_bodies();
    }
  }

  // The noise scale of the costs: the best fit per degree of freedom among the bodies that have
  // any left, never below the weights' own scale. (Not the most distal body's: with a force of
  // one direction it no longer explains a more proximal contact.)
  double scale = std::numeric_limits<double>::infinity();
  for (const BodyFit& g : fits)
    if (const double dof = static_cast<double>(fit.size()) * nq - g.unknowns; dof > 0)
      scale = std::min(scale, g.cost / dof);
  scale = std::isfinite(scale) ? std::max(1.0, scale) : 1.0;
  std::size_t chosen = 0;
  double best_score = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < fits.size(); ++i) {
    const double score = fits[i].cost + options_.penalty_per_unknown * scale * fits[i].unknowns;
    if (score < best_score) best_score = score, chosen = i;  // ties: the more proximal body
  }
  // The likelihood is tempered by the dependence of what the best fit leaves along the samples
  // (dependence_factor), on top of the temperature a labelled campaign taught.
  std::vector<Eigen::VectorXd> misfits;
  point_cost(kin, fit, fits[chosen].body, (*fits[chosen].points)[fits[chosen].best], &misfits);
  const double temperature = options_.link_temperature * dependence_factor(misfits);
  out.temperature = temperature;
  if (choice == LinkChoice::proximal_accepted)
    for (std::size_t i = 0; i < fits.size(); ++i) {
      const double dof = static_cast<double>(fit.size()) * nq - fits[i].unknowns;
      // Refuted too by a more distal body that explains the residuals better than its few extra
      // unknowns (at least one: the other body's geometry) could by chance: a likelihood-ratio
      // test at the same level.
      bool beaten = false;
      for (std::size_t j = i + 1; j < fits.size() && !beaten; ++j) {
        const int extra = std::max(1, fits[j].unknowns - fits[i].unknowns);
        beaten = fits[i].cost - fits[j].cost > chi_square_quantile(extra, options_.proximal_alpha);
      }
      if (dof > 0 && !beaten && fits[i].cost <= chi_square_quantile(dof, options_.proximal_alpha)) {
        chosen = i;
        break;
      }
    }
  for (const BodyFit& g : fits) {
    CandidateFit c{g.body + 1, g.cost, g.unknowns, g.body + 1 >= 4, 0.0, 0.0};
    if (c.point_unknown) {
      // ln mean exp(-(cost_p - cost) / 2sT): the best point contributes 1, so no underflow.
      double share = 0;
      for (double cost : g.costs) share += std::exp(-0.5 * (cost - g.cost) / (scale * temperature));
      c.log_point_share = std::log(share / static_cast<double>(g.costs.size()));
    }
    out.candidates.push_back(c);
  }
  candidate_probabilities(out.candidates, static_cast<double>(fit.size()) * nq, scale, temperature);
  if (choice == LinkChoice::most_probable) {
    chosen = 0;
    for (std::size_t i = 1; i < fits.size(); ++i)
      if (out.candidates[i].probability > out.candidates[chosen].probability) chosen = i;  // ties: proximal
  }
  out.noise_scale = scale;
  const BodyFit& f = fits[chosen];
  const Segment& seg = segments_[static_cast<std::size_t>(f.body)];
  out.link = f.body + 1;
  out.force_determined = f.body + 1 >= 3;
  out.point_determined = f.body + 1 >= 4;
  const double dof = static_cast<double>(fit.size()) * nq - f.unknowns;
  out.chi2 = dof > 0 ? f.cost / dof : 0;
  if (out.point_determined) {
    out.point = (*f.points)[f.best];
    // The points whose cost is within one (scaled) unit of the best: their largest distance
    // from it is a 68% radius; at least half the spacing of the candidates.
    double spread = 0.5 * pool[static_cast<std::size_t>(f.body)].spacing;
    for (std::size_t p = 0; p < f.points->size(); ++p)
      if (f.costs[p] <= f.cost + scale) spread = std::max(spread, ((*f.points)[p] - out.point).norm());
    out.point_sd = spread;
  } else {
    out.point = 0.5 * (seg.from + seg.to);
    out.point_sd = 0.5 * (seg.to - seg.from).norm() + options_.link_radius;
  }

  // Force on every sample at the chosen point: the peak and the impulse, from the disturbance
  // with the observer's lag undone where the samples carry it; the strongest sample's force
  // with its uncertainty, from the residual the fit weighed.
  double previous_t = 0, previous_norm = 0;
  std::size_t peak = 0;
  ResidualSample undone;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Kinematics k = kinematics(samples[i]);
    Eigen::Matrix3d covariance;
    const Eigen::Vector3d force = solve_force(k, samples[i], f.body, out.point, &covariance, nullptr);
    double norm = force.norm();
    if (i == strongest) {
      out.force = force;
      out.force_norm = norm;
      out.force_sd = norm_sd(force, covariance, scale);
    }
    if (samples[i].tau.size() == samples[i].r.size())
      norm = solve_force(k, disturbance(samples[i], undone), f.body, out.point, nullptr, nullptr).norm();
    if (norm > out.peak_force) out.peak_force = norm, out.t_peak = samples[i].t, peak = i;
    if (i > 0) out.impulse += 0.5 * (norm + previous_norm) * (samples[i].t - previous_t);
    previous_t = samples[i].t;
    previous_norm = norm;
  }

  // The peak force's uncertainty, at the peak sample: its noise and, in quadrature, the
  // deviation from the reported force that holds 68.3% of the forces at the body's points, each
  // by its share of the body's likelihood (CandidateFit::log_point_share's terms), or evenly
  // over the body when the joints do not determine the point (the middle is reported then).
  // The lever arm's uncertainty, not the noise, is what dominates a contact's force error: on
  // the MuJoCo UR5 campaigns the noise alone covered 7 of 48 errors. A deviation rather than a
  // spread, since points near a joint's axis have forces without bound. The reported body's
  // alone: mixing in the other candidate bodies by their probability covered 42 of 48 (87.5%)
  // where 68% is stated, since what the joints cannot tell apart is already in the link set.
  if (!samples.empty()) {
    const Kinematics k = kinematics(samples[peak]);
    const ResidualSample& at_peak = disturbance(samples[peak], undone);
    Eigen::Matrix3d covariance;
    const Eigen::Vector3d force = solve_force(k, at_peak, f.body, out.point, &covariance, nullptr);
    std::vector<std::pair<double, double>> deviations;  // |force - peak_force|, weight
    double total = 0;
    for (std::size_t p = 0; p < f.points->size(); ++p) {
      const double weight =
          out.point_determined ? std::exp(-0.5 * (f.costs[p] - f.cost) / (scale * temperature)) : 1.0;
      const double norm = solve_force(k, at_peak, f.body, (*f.points)[p], nullptr, nullptr).norm();
      deviations.emplace_back(std::abs(norm - out.peak_force), weight);
      total += weight;
    }
    std::sort(deviations.begin(), deviations.end());
    double mass = 0, within = 0;
    for (const auto& [deviation, weight] : deviations)
      if ((mass += weight) >= kOneSigmaMass * total) {
        within = deviation;
        break;
      }
    out.peak_force_sd = std::hypot(norm_sd(force, covariance, scale), within);
  }
  return out;
}

}  // namespace momentum::contact
