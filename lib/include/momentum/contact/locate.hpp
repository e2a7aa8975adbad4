#pragma once
// Contact identification: after the detector has seen a contact, where on the arm it acts and
// with what force, from the residuals and the chain's Jacobians alone (no force sensor).
//
// A contact force F (world frame, N, the force on the robot) at a point p of body b moves the
// residuals of joints 1..b by r = -J_p(q)^T F (the sign of the disturbance torque tau_d in the
// design notes), and leaves the joints after b untouched. For every candidate point the best
// force is a weighted linear least-squares problem; the point is searched on the links'
// geometry: the segment from each body's joint to the next joint (to the tip frame for the last
// body), the skeleton a URDF without collision shapes still gives, and a cylinder of a given
// radius around it (a force on a wrist link turns that link's own joint only through its
// lever off the axis). Several samples of the same
// contact (the arm moves, the force grows and fades, the point stays) sharpen the point. The
// samples share the point and the force's direction (the contact's normal, tilted within its
// friction cone, turns little while the contact is strong); each has a magnitude
// of its own. That is the physics of a contact and not of the model's errors, which the
// controller's reaction to the contact spreads over the other joints with a pattern that
// changes from sample to sample: a body that fits a sample's residuals only by absorbing those
// errors with a force of a new direction each sample no longer fits. (On 13 campaigns of 30
// contacts, 3 simulated arms at 2 rates and 2 seeds and the MuJoCo UR5, isolation went from
// 310 to 324 of 386 with it and the likelihood-ratio test of LinkChoice::proximal_accepted,
// and at detection from 191 to 216.)
//
// The weights are the calibrated noise of free motion, but a contact's reaction brings the
// model's errors in accelerations free motion does not reach: what no candidate body explains on
// a joint is taken as that joint's noise in the event (Locator::locate fits twice).
//
// What the joints cannot see is said, not guessed: a force on body b has 3 unknowns and the
// point 1 more, but only joints 1..b see it. Below 3 joints the force is known only along the
// directions those joints see (the minimum-norm solution is given); below 4 the point anywhere
// on the link explains the residuals equally well (the point is then the segment's middle, its
// uncertainty the half-length, and `point_determined` false).
//
// Units: s, m, N, Nm; point in the body frame (the frame of the joint that moves the body).

#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "momentum/model/dynamics.hpp"
#include "momentum/model/model.hpp"

namespace momentum::contact {

// The segment of body `body` (0-based) searched for contact points, in the body frame, m.
struct Segment {
  int body = 0;
  Eigen::Vector3d from = Eigen::Vector3d::Zero();  // the body's joint origin
  Eigen::Vector3d to = Eigen::Vector3d::Zero();    // the next joint's origin, or the tip frame
};

// One segment per body of `model`, in body order.
std::vector<Segment> link_segments(const model::Model& model);

// Points about `spacing` apart (m) on the surfaces of `shapes` (a body's collision shapes), in
// the body frame: grids on boxes' faces and cylinders' sides and caps, a Fibonacci lattice on
// spheres, meshes sampled in proportion to their triangles' areas (each point a triangle's
// centroid). `spacing` > 0.
std::vector<Eigen::Vector3d> surface_points(const std::vector<model::CollisionShape>& shapes, double spacing);

// The surface area of `shapes`, m^2 (meshes: the sum of their triangles' areas).
double surface_area(const std::vector<model::CollisionShape>& shapes);

// One residual sample of a contact: time (s), joint positions q (nq, rad or m), the residual
// minus its level before the contact (nq, Nm or N), and optionally the weight of each joint's
// residual on this row (nq, 1/Nm: a joint near standstill, where friction flips, is trusted
// less than a moving one); empty: the locator's.
struct ResidualSample {
  double t = 0;
  Eigen::VectorXd q;
  Eigen::VectorXd r;
  Eigen::VectorXd weight;
  // The disturbance torque with the observer's lag undone, minus the same level (nq), or empty
  // when the observer is not known (ContactWindow::undo_first_order_lag): what the peak force
  // and the impulse are taken from.
  Eigen::VectorXd tau;
  // The weights of tau (nq, with tau): `weight` over tau's noise gain per joint,
  // (1 - a) / sqrt(1 + a^2) for a = exp(-K1 span), the undoing's amplification of a noise
  // that is independent at the two rows it reads (the residual's own correlation over that
  // span makes it smaller: the sd stated from it errs on the wide side).
  Eigen::VectorXd tau_weight;
};

struct LocatorOptions {
  // Candidate points per segment, evenly spaced from its joint to its end, >= 2.
  int points_per_link = 21;
  // Radius of the links' cylinders, m (>= 0; 0: the segments only). Each axial position adds
  // 16 points around it (8 for LinkChoice::best_fit). A cobot's links are about 0.05 m (mo-sim's default too).
  double link_radius = 0.05;
  // Most samples used in one fit (evenly chosen among those of at least half the peak, before
  // and after it), >= 1.
  int max_fit_samples = 24;
  // A more distal body is chosen over the most proximal candidate only when its weighted cost
  // is lower by more than this per extra unknown (the fit's own noise scale; a likelihood-ratio
  // criterion: 2 is Akaike's), > 0.
  double penalty_per_unknown = 2.0;
  // LinkChoice::proximal_accepted: the level at which a candidate body's weighted cost is
  // refuted as more than the calibrated noise (chi-square on its degrees of freedom), (0, 0.5).
  double proximal_alpha = 0.001;
  // The confidence the reported link set reaches (link_set), (0, 1].
  double link_confidence = 0.9;
  // The temperature of the candidates' probabilities, > 0: the log evidence of each body is
  // divided by it times the dependence the contact's own misfits show (dependence_factor;
  // together Location::temperature). The residuals of the samples of one contact are not
  // independent (the observer's low pass, the model's errors that the arm's motion and
  // reaction make smooth), so the Gaussian likelihood of white noise overstates what they
  // tell; 1 leaves the misfits' dependence alone to temper it, a larger value is what a
  // labelled campaign shows beyond it (mo-calibrate --classes:
  // thresholds.<signal>.identify.link_temperature).
  double link_temperature = 1;
  // The gains K1 (1/s, one or one per joint) of the first-order observer that made the
  // residuals, whose lag the peak force and the impulse undo (ContactWindow::
  // undo_first_order_lag); empty: taken from the residuals as they are (another observer).
  std::vector<double> observer_k1;
  bool IsValid(std::string* why) const;
};

// How Locator::locate chooses the body among its candidates.
enum class LinkChoice {
  // The least weighted cost, penalised per unknown (LocatorOptions::penalty_per_unknown). For
  // few samples (at detection), where no candidate can be refuted yet.
  best_fit,
  // The most proximal candidate whose cost the calibrated noise accepts at
  // LocatorOptions::proximal_alpha and that no more distal candidate beats by more than its
  // extra unknowns (at least 1) explain by chance at the same level (a likelihood-ratio test),
  // else best_fit's. A rule for a whole contact (mo-detect's before most_probable): a contact
  // puts no torque on the joints beyond its link, and a more distal body that fits only a
  // little better, by absorbing the model's small errors on those joints, is not evidence of a
  // more distal contact; one that fits much better with a direction and a point of its own is.
  proximal_accepted,
  // The body of the highest probability (CandidateFit::probability; ties: the more proximal):
  // the link that the probabilities stated beside it favour. For a whole contact (mo-detect's
  // end rows). Against proximal_accepted, learnt on neither campaign: isolation on the MuJoCo
  // UR5 campaigns 18 -> 19 of 30 and 21 -> 33 of 48 (each with the other's class rule), on
  // the suite's own (seeds 6, 7) at 125 Hz paper arm 28 -> 28 of 30, UR5 22 -> 23 of 29,
  // Panda 26 -> 26 of 30, at 1 kHz 30 -> 30, 22 -> 21, 26 -> 26; on the UR10e log link4 the
  // third push goes to link 4 (was 5).
  most_probable,
};

// One candidate body's best fit: its weighted residual sum of squares at its best point (in
// units of the calibrated noise) and its unknowns (a magnitude per sample, the direction, the
// point).
struct CandidateFit {
  int link = 0;  // 1..nq
  double cost = 0;
  int unknowns = 0;
  // Whether the point along the body is one of `unknowns` (>= 4 joints see the body), and then
  // ln of the mean over the body's candidate points of their likelihood relative to the best
  // point's, exp(-(cost_p - cost) / (2 s T)) (<= 0): the share of the body's surface that
  // explains the residuals, the point's Occam factor under a uniform prior on the surface.
  bool point_unknown = false;
  double log_point_share = 0;
  // Posterior probability that the contact is on this body, among the candidates (they sum to
  // 1), with equal priors: the residuals' Gaussian likelihood at the body's best fit,
  // exp(-cost / (2 s)) with s the fit's noise scale (Location::noise_scale), times
  // n^(-k / 2) for the body's unknowns k other than the point over the n residual values
  // fitted (Schwarz's approximation of the marginal likelihood: a body with more freedom must
  // fit better by more than its freedom buys), both to the power 1 / T (the temperature,
  // LocatorOptions::link_temperature), times the point's share (log_point_share).
  double probability = 0;
};

// What one fit found. `link` 0 when nothing could be fitted (no sample, or no candidate body).
struct Location {
  int link = 0;                                      // body 1..nq of the best point
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   // in that body's frame, m
  double point_sd = 0;                               // m, spread of the points that fit within one unit
  bool point_determined = false;                     // >= 4 joints see the body
  bool force_determined = false;                     // >= 3 joints see the body
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   // world, N, at the strongest sample
  double force_norm = 0;                             // |force|, N
  double force_sd = 0;                               // sd of |force|, N
  double peak_force = 0;                             // largest |force| over all samples, N
  // sd of peak_force, N: the noise of the peak sample's force and, in quadrature, the deviation
  // from peak_force that holds 68.3% of the peak sample's forces at the body's points, each by
  // its share of the body's likelihood (evenly over the body when the joints do not determine
  // the point). Not the other candidate bodies (`candidates` states those), nor the component
  // a body seen by fewer than 3 joints hides (a partial force is the least that explains the
  // residuals).
  double peak_force_sd = 0;
  double t_peak = 0;                                 // s, time of that sample
  double impulse = 0;                                // integral of |force| over the samples, N s
  double chi2 = 0;                                   // weighted residual sum of squares per degree of freedom
  double noise_scale = 1;                            // the costs' variance scale (>= 1, in calibrated noise units^2)
  // The temperature of the candidates' probabilities: LocatorOptions::link_temperature times
  // the dependence of the best fit's misfits along the samples (dependence_factor), >= 1.
  double temperature = 1;
  std::vector<CandidateFit> candidates;              // every body fitted, proximal first
};

// How many times fewer independent samples `misfits` (one vector per sample, in order) are
// worth than their count: (1 + rho) / (1 - rho) for rho the lag-1 correlation of the vectors
// (sum of m_i . m_i+1 over sum of |m_i|^2), clamped to [0, 1), at most their count. 1 for
// fewer than 3 samples or all zero. The samples of one contact are not independent draws of
// the calibrated noise: what a fit leaves (the model's errors in the arm's motion and in its
// reaction, smoothed by the observer) runs on from sample to sample, and the white-noise
// likelihood would state links with a confidence the data do not hold.
double dependence_factor(const std::vector<Eigen::VectorXd>& misfits);

// The smallest set of candidate links that holds `chosen` (the reported link; 0: none) and
// whose probabilities (CandidateFit::probability) sum to at least `confidence` (0 < confidence
// <= 1): `chosen`, then the others most probable first (ties: the more proximal), and that
// sum. Empty (sum 0) without candidates.
struct LinkSet {
  std::vector<int> links;   // 1..nq, ascending
  double probability = 0;   // their summed probability
};
LinkSet link_set(const std::vector<CandidateFit>& candidates, double confidence, int chosen = 0);

// CandidateFit::probability from the costs and unknowns of `candidates` over `observations`
// residual values, with the costs' variance scale `noise_scale` (> 0) and the temperature
// `temperature` (> 0, Location::temperature). Exposed for tests.
void candidate_probabilities(std::vector<CandidateFit>& candidates, double observations, double noise_scale,
                             double temperature = 1);

// Finds contact points and forces on one model. Read-only after construction except for its
// scratch; one per thread.
class Locator {
 public:
  // `sigma` (nq, > 0): the residual noise scale per joint (Nm), the weights of the least
  // squares. Throws momentum::Error when the options are invalid or sigma has the wrong size or
  // a non-positive entry.
  Locator(const model::Model& model, Eigen::VectorXd sigma, LocatorOptions options = {});

  // Fits the samples of one contact (time order) with candidate bodies first_link (1-based; the
  // most distal joint that fired at detection, since no joint beyond the contact's body can feel
  // it), signature_link (the most distal joint that fired by now, when different) and, beyond
  // first_link, every body whose fit keeps a degree of freedom (fewer force components than
  // joints: a body whose force explains every joint's residual exactly cannot be refuted by
  // the residuals, only by the calibrated thresholds, i.e. the signature). `choice`: how the
  // body is chosen among the candidates (LinkChoice).
  Location locate(std::span<const ResidualSample> samples, int first_link, int signature_link = 0,
                  LinkChoice choice = LinkChoice::best_fit);

 private:
  struct Kinematics {
    std::vector<Eigen::Matrix3d> rotation;
    std::vector<Eigen::Vector3d> position, axis;
  };
  // Candidate points of body `body`, its frame, and their spacing (m): on its collision shapes
  // where the URDF gives some and every one could be read, else on the segment's cylinder;
  // `around`: the points around each axial position (on shapes: the same density).
  struct Candidates {
    std::vector<Eigen::Vector3d> points;
    double spacing = 0;
  };
  Candidates candidates(int body, int around) const;
  void jacobian_transpose(const Kinematics& k, int body, const Eigen::Vector3d& point, const Eigen::VectorXd& weight,
                          Eigen::MatrixXd& JT) const;
  const Eigen::VectorXd& weight_of(const ResidualSample& s) const { return s.weight.size() ? s.weight : weight_; }
  // Weighted residual sum of squares at one point of the best forces of one direction (world)
  // and a magnitude per sample of `fit`; with `misfits`, also each sample's weighted misfit
  // W r + W J^T F (nq).
  double point_cost(const std::vector<Kinematics>& kin, const std::vector<const ResidualSample*>& fit, int body,
                    const Eigen::Vector3d& point, std::vector<Eigen::VectorXd>* misfits = nullptr);
  Eigen::Vector3d solve_force(const Kinematics& k, const ResidualSample& s, int body, const Eigen::Vector3d& point,
                              Eigen::Matrix3d* covariance, double* cost);

  const model::Model* model_;
  model::Data data_;
  Eigen::VectorXd weight_;  // 1 / sigma
  LocatorOptions options_;
  std::vector<Segment> segments_;
  std::vector<Candidates> candidates_;         // per body, made once
  std::vector<Candidates> coarse_candidates_;  // the same, half as dense around, for LinkChoice::best_fit
  Eigen::MatrixXd JT_;
  // point_cost's scratch, per sample, with A = W J^T: A^T A, A^T W r and |W r|^2.
  std::vector<Eigen::Matrix3d> normals_;
  std::vector<Eigen::Vector3d> projections_;
  std::vector<double> squares_;
  Eigen::VectorXd weighted_residual_;  // W r of one sample
};

}  // namespace momentum::contact
