// Trajectories, contact campaigns, sensors and whole runs: closed forms (the paper's sine,
// quintic boundary conditions), finite differences, counting, and reproducibility.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <vector>

#include "momentum/model/dynamics.hpp"
#include "momentum/sim/run.hpp"
#include "paper_arm.hpp"

namespace momentum::sim {
namespace {

using Eigen::VectorXd;

TEST(Trajectory, PaperIsTheSineBetweenQuinticBlendsFromAndToRest) {
  auto arm = testing::paper_arm();
  TrajectoryOptions o;
  o.duration = 12.0;
  Trajectory trajectory(o, arm.model, arm.section.home, 1);
  VectorXd q, dq, ddq;
  const double w = 2 * std::numbers::pi * 0.2;
  for (double t = 1.0; t < 11.0; t += 0.137) {
    trajectory.evaluate(t, q, dq, ddq);
    for (int j = 0; j < 3; ++j) {
      EXPECT_NEAR(q[j], arm.section.home[j] + 0.6 * std::sin(w * (t - 1.0)), 1e-12);
      EXPECT_NEAR(dq[j], 0.6 * w * std::cos(w * (t - 1.0)), 1e-12);
      EXPECT_NEAR(ddq[j], -0.6 * w * w * std::sin(w * (t - 1.0)), 1e-12);
    }
  }
  // At rest at both ends; continuous in q, dq, ddq across the blend boundaries.
  for (double t : {0.0, 12.0, 13.0}) {
    trajectory.evaluate(t, q, dq, ddq);
    EXPECT_LT(dq.norm() + ddq.norm(), 1e-12) << t;
  }
  VectorXd q1, dq1, ddq1;
  for (double t : {1.0, 11.0}) {
    trajectory.evaluate(t - 1e-9, q, dq, ddq);
    trajectory.evaluate(t + 1e-9, q1, dq1, ddq1);
    EXPECT_LT((q - q1).norm(), 1e-8);
    EXPECT_LT((dq - dq1).norm(), 1e-7);
    EXPECT_LT((ddq - ddq1).norm(), 1e-6);
  }
  EXPECT_EQ(trajectory.steady_begin(), 1.0);
  EXPECT_EQ(trajectory.steady_end(), 11.0);
}

// dq and ddq are the derivatives of q for every kind (central differences), and every pose
// is within the joint limits.
TEST(Trajectory, VelocitiesAndAccelerationsAreDerivativesAndLimitsHold) {
  auto arm = testing::paper_arm();
  for (auto kind : {TrajectoryKind::paper, TrajectoryKind::multisine, TrajectoryKind::ptp, TrajectoryKind::hold}) {
    TrajectoryOptions o;
    o.kind = kind;
    o.duration = 40.0;
    Trajectory trajectory(o, arm.model, arm.section.home, 5);
    VectorXd q, dq, ddq, qa, dqa, ddqa, qb, dqb, ddqb;
    const double e = 1e-5;
    bool moved = false;
    for (double t = 0.01; t < 40.0; t += 0.0731) {
      trajectory.evaluate(t - e, qa, dqa, ddqa);
      trajectory.evaluate(t, q, dq, ddq);
      trajectory.evaluate(t + e, qb, dqb, ddqb);
      EXPECT_LT(((qb - qa) / (2 * e) - dq).norm(), 1e-6) << trajectory_name(kind) << " t = " << t;
      EXPECT_LT(((dqb - dqa) / (2 * e) - ddq).norm(), 1e-5) << trajectory_name(kind) << " t = " << t;
      for (int j = 0; j < 3; ++j) {
        EXPECT_GE(q[j], arm.model.joints[j].limits.lower);
        EXPECT_LE(q[j], arm.model.joints[j].limits.upper);
      }
      moved = moved || dq.norm() > 0.1;
    }
    EXPECT_EQ(moved, kind != TrajectoryKind::hold) << trajectory_name(kind);
  }
}

TEST(Trajectory, RefusesMotionOutsideTheLimits) {
  auto arm = testing::paper_arm();
  TrajectoryOptions o;
  o.amplitude = 2.0;  // the shoulder at 0.7 +- 2 leaves [-2.09, 2.09]
  EXPECT_THROW(Trajectory(o, arm.model, arm.section.home, 1), Error);
  o.amplitude = 0.6;
  o.duration = 1.5;  // shorter than the two blends
  EXPECT_THROW(Trajectory(o, arm.model, arm.section.home, 1), Error);
}

TEST(Contacts, CampaignRespectsSpacingLinksAndWindow) {
  auto arm = testing::paper_arm();
  ContactOptions o;
  o.count = 50;
  o.min_spacing = 2.0;
  o.clamp_fraction = 0.2;
  const auto contacts = plan_contacts(o, arm.model, 2.0, 400.0, 9);
  ASSERT_EQ(contacts.size(), 50u);
  int clamps = 0, on_link[4] = {0, 0, 0, 0};
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    const auto& c = contacts[k];
    EXPECT_GE(c.t_onset, 2.0);
    EXPECT_LE(c.t_end, 400.0);
    EXPECT_LE(c.t_onset, c.t_rise_end);
    EXPECT_LE(c.t_rise_end, c.t_hold_end);
    EXPECT_LT(c.t_hold_end, c.t_end);
    EXPECT_GE(c.peak, 30.0);
    EXPECT_LE(c.peak, 150.0);
    if (k > 0) {
      EXPECT_GE(c.t_onset - contacts[k - 1].t_end, 2.0 - 1e-9);
    }
    ASSERT_GE(c.link, 2);  // default: the distal links 2..n
    ASSERT_LE(c.link, 3);
    ++on_link[c.link];
    clamps += c.clamp;
    // The point lies on the link's cylinder (radius 0.05 m around the segment to the next joint).
    const Eigen::Vector3d axis = c.link == 3 ? arm.model.tip_placement.translation
                                             : arm.model.joints[c.link].placement.translation;
    const Eigen::Vector3d e = axis.normalized();
    const double along = c.point.dot(e);
    EXPECT_GE(along, -1e-12);
    EXPECT_LE(along, axis.norm() + 1e-12);
    EXPECT_NEAR((c.point - along * e).norm(), 0.05, 1e-12);
    EXPECT_NEAR(c.direction.dot(e), 0.0, 1e-12);  // inward normal: perpendicular to the link
  }
  EXPECT_GT(on_link[2], 10);
  EXPECT_GT(on_link[3], 10);
  EXPECT_GT(clamps, 2);
  EXPECT_LT(clamps, 20);
  // Too many for the time: a clear error, not a silent overlap.
  o.count = 200;
  EXPECT_THROW(plan_contacts(o, arm.model, 2.0, 400.0, 9), Error);
  o.count = 3;
  o.links = {4};
  EXPECT_THROW(plan_contacts(o, arm.model, 2.0, 400.0, 9), Error);
}

TEST(Contacts, PushEnvelopeRisesHoldsAndReleases) {
  Contact c;
  c.t_onset = 1.0, c.t_rise_end = 1.1, c.t_hold_end = 1.3, c.t_end = 1.4;
  EXPECT_EQ(push_envelope(c, 0.9), 0.0);
  EXPECT_NEAR(push_envelope(c, 1.05), 0.5, 1e-12);
  EXPECT_EQ(push_envelope(c, 1.2), 1.0);
  EXPECT_NEAR(push_envelope(c, 1.35), 0.5, 1e-12);
  EXPECT_EQ(push_envelope(c, 1.4), 0.0);
}

TEST(Sensors, QuantisationNoiseAndVelocityDifference) {
  VectorXd k_i(2);
  k_i << 10.0, 4.0;
  Eigen::Array<bool, Eigen::Dynamic, 1> revolute(2);
  revolute << true, false;
  SensorOptions o;
  o.encoder_bits = 12;
  o.current_noise = 0.0;
  o.velocity = VelocitySource::difference;
  o.velocity_resolution = 0;
  Sensors sensors(o, k_i, revolute, 1);
  VectorXd q_true(2), dq_true = VectorXd::Zero(2), tau(2), q, dq, i;
  tau << 5.0, -2.0;
  q_true << 0.1, 0.2;
  sensors.measure(0.0, q_true, dq_true, tau, q, dq, i);
  const double rad = 2 * std::numbers::pi / 4096, m = 1.0 / 4096;
  EXPECT_DOUBLE_EQ(q[0], std::round(0.1 / rad) * rad);
  EXPECT_DOUBLE_EQ(q[1], std::round(0.2 / m) * m);
  EXPECT_EQ(dq, VectorXd::Zero(2));
  EXPECT_DOUBLE_EQ(i[0], 0.5);
  EXPECT_DOUBLE_EQ(i[1], -0.5);
  const VectorXd q_first = q;
  q_true << 0.15, 0.1;
  sensors.measure(0.01, q_true, dq_true, tau, q, dq, i);
  EXPECT_NEAR(dq[0], (q[0] - q_first[0]) / 0.01, 1e-9);
  EXPECT_NEAR(dq[1], (q[1] - q_first[1]) / 0.01, 1e-9);
  // Reported in steps of the velocity resolution: the nearest multiple.
  SensorOptions stepped = o;
  stepped.velocity_resolution = 1e-3;
  Sensors counts(stepped, k_i, revolute, 1);
  VectorXd q2, dq2, i2;
  q_true << 0.1, 0.2;
  counts.measure(0.0, q_true, dq_true, tau, q2, dq2, i2);
  q_true << 0.15, 0.1;
  counts.measure(0.01, q_true, dq_true, tau, q2, dq2, i2);
  EXPECT_DOUBLE_EQ(dq2[0], std::round((q2[0] - q_first[0]) / 0.01 / 1e-3) * 1e-3);
  EXPECT_DOUBLE_EQ(dq2[1], std::round((q2[1] - q_first[1]) / 0.01 / 1e-3) * 1e-3);

  // Noise: the sample standard deviation within 3% of the setting over 20000 samples.
  SensorOptions noisy;
  noisy.encoder_bits = 0;
  noisy.current_noise = 0.02;
  noisy.velocity_noise = 0.005;
  Sensors s2(noisy, k_i, revolute, 2);
  double sum_i = 0, sum_i2 = 0, sum_v2 = 0;
  const int count = 20000;
  for (int k = 0; k < count; ++k) {
    s2.measure(k * 1e-3, q_true, dq_true, tau, q, dq, i);
    EXPECT_EQ(q, q_true);
    sum_i += i[0] - 0.5;
    sum_i2 += (i[0] - 0.5) * (i[0] - 0.5);
    sum_v2 += dq[1] * dq[1];
  }
  EXPECT_NEAR(std::sqrt(sum_i2 / count), 0.02, 0.03 * 0.02);
  EXPECT_NEAR(sum_i / count, 0.0, 4 * 0.02 / std::sqrt(count));
  EXPECT_NEAR(std::sqrt(sum_v2 / count), 0.005, 0.03 * 0.005);
}

struct Recorded {
  std::vector<std::vector<double>> rows;
  std::vector<ContactTruth> truth;
  RunSummary summary;
};

Recorded record(const testing::Arm& arm, const RunOptions& o, std::uint64_t seed) {
  Recorded r;
  RunCallbacks callbacks;
  callbacks.sample = [&](const Sample& s) {
    std::vector<double> row;
    sample_row(s, true, row);
    r.rows.push_back(row);
  };
  callbacks.contact = [&](const ContactTruth& c) { r.truth.push_back(c); };
  r.summary = simulate(arm.model, &arm.section.friction, arm.section.home, o, seed, callbacks);
  return r;
}

RunOptions busy_options() {
  RunOptions o;
  o.rate_hz = 125;
  o.trajectory.duration = 10;
  o.sensors.time_jitter = 0.0005;
  o.sensors.drop_rate = 0.01;
  o.contacts.count = 2;
  o.contacts.clamp_fraction = 0.5;
  return o;
}

TEST(Run, SameSeedGivesBitIdenticalOutputAndAnotherSeedDoesNot) {
  auto arm = testing::paper_arm();
  const RunOptions o = busy_options();
  const Recorded a = record(arm, o, 42), b = record(arm, o, 42), c = record(arm, o, 43);
  ASSERT_EQ(a.rows.size(), b.rows.size());
  for (std::size_t k = 0; k < a.rows.size(); ++k)
    ASSERT_EQ(std::memcmp(a.rows[k].data(), b.rows[k].data(), a.rows[k].size() * sizeof(double)), 0) << k;
  ASSERT_EQ(a.truth.size(), 2u);
  ASSERT_EQ(b.truth.size(), 2u);
  for (std::size_t k = 0; k < a.truth.size(); ++k) {
    std::vector<double> ra, rb;
    truth_row(a.truth[k], ra);
    truth_row(b.truth[k], rb);
    EXPECT_EQ(ra, rb);
  }
  bool differs = a.rows.size() != c.rows.size();
  for (std::size_t k = 0; !differs && k < a.rows.size(); ++k) differs = a.rows[k] != c.rows[k];
  EXPECT_TRUE(differs);
}

TEST(Run, SamplingJitterAndDropsAreAsAsked) {
  auto arm = testing::paper_arm();
  RunOptions o = busy_options();
  o.contacts.count = 0;
  o.trajectory.duration = 24;
  o.sensors.drop_rate = 0.02;
  const Recorded r = record(arm, o, 5);
  const double period = 1.0 / 125;
  const std::uint64_t nominal = 24 * 125 + 1;
  EXPECT_EQ(r.summary.samples + r.summary.dropped, nominal);
  EXPECT_EQ(r.rows.size(), r.summary.samples);
  // Drops: binomial(3001, 0.02): mean 60, sd 7.7.
  EXPECT_GT(r.summary.dropped, 29u);
  EXPECT_LT(r.summary.dropped, 91u);
  double previous = -1;
  int irregular = 0;
  for (const auto& row : r.rows) {
    const double t = row[0];
    EXPECT_GT(t, previous);
    const double nearest = std::round(t / period) * period;
    EXPECT_LE(std::abs(t - nearest), 0.45 * period + 1e-4);
    if (std::abs(t - nearest) > 1e-9) ++irregular;
    previous = t;
  }
  EXPECT_GT(irregular, 600);
}

// The controller follows the paper's trajectory through the friction, and the output columns
// hold what they claim: current = motor torque / k_i, true contact torque = -J^T F at the
// sample's own state (encoder exact, no noise).
TEST(Run, TracksThePaperTrajectoryAndReportsTrueTorques) {
  auto arm = testing::paper_arm();
  RunOptions o;
  o.rate_hz = 1000;
  o.trajectory.duration = 14;
  o.sensors.encoder_bits = 0;
  o.sensors.current_noise = 0;
  o.sensors.velocity_noise = 0;
  o.contacts.count = 2;
  o.contacts.min_spacing = 1;
  // PD, as measured before the integral existed; with it the error after a contact grows by
  // the integrator's windup (0.051 rad here).
  o.controller.integral_time = 0;
  const Recorded r = record(arm, o, 3);
  EXPECT_LT(r.summary.max_tracking_error, 0.05);
  ASSERT_EQ(r.truth.size(), 2u);
  model::Data data(arm.model);
  int checked = 0;
  for (const auto& truth : r.truth) {
    const Contact& c = truth.contact;
    EXPECT_NEAR(truth.peak_force, c.peak, 1e-9 * c.peak);
    for (const auto& row : r.rows) {
      const double t = row[0];
      if (t < c.t_rise_end || t > c.t_hold_end) continue;
      VectorXd q(3);
      q << row[1], row[2], row[3];
      for (int j = 0; j < 3; ++j) {
        const double eps = 1e-6;
        VectorXd qp = q, qm = q;
        qp[j] += eps, qm[j] -= eps;
        const Eigen::Vector3d dx = (model::point_position(arm.model, data, qp, c.link - 1, c.point) -
                                    model::point_position(arm.model, data, qm, c.link - 1, c.point)) / (2 * eps);
        EXPECT_NEAR(row[13 + j], -truth.force.dot(dx), 1e-6 * c.peak) << "t = " << t;
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 20);
  // Outside contacts the contact columns are exactly zero; friction is what LuGre says.
  double friction_peak = 0;
  for (const auto& row : r.rows) {
    bool in_contact = false;
    for (const auto& truth : r.truth) in_contact |= row[0] >= truth.contact.t_onset && row[0] <= truth.contact.t_end;
    if (!in_contact) {
      for (int j = 0; j < 3; ++j) ASSERT_EQ(row[13 + j], 0.0);
    }
    friction_peak = std::max(friction_peak, std::abs(row[10]));
  }
  // Peak friction of joint 1 at ~0.75 rad/s: tau_c + sigma2 w = 7.83 + 6.49 * 0.75 = 12.7 Nm.
  EXPECT_NEAR(friction_peak, 7.8322 + 6.4865 * 0.6 * 2 * std::numbers::pi * 0.2, 0.3);
}

TEST(Run, ClampsPressUntilTheForceLimit) {
  auto arm = testing::paper_arm();
  RunOptions o;
  o.rate_hz = 1000;
  o.trajectory.duration = 24;
  o.contacts.count = 4;
  o.contacts.clamp_fraction = 1.0;
  o.contacts.clamp_hold_min = 1.0;
  o.contacts.clamp_hold_max = 1.5;
  const Recorded r = record(arm, o, 11);
  ASSERT_EQ(r.truth.size(), 4u);
  int saturated = 0;
  for (const auto& truth : r.truth) {
    EXPECT_TRUE(truth.contact.clamp);
    EXPECT_LE(truth.peak_force, truth.contact.peak * (1 + 1e-12));
    EXPECT_GT(truth.peak_force, 5.0);
    saturated += truth.peak_force > 0.999 * truth.contact.peak;
  }
  EXPECT_GE(saturated, 2);
}

// mo-sim warns that the controller lost track when max_tracking_error exceeds 0.1 rad. The
// contacts of a campaign push the arm off its trajectory by more than that (the clamps hold it
// against an obstacle for a second or more): their deflection is kept apart, so that the
// demo's campaign raises no warning (it did: 0.135 rad, 50 contacts, seed 3 of the paper arm at
// 125 Hz; 0.052 rad now, where its motion without contacts gives 0.051), while a
// loop that truly cannot follow (a bandwidth too low for the friction) still reports its error.
TEST(Run, ContactDeflectionIsNotATrackingFailure) {
  auto arm = testing::paper_arm();
  RunOptions o;
  o.rate_hz = 125;
  o.trajectory.duration = 20;
  o.contacts.count = 4;
  o.contacts.force_min = o.contacts.force_max = 150;  // the demo's strongest pushes
  o.contacts.hold_min = o.contacts.hold_max = 0.3;
  const Recorded campaign = record(arm, o, 3);
  ASSERT_EQ(campaign.truth.size(), 4u);

  RunOptions free = o;
  free.contacts.count = 0;
  const Recorded alone = record(arm, free, 3);
  // Outside the contacts, the error of the same motion without them (friction the computed
  // torque does not know), give or take the integrator's windup left after the last.
  EXPECT_LT(campaign.summary.max_tracking_error, alone.summary.max_tracking_error + 0.01);
  EXPECT_LT(campaign.summary.max_tracking_error, 0.1);
  // The contacts did push it further (the error the summary gave before: 0.085 rad here).
  EXPECT_GT(campaign.summary.max_contact_deflection, alone.summary.max_tracking_error + 0.02);

  RunOptions slow = free;
  slow.controller.bandwidth_hz = 0.3;
  slow.controller.integral_time = 0;
  const Recorded lagging = record(arm, slow, 3);
  EXPECT_GT(lagging.summary.max_tracking_error, 0.1);  // 0.98 rad
  EXPECT_EQ(lagging.summary.max_contact_deflection, 0.0);
}

}  // namespace
}  // namespace momentum::sim
