// The momentum observer: analytic step responses on a 1-DOF system, friction compensation
// identity, time handling, and the reference trajectories of UR5 and Panda (Pinocchio data,
// tau_m = M ddq + C dq + g + tau_dist) against an independent low-pass of tau_dist.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "momentum/friction/friction.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/observer/filter.hpp"
#include "momentum/observer/observer.hpp"
#include "momentum/stream/reader.hpp"

namespace mo = momentum::observer;
namespace mf = momentum::friction;
namespace mm = momentum::model;

namespace {

// Step response of H(s) = (K1+K3) s / ((s+K1)(s+K2)) at time t >= 0 after a unit step.
double analytic_step(const mo::Gains& g, double t) {
  if (g.k1 == g.k2) return (g.k1 + g.k3) * t * std::exp(-g.k1 * t);
  return (g.k1 + g.k3) / (g.k1 - g.k2) * (std::exp(-g.k2 * t) - std::exp(-g.k1 * t));
}

}  // namespace

// A 1-DOF system (momentum p = m dq) under a constant motor torque u and a disturbance step
// of A at t0: p is linear between samples, so the discretization is exact and r must equal A
// times the step response of the transfer function at every (irregular) sample.
TEST(ResidualObserver, StepResponseIsTransferFunction) {
  const mo::Gains cases[] = {{50, 0, 0}, {50, 5, 0}, {50, 5, 20}, {30, 30, 0}, {30, 30, 12}, {8, 40, 0}};
  for (const mo::Gains& g : cases) {
    mo::ResidualObserver observer({g}, nullptr);
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> jitter(0.3, 1.7);
    const double u = 2.5, amplitude = -4.0, p0 = 1.2;
    double t = 0;
    const double t0 = 0.2;
    bool stepped = false;
    double worst = 0;
    for (int k = 0; k < 1500; ++k) {
      double next = t + 0.001 * jitter(rng);
      if (!stepped && next >= t0) next = t0, stepped = true;  // the step falls on a sample
      const double dt = k ? next - t : 0.0;
      if (k) t = next;
      const double p = p0 + u * t - amplitude * std::max(0.0, t - t0);
      double r = 0;
      observer.step(dt, &p, &u, nullptr, &r, nullptr, nullptr);
      const double expected = t >= t0 ? amplitude * analytic_step(g, t - t0) : 0.0;
      worst = std::max(worst, std::abs(r - expected));
    }
    EXPECT_LT(worst, 1e-11) << "k1 " << g.k1 << " k2 " << g.k2 << " k3 " << g.k3;
  }
}

// Compensation inside the observer (u - tau_f as a known torque) equals r - F(tau_f) with the
// stand-alone filter the fitter uses.
TEST(ResidualObserver, CompensationEqualsFilteredFriction) {
  mf::FrictionModel friction;
  friction.kind = mf::Kind::lugre;
  friction.joints = {{98467.9088, 314.0483, 6.4865, 7.8322, 4.0033, 0.0978},
                     {1.0e5, 300.0, 0.8, 2.0, 3.0, 0.05}};
  const std::vector<mo::Gains> gains{{50, 0, 0}, {40, 6, 10}};
  mo::ResidualObserver observer(gains, &friction);
  mo::DisturbanceFilter<double> f1(gains[0]), f2(gains[1]);
  auto lugre = mf::make_joint_frictions(friction);
  std::vector<double> ts, w1, r1, mu1;
  double t = 0;
  for (int k = 0; k < 3000; ++k) {
    const double dt = k ? 0.001 * (1 + 0.4 * std::sin(0.7 * k)) : 0.0;
    t += dt;
    const double dq[2] = {0.6 * std::sin(2 * M_PI * 0.5 * t), 0.2 * std::cos(2 * M_PI * 1.1 * t)};
    const double p[2] = {2.0 * dq[0], 0.5 * dq[1] + 0.1};
    const double u[2] = {10 * std::sin(3 * t), -3 + t};
    double r[2], tau_f[2], mu[2];
    observer.step(dt, p, u, dq, r, tau_f, mu);
    const double expected_tau_f[2] = {lugre[0].step(dq[0], dt), lugre[1].step(dq[1], dt)};
    const double filtered[2] = {f1.step(expected_tau_f[0], dt), f2.step(expected_tau_f[1], dt)};
    ts.push_back(t);
    w1.push_back(dq[1]);
    r1.push_back(r[1]);
    mu1.push_back(mu[1]);
    for (int j = 0; j < 2; ++j) {
      ASSERT_EQ(tau_f[j], expected_tau_f[j]);
      ASSERT_NEAR(mu[j], r[j] - filtered[j], 1e-11 * (1 + std::abs(r[j]))) << "joint " << j + 1 << " k " << k;
    }
  }
  // The fitter's one-call version gives the same r - mu.
  std::vector<double> model(ts.size());
  mo::filtered_friction(friction.kind, friction.joints[1], friction.options, gains[1], ts.data(),
                        w1.data(), ts.size(), model.data());
  for (std::size_t k = 0; k < ts.size(); ++k) ASSERT_NEAR(model[k], r1[k] - mu1[k], 1e-11 * (1 + std::abs(r1[k])));
}

// The joints are independent filters: five joints stepped together (two pairs and an odd last
// one, some sharing the gains of the joint before) give, bit for bit, what five one-joint
// observers give, with and without friction.
TEST(ResidualObserver, JointsTogetherAreEachJointAlone) {
  const std::vector<mo::Gains> gains{{50, 0, 0}, {50, 0, 0}, {40, 6, 10}, {30, 30, 0}, {8, 40, 3}};
  const std::size_t n = gains.size();
  mf::FrictionModel friction;
  friction.kind = mf::Kind::lugre;
  friction.joints = {{98467.9088, 314.0483, 6.4865, 7.8322, 4.0033, 0.0978},
                     {1.0e5, 300.0, 0.8, 2.0, 3.0, 0.05},
                     {5.0e4, 200.0, 2.0, 4.0, 5.0, 0.1},
                     {98467.9088, 314.0483, 6.4865, 7.8322, 4.0033, 0.0978},
                     {2.0e5, 100.0, 0.3, 1.0, 1.5, 0.02}};
  for (const bool with_friction : {false, true}) {
    mo::ResidualObserver together(gains, with_friction ? &friction : nullptr);
    std::vector<mo::ResidualObserver> alone;
    std::vector<mf::FrictionModel> one_joint(n, friction);
    for (std::size_t j = 0; j < n; ++j) {
      one_joint[j].joints = {friction.joints[j]};
      alone.emplace_back(std::vector<mo::Gains>{gains[j]}, with_friction ? &one_joint[j] : nullptr);
    }
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> jitter(0.5, 1.5), noise(-1, 1);
    std::vector<double> p(n), u(n), dq(n), r(n), tau_f(n), mu(n);
    double t = 0;
    for (int k = 0; k < 2000; ++k) {
      const double dt = k ? 0.001 * jitter(rng) : 0.0;
      t += dt;
      for (std::size_t j = 0; j < n; ++j) {
        dq[j] = (0.3 + 0.1 * static_cast<double>(j)) * std::sin((1.0 + static_cast<double>(j)) * t) + 1e-3 * noise(rng);
        p[j] = (1.0 + static_cast<double>(j)) * dq[j];
        u[j] = 5 * std::cos(2 * t + static_cast<double>(j)) + noise(rng);
      }
      together.step(dt, p.data(), u.data(), dq.data(), r.data(), tau_f.data(), mu.data());
      for (std::size_t j = 0; j < n; ++j) {
        double r_j = 0, tau_f_j = 0, mu_j = 0;
        alone[j].step(dt, &p[j], &u[j], &dq[j], &r_j, &tau_f_j, &mu_j);
        ASSERT_EQ(r[j], r_j) << "joint " << j + 1 << " sample " << k << (with_friction ? " with friction" : "");
        if (with_friction) {
          ASSERT_EQ(tau_f[j], tau_f_j) << "joint " << j + 1 << " sample " << k;
          ASSERT_EQ(mu[j], mu_j) << "joint " << j + 1 << " sample " << k;
        }
      }
    }
  }
}

TEST(ObserverOptions, FromJson) {
  std::vector<std::string> warnings;
  const auto o = mo::observer_options_from_json(
      nlohmann::json::parse(R"({"order": 2, "cutoff_hz": [1, 2], "k2": 3, "k3": 0.5, "gap_factor": 8, "bridge_tolerance": 0.002, "kk": 1})"),
      &warnings);
  EXPECT_EQ(o.order, 2);
  ASSERT_EQ(o.k1.size(), 2u);
  EXPECT_NEAR(o.k1[1], 4 * M_PI, 1e-15);
  EXPECT_EQ(o.k2, std::vector<double>{3});
  EXPECT_EQ(o.gap_factor, 8);
  EXPECT_EQ(o.bridge_tolerance, 0.002);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], "observer: unknown key 'kk'");
  const auto gains = o.joint_gains(2);
  EXPECT_EQ(gains[1].k2, 3);
  EXPECT_EQ(gains[0].k3, 0.5);
  auto message = [](const char* text) -> std::string {
    try {
      mo::observer_options_from_json(nlohmann::json::parse(text)).joint_gains(6);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(message(R"({"k1": 5, "cutoff_hz": 1})"), "observer: give either 'k1' or 'cutoff_hz', not both");
  EXPECT_EQ(message(R"({"k1": [1, 2, 3]})"), "observer: k1 has 3 values for 6 joints");
  EXPECT_EQ(message(R"({"order": 3})"), "observer: 'order' must be 1 or 2");
  EXPECT_EQ(message(R"({"order": 2, "k1": [5, -1]})"), "observer: joint 2: k1 = -1 is not a finite value > 0");
  // Order 1 ignores k2 and k3.
  const auto first = mo::observer_options_from_json(nlohmann::json::parse(R"({"k2": 9, "k3": 2})"));
  EXPECT_EQ(first.joint_gains(1)[0].k2, 0.0);
}

namespace {

struct Trajectory {
  int joints = 0;
  std::vector<double> t;
  std::vector<std::vector<double>> q, dq, tau_m, tau_dist;  // [sample][joint]
};

Trajectory load_trajectory(const std::string& name, int joints, int every = 1) {
  auto in = momentum::stream::Reader::open(std::string(MOMENTUM_TEST_DATA) + "/" + name);
  Trajectory traj;
  traj.joints = joints;
  std::vector<std::size_t> iq, idq, itau, idist;
  for (int j = 1; j <= joints; ++j) {
    iq.push_back(in->require("q" + std::to_string(j)));
    idq.push_back(in->require("dq" + std::to_string(j)));
    itau.push_back(in->require("tau_m" + std::to_string(j)));
    idist.push_back(in->require("tau_dist" + std::to_string(j)));
  }
  const std::size_t it = in->require("t");
  long k = 0;
  while (const double* row = in->next()) {
    if (k++ % every) continue;
    traj.t.push_back(row[it]);
    auto take = [&](const std::vector<std::size_t>& idx) {
      std::vector<double> v;
      for (std::size_t i : idx) v.push_back(row[i]);
      return v;
    };
    traj.q.push_back(take(iq));
    traj.dq.push_back(take(idq));
    traj.tau_m.push_back(take(itau));
    traj.tau_dist.push_back(take(idist));
  }
  return traj;
}

// Independent reference: the unit-gain low-pass K/(s+K) of a signal that is linear between
// samples, written as the error e = y - x, which obeys e' = -K e - x' (x' constant per interval).
std::vector<double> low_pass_reference(const std::vector<double>& t, const std::vector<double>& x, double k) {
  std::vector<double> y(t.size(), 0.0);
  for (std::size_t i = 1; i < t.size(); ++i) {
    const double h = t[i] - t[i - 1];
    const double a = std::exp(-k * h);
    const double slope = (x[i] - x[i - 1]) / h;
    y[i] = x[i] + a * (y[i - 1] - x[i - 1]) - slope * (1 - a) / k;
  }
  return y;
}

std::vector<std::vector<double>> observe(const Trajectory& traj, const mm::Model& model,
                                         const mo::ObserverOptions& options) {
  mo::MomentumObserver observer(model, options, nullptr);
  std::vector<std::vector<double>> r(traj.t.size(), std::vector<double>(traj.joints));
  for (std::size_t k = 0; k < traj.t.size(); ++k) {
    const auto status = observer.step(traj.t[k], traj.q[k].data(), traj.dq[k].data(),
                                      traj.tau_m[k].data(), r[k].data(), nullptr, nullptr);
    EXPECT_EQ(status, k ? mo::SampleStatus::ok : mo::SampleStatus::started);
  }
  return r;
}

struct Deviation {
  double rms = 0, peak = 0, largest_pulse = 0;
};

// Deviation of r from the low-pass reference of tau_dist over all samples of joint j.
Deviation deviation(const Trajectory& traj, const std::vector<std::vector<double>>& r, int j, double k) {
  std::vector<double> dist;
  for (const auto& row : traj.tau_dist) dist.push_back(row[j]);
  const std::vector<double> ref = low_pass_reference(traj.t, dist, k);
  Deviation d;
  double sum = 0;
  for (std::size_t i = 0; i < traj.t.size(); ++i) {
    const double e = r[i][j] - ref[i];
    sum += e * e;
    d.peak = std::max(d.peak, std::abs(e));
    for (double v : traj.tau_dist[i]) d.largest_pulse = std::max(d.largest_pulse, std::abs(v));
  }
  d.rms = std::sqrt(sum / traj.t.size());
  return d;
}

void check_reference_trajectory(const std::string& robot, const std::string& profile, int joints) {
  const mm::Model model = mm::build_model(mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/" + profile));
  ASSERT_EQ(model.nq, joints);
  mo::ObserverOptions options;
  options.k1 = {50.0};
  const double k = 50.0;
  const Trajectory full = load_trajectory(robot + ".traj.csv", joints);
  const Trajectory coarse = load_trajectory(robot + ".traj.csv", joints, 8);  // 125 Hz
  ASSERT_EQ(full.t.size(), 8001u);
  const auto r_full = observe(full, model, options);
  const auto r_coarse = observe(coarse, model, options);
  for (int j = 0; j < joints; ++j) {
    const Deviation d = deviation(full, r_full, j, k);
    EXPECT_LT(d.rms, 0.01 * d.largest_pulse) << robot << " joint " << j + 1;
    EXPECT_LT(d.peak, 0.05 * d.largest_pulse) << robot << " joint " << j + 1;
    const Deviation dc = deviation(coarse, r_coarse, j, k);
    EXPECT_LT(dc.rms, 0.01 * dc.largest_pulse) << robot << " 125 Hz joint " << j + 1;
    EXPECT_LT(dc.peak, 0.05 * dc.largest_pulse) << robot << " 125 Hz joint " << j + 1;
    // 125 Hz against 1 kHz at the common samples: they differ where the 125 Hz input's coarser
    // interpolation of the pulse edges shifts the low-pass (the filter's lag), i.e. by what
    // their references differ; what that does not explain must meet the same 1% RMS / 5% peak
    // bounds. (It is the O(dt^2) error of taking u and p linear over 8 ms.)
    std::vector<double> dist_full, dist_coarse;
    for (const auto& row : full.tau_dist) dist_full.push_back(row[j]);
    for (const auto& row : coarse.tau_dist) dist_coarse.push_back(row[j]);
    const auto ref_full = low_pass_reference(full.t, dist_full, k);
    const auto ref_coarse = low_pass_reference(coarse.t, dist_coarse, k);
    double worst = 0, sum = 0, lag_effect = 0;
    for (std::size_t i = 0; i < coarse.t.size(); ++i) {
      const double difference = r_coarse[i][j] - r_full[8 * i][j];
      const double explained = ref_coarse[i] - ref_full[8 * i];
      worst = std::max(worst, std::abs(difference - explained));
      sum += (difference - explained) * (difference - explained);
      lag_effect = std::max(lag_effect, std::abs(explained));
    }
    const double rms = std::sqrt(sum / coarse.t.size());
    EXPECT_LT(rms, 0.01 * d.largest_pulse) << robot << " joint " << j + 1;
    EXPECT_LT(worst, 0.05 * d.largest_pulse) << robot << " joint " << j + 1;
    std::printf("%s joint %d: 1 kHz rms %.4f peak %.4f | 125 Hz rms %.4f peak %.4f | 125 Hz vs 1 kHz "
                "beyond the lag: rms %.4f peak %.4f; lag effect %.4f | largest pulse %.3f Nm\n",
                robot.c_str(), j + 1, d.rms, d.peak, dc.rms, dc.peak, rms, worst, lag_effect, d.largest_pulse);
  }
}

}  // namespace

TEST(MomentumObserver, Ur5ReferenceTrajectory) { check_reference_trajectory("ur5", "ur5.json", 6); }
TEST(MomentumObserver, PandaReferenceTrajectory) { check_reference_trajectory("panda", "panda.json", 7); }

// Gaps, NaN rows and time going backwards, on the UR5 reference motion.
TEST(MomentumObserver, TimeHandling) {
  const mm::Model model = mm::build_model(mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/ur5.json"));
  const Trajectory traj = load_trajectory("ur5.traj.csv", 6);
  mo::ObserverOptions options;
  mo::MomentumObserver observer(model, options, nullptr);
  mo::MomentumObserver fresh(model, options, nullptr);
  std::vector<double> r(6), r_fresh(6);
  auto feed = [&](mo::MomentumObserver& o, std::size_t k, std::vector<double>& out, double t_shift = 0) {
    return o.step(traj.t[k] + t_shift, traj.q[k].data(), traj.dq[k].data(), traj.tau_m[k].data(),
                  out.data(), nullptr, nullptr);
  };
  for (std::size_t k = 0; k < 100; ++k) feed(observer, k, r);
  EXPECT_NEAR(observer.median_dt(), 0.001, 1e-12);
  // Time going backwards or standing still: rejected, state untouched.
  const std::vector<double> before = r;
  EXPECT_EQ(feed(observer, 50, r), mo::SampleStatus::time_not_increasing);
  EXPECT_EQ(feed(observer, 99, r), mo::SampleStatus::time_not_increasing);
  EXPECT_EQ(r, before);
  // The next sample continues as if nothing happened: compare with an uninterrupted run.
  mo::MomentumObserver straight(model, options, nullptr);
  std::vector<double> r_straight(6);
  for (std::size_t k = 0; k <= 100; ++k) feed(straight, k, r_straight);
  EXPECT_EQ(feed(observer, 100, r), mo::SampleStatus::ok);
  EXPECT_EQ(r, r_straight);
  // A gap of 10 ms (> 5 x 1 ms): restart with r = 0, then identical to a fresh observer.
  EXPECT_EQ(feed(observer, 110, r), mo::SampleStatus::restarted_after_gap);
  EXPECT_NEAR(observer.last_gap(), 0.010, 1e-12);
  EXPECT_EQ(r, std::vector<double>(6, 0.0));
  EXPECT_EQ(feed(fresh, 110, r_fresh), mo::SampleStatus::started);
  for (std::size_t k = 111; k < 200; ++k) {
    EXPECT_EQ(feed(observer, k, r), mo::SampleStatus::ok);
    feed(fresh, k, r_fresh);
    ASSERT_EQ(r, r_fresh);
  }
  // A gap of 4 ms (3 samples lost) on this smooth motion is bridged.
  EXPECT_EQ(feed(observer, 203, r), mo::SampleStatus::bridged);
  EXPECT_FALSE(observer.last_gap_mismatched());
  // NaN: NaN out, then a restart at the next good sample.
  Trajectory bad = traj;
  bad.dq[204][2] = NAN;
  bad.tau_m[205][0] = INFINITY;
  auto feed_bad = [&](std::size_t k) {
    return observer.step(bad.t[k], bad.q[k].data(), bad.dq[k].data(), bad.tau_m[k].data(), r.data(), nullptr, nullptr);
  };
  EXPECT_EQ(feed_bad(204), mo::SampleStatus::invalid);
  EXPECT_TRUE(std::isnan(r[0]));
  EXPECT_EQ(feed_bad(205), mo::SampleStatus::invalid);
  EXPECT_EQ(feed_bad(206), mo::SampleStatus::restarted_after_bad);
  EXPECT_EQ(observer.last_bad_run(), 2u);
  EXPECT_EQ(r, std::vector<double>(6, 0.0));
  EXPECT_EQ(feed_bad(207), mo::SampleStatus::ok);
}

// The median follows a change of sample rate instead of restarting forever.
TEST(MomentumObserver, SampleRateChange) {
  const mm::Model model = mm::build_model(mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/ur5.json"));
  const Trajectory traj = load_trajectory("ur5.traj.csv", 6);
  mo::MomentumObserver observer(model, {}, nullptr);
  std::vector<double> r(6);
  int restarts = 0;
  for (std::size_t k = 0; k < traj.t.size(); k += (k < 1000 ? 1 : 8)) {
    const auto s = observer.step(traj.t[k], traj.q[k].data(), traj.dq[k].data(), traj.tau_m[k].data(), r.data(), nullptr, nullptr);
    restarts += s == mo::SampleStatus::restarted_after_gap;
  }
  EXPECT_GE(restarts, 1);
  EXPECT_LE(restarts, 8);  // until half of the 16-interval window holds the new rate
  EXPECT_NEAR(observer.median_dt(), 0.008, 1e-9);
}

// Lost samples on the UR5 reference motion (1 kHz, smooth, with disturbance pulses): short gaps
// are bridged without a restart, and 0.1 s (5 time constants 1/K1) after a gap the residual is
// that of the complete log. Within that time it may differ: a pulse edge inside a gap is seen
// as a ramp over the gap, which the low-pass shows as a transient of up to K1 A dt / 2.
TEST(MomentumObserver, BridgedGapsKeepTheResidual) {
  const mm::Model model = mm::build_model(mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/ur5.json"));
  const Trajectory traj = load_trajectory("ur5.traj.csv", 6);
  mo::ObserverOptions options;
  mo::MomentumObserver complete(model, options, nullptr), gappy(model, options, nullptr);
  std::vector<double> r(6), r_gappy(6);
  std::mt19937_64 rng(5);
  std::uniform_int_distribution<int> lost(1, 3);
  double worst = 0, near = 0, largest = 0, last_bridge = -1;
  int bridged = 0;
  std::size_t next_gap = 200, resume = 0;
  for (std::size_t k = 0; k < traj.t.size(); ++k) {
    complete.step(traj.t[k], traj.q[k].data(), traj.dq[k].data(), traj.tau_m[k].data(), r.data(), nullptr, nullptr);
    for (double x : r) largest = std::max(largest, std::abs(x));
    if (k == next_gap) {  // lose 1 to 3 samples every 250 ms
      next_gap += 250;
      resume = k + static_cast<std::size_t>(lost(rng));
    }
    if (k <= resume && k + 3 >= resume && resume >= 200) {
      if (k < resume) continue;
    }
    const auto s = gappy.step(traj.t[k], traj.q[k].data(), traj.dq[k].data(), traj.tau_m[k].data(),
                              r_gappy.data(), nullptr, nullptr);
    ASSERT_NE(s, mo::SampleStatus::restarted_after_gap)
        << traj.t[k] << " gap " << gappy.last_gap() << " mismatch " << gappy.mismatch() << " joint "
        << gappy.mismatch_joint() << " median " << gappy.median_dt();
    bridged += s == mo::SampleStatus::bridged;
    if (s == mo::SampleStatus::bridged) last_bridge = traj.t[k];
    for (int j = 0; j < 6; ++j) {
      const double e = std::abs(r_gappy[j] - r[j]);
      near = std::max(near, e);
      if (traj.t[k] - last_bridge > 0.1) worst = std::max(worst, e);
    }
  }
  EXPECT_GT(bridged, 25);
  // 5 time constants after a transient of at most ~0.4 Nm: < 0.003 Nm, far below 1% of the
  // residual's range (8.2 Nm).
  EXPECT_LT(worst, 0.001 * largest) << "worst " << worst << " largest " << largest;
  EXPECT_GT(near, worst);  // the transients exist: this test sees the gaps
  std::printf("bridged %d gaps; |r - r_complete| <= %.3g Nm near them, %.3g Nm 0.1 s after; range %.3g Nm\n",
              bridged, near, worst, largest);
}

// A gap whose positions do not follow the velocities (the arm moved in a way the samples at
// either end do not explain) restarts the observer instead of integrating a false momentum.
TEST(MomentumObserver, InconsistentGapRestarts) {
  const mm::Model model = mm::build_model(mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/ur5.json"));
  Trajectory traj = load_trajectory("ur5.traj.csv", 6);
  mo::ObserverOptions options;
  mo::MomentumObserver observer(model, options, nullptr);
  std::vector<double> r(6);
  for (std::size_t k = 0; k < 100; ++k)
    observer.step(traj.t[k], traj.q[k].data(), traj.dq[k].data(), traj.tau_m[k].data(), r.data(), nullptr, nullptr);
  traj.q[103][4] += 0.005;  // 5 mrad more than the velocity integrates to
  EXPECT_EQ(observer.step(traj.t[103], traj.q[103].data(), traj.dq[103].data(), traj.tau_m[103].data(),
                          r.data(), nullptr, nullptr),
            mo::SampleStatus::restarted_after_gap);
  EXPECT_TRUE(observer.last_gap_mismatched());
  EXPECT_EQ(observer.mismatch_joint(), 4);
  EXPECT_NEAR(observer.mismatch(), 0.005, 1e-4);
  EXPECT_EQ(r, std::vector<double>(6, 0.0));
  // A tolerance of 0 never bridges a moving arm.
  options.bridge_tolerance = 0;
  mo::MomentumObserver strict(model, options, nullptr);
  for (std::size_t k = 0; k < 100; ++k)
    strict.step(traj.t[k], traj.q[k].data(), traj.dq[k].data(), traj.tau_m[k].data(), r.data(), nullptr, nullptr);
  EXPECT_EQ(strict.step(traj.t[102], traj.q[102].data(), traj.dq[102].data(), traj.tau_m[102].data(),
                        r.data(), nullptr, nullptr),
            mo::SampleStatus::restarted_after_gap);
  std::string why;
  options.bridge_tolerance = -1;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("bridge_tolerance"), std::string::npos);
}

// precompute() is a hint: on the UR5 reference motion, hinted in batches of 1 to 4 samples,
// some hints wrong (another sample's q, a velocity one ulp off), some samples skipped and one
// stepped twice in a row, the residual is bit for bit the one without hints, and every sample
// whose hint was right took it.
TEST(MomentumObserver, PrecomputedDynamicsChangeNothing) {
  const mm::Model model = mm::build_model(mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/ur5.json"));
  const Trajectory traj = load_trajectory("ur5.traj.csv", 6);
  mo::ObserverOptions options;
  options.k1 = {50.0};
  mo::MomentumObserver plain(model, options, nullptr), hinted(model, options, nullptr);
  if (!hinted.can_precompute()) GTEST_SKIP() << "no AVX2 on this CPU: precompute() does nothing";
  std::vector<double> r_plain(6), r_hinted(6);
  std::vector<double> wrong_dq(6);
  std::uint64_t expected_taken = 0;
  std::size_t k = 0;
  int batch = 0;
  while (k < traj.t.size()) {
    const int count = static_cast<int>(std::min<std::size_t>(1 + batch % 4, traj.t.size() - k));
    const double* q[4];
    const double* dq[4];
    for (int lane = 0; lane < count; ++lane) {
      q[lane] = traj.q[k + lane].data();
      dq[lane] = traj.dq[k + lane].data();
    }
    // Every fifth batch: lane 1 is another sample's q, lane 2 a velocity one ulp off.
    const bool wrong = batch % 5 == 0 && count > 2;
    // Every seventh batch leaves its second sample out (a row the signal check left out).
    const bool skip_second = batch % 7 == 3 && count > 1;
    if (wrong) {
      q[1] = traj.q[(k + 100) % traj.t.size()].data();
      wrong_dq = traj.dq[k + 2];
      wrong_dq[3] = std::nextafter(wrong_dq[3], 10.0);
      dq[2] = wrong_dq.data();
    }
    hinted.precompute(count, q, dq);
    const int hinted_now = hinted.precomputed();
    EXPECT_EQ(hinted_now, count >= 2 ? count : 0);
    // Taken: every sample of a batch of two or more up to the first wrong hint, which drops
    // the rest; a sample left out is passed over.
    if (count >= 2) expected_taken += wrong ? 1 : count - (skip_second ? 1 : 0);
    for (int lane = 0; lane < count; ++lane, ++k) {
      if (skip_second && lane == 1) continue;
      const auto s_plain = plain.step(traj.t[k], traj.q[k].data(), traj.dq[k].data(), traj.tau_m[k].data(),
                                      r_plain.data(), nullptr, nullptr);
      const auto s_hinted = hinted.step(traj.t[k], traj.q[k].data(), traj.dq[k].data(), traj.tau_m[k].data(),
                                        r_hinted.data(), nullptr, nullptr);
      ASSERT_EQ(s_plain, s_hinted) << "sample " << k;
      for (int j = 0; j < 6; ++j) ASSERT_EQ(r_plain[j], r_hinted[j]) << "sample " << k << " joint " << j + 1;
    }
    ++batch;
  }
  EXPECT_EQ(hinted.precomputed_taken(), expected_taken);
  std::printf("%llu of %zu samples took a precomputed result\n",
              static_cast<unsigned long long>(hinted.precomputed_taken()), traj.t.size());
}
