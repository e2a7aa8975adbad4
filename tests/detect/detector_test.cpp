// The detector state machine on synthetic streams whose answers are known in closed form:
// steps and pulses injected at known rows, with and without seeded noise.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "momentum/detect/detector.hpp"

using namespace momentum::detect;

namespace {

// 1/1024 s: every row time and every hold or rest time below is exact in binary.
constexpr double kDt = 1.0 / 1024;

// Rows of an n-joint stream: t = k dt, x from a function of (k, j), dq from another.
struct Run {
  std::vector<Event> rows;  // event rows in order, onset and end
  std::vector<int> links;   // open_link() after each row
};

template <class X, class V>
Run run(Detector& d, int rows, X&& x_of, V&& dq_of, bool finish = true) {
  Run out;
  const std::size_t n = d.joints();
  std::vector<double> x(n), dq(n);
  for (int k = 0; k < rows; ++k) {
    for (std::size_t j = 0; j < n; ++j) {
      x[j] = x_of(k, static_cast<int>(j));
      dq[j] = dq_of(k, static_cast<int>(j));
    }
    for (const Event& e : d.step(k * kDt, x.data(), dq.data())) out.rows.push_back(e);
    out.links.push_back(d.open_link());
  }
  if (finish)
    if (const Event* e = d.finish(EndReason::eof)) out.rows.push_back(*e);
  return out;
}

auto moving = [](int, int) { return 0.5; };

Thresholds constant(std::vector<double> values) {
  return constant_thresholds(Signal::mu, values, values.size());
}

}  // namespace

TEST(Detector, StepCrossingGivesExactOnsetAndDetectTimes) {
  // Joint 2 steps from 0 to 2 x threshold at row 1000: onset and detection on that row.
  Detector d(constant({1, 1, 1}), {}, false);
  auto r = run(d, 3000, [](int k, int j) { return j == 1 && k >= 1000 && k < 1500 ? 2.0 : 0.0; }, moving);
  ASSERT_EQ(r.rows.size(), 2u);
  const Event& on = r.rows[0];
  EXPECT_EQ(on.kind, EventKind::onset);
  EXPECT_DOUBLE_EQ(on.t_onset_estimate, 1000 * kDt);
  EXPECT_DOUBLE_EQ(on.t_detect, 1000 * kDt);
  EXPECT_EQ(on.link, 2);
  EXPECT_EQ(on.joints, std::vector<int>({2}));
  EXPECT_EQ(on.id, 1u);
  EXPECT_DOUBLE_EQ(on.peaks[1], 2.0);
  const Event& end = r.rows[1];
  EXPECT_EQ(end.kind, EventKind::end);
  EXPECT_EQ(end.ended_by, EndReason::release);
  // First quiet row 1500; the default hold of 0.2 s (204.8 rows) closes it on row 1705.
  EXPECT_DOUBLE_EQ(end.t_end, 1500 * kDt);
  EXPECT_EQ(r.links[1704], 2);
  EXPECT_EQ(r.links[1705], 0);
  EXPECT_EQ(r.links[999], 0);
  EXPECT_EQ(r.links[1000], 2);
}

TEST(Detector, MinSamplesDelaysDetectionByExactlyThatManyRows) {
  for (int m : {1, 2, 5, 8}) {
    DetectorOptions o;
    o.min_samples = m;
    Detector d(constant({1}), o, false);
    auto r = run(d, 2000, [](int k, int) { return k >= 700 && k < 900 ? 3.0 : 0.0; }, moving);
    ASSERT_EQ(r.rows.size(), 2u) << m;
    EXPECT_DOUBLE_EQ(r.rows[0].t_onset_estimate, 700 * kDt) << m;
    EXPECT_DOUBLE_EQ(r.rows[0].t_detect, (700 + m - 1) * kDt) << m;
  }
}

TEST(Detector, MinSamplesIgnoresShorterSpikes) {
  DetectorOptions o;
  o.min_samples = 4;
  Detector d(constant({1}), o, false);
  // Spikes of 3 rows every 50 rows never fire; one of 4 rows at row 1000 does.
  auto r = run(d, 2000, [](int k, int) {
    if (k >= 1000 && k < 1004) return 5.0;
    return k % 50 < 3 ? 5.0 : 0.0;
  }, moving);
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(r.rows[0].t_detect, 1003 * kDt);
}

TEST(Detector, ThresholdIsStrict) {
  // |x| == threshold does not fire; the next representable value does.
  Detector d(constant({1}), {}, false);
  auto r = run(d, 10, [](int k, int) { return k < 5 ? 1.0 : std::nextafter(1.0, 2.0); }, moving);
  ASSERT_FALSE(r.rows.empty());
  EXPECT_DOUBLE_EQ(r.rows[0].t_detect, 5 * kDt);
}

TEST(Detector, NegativeResidualsFireOnMagnitude) {
  Detector d(constant({1}), {}, false);
  auto r = run(d, 100, [](int k, int) { return k >= 10 && k < 20 ? -1.5 : 0.0; }, moving);
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(r.rows[0].t_detect, 10 * kDt);
  EXPECT_DOUBLE_EQ(r.rows[0].peaks[0], 1.5);
}

TEST(Detector, ReleaseAndHold) {
  DetectorOptions o;
  o.release = 0.5;
  o.hold = 50 * kDt;
  Detector d(constant({2}), o, false);
  // Over the threshold on rows 100..199; 1.5 (over 0.5 x 2 = 1, under 2) on 200..229 keeps
  // the event open; 0.5 from 230 on is quiet, but a blip at rows 260..261 restarts the hold.
  auto r = run(d, 1000, [](int k, int) {
    if (k >= 100 && k < 200) return 3.0;
    if (k >= 200 && k < 230) return 1.5;
    if (k == 260 || k == 261) return 1.2;
    return 0.5;
  }, moving);
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(r.rows[1].t_end, 262 * kDt);
  EXPECT_EQ(r.links[262 + 49], 1);
  EXPECT_EQ(r.links[262 + 50], 0);  // hold complete on row 312
}

TEST(Detector, HoldZeroEndsOnTheFirstQuietRow) {
  DetectorOptions o;
  o.hold = 0;
  Detector d(constant({1}), o, false);
  auto r = run(d, 100, [](int k, int) { return k >= 10 && k < 20 ? 2.0 : 0.0; }, moving);
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(r.rows[1].t_end, 20 * kDt);
  EXPECT_EQ(r.links[19], 1);
  EXPECT_EQ(r.links[20], 0);
}

TEST(Detector, IsolationIsTheMostDistalFiredJoint) {
  // A contact on link 3 of a 4-joint arm moves joints 1..3; joint 3 crosses last.
  Detector d(constant({1, 1, 1, 1}), {}, false);
  auto r = run(d, 2000, [](int k, int j) {
    if (k < 500 || k >= 800) return 0.0;
    const double ramp = (k - 500) * 0.01;  // crosses 1 after 100 rows
    const double gain[] = {1.5, 1.2, 0.9, 0.0};
    return ramp * gain[j];
  }, moving);
  ASSERT_EQ(r.rows.size(), 2u);
  const Event& on = r.rows[0];
  // Joint 1 crosses first: 0.015 (k - 500) > 1 from k = 567.
  EXPECT_DOUBLE_EQ(on.t_detect, 567 * kDt);
  EXPECT_EQ(on.link, 1);
  EXPECT_EQ(on.joints, std::vector<int>({1}));
  const Event& end = r.rows[1];
  EXPECT_EQ(end.link, 3);
  EXPECT_EQ(end.joints, std::vector<int>({1, 2, 3}));
  EXPECT_EQ(end.t_detect, on.t_detect);
  EXPECT_EQ(end.id, on.id);
  // Peaks: the ramp's last value on row 799 times each gain; joint 4 never moved.
  EXPECT_NEAR(end.peaks[0], 2.99 * 1.5, 1e-12);
  EXPECT_NEAR(end.peaks[2], 2.99 * 0.9, 1e-12);
  EXPECT_EQ(end.peaks[3], 0.0);
}

TEST(Detector, OnsetEstimateOfARamp) {
  Detector d(constant({1}), {}, false);
  // x = (k - 300) / 64 from row 300 (exact in binary): > 0.5 from row 333, > 1 from row 365.
  auto r = run(d, 1000, [](int k, int) { return k < 300 || k > 600 ? 0.0 : (k - 300) / 64.0; }, moving);
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(r.rows[0].t_onset_estimate, 333 * kDt);
  EXPECT_DOUBLE_EQ(r.rows[0].t_detect, 365 * kDt);
}

TEST(Detector, OnsetUsesTheCalibratedBand) {
  Thresholds t = constant({1});
  t.joints[0].band = 0.25;  // the usual band from calibration
  Detector d(t, {}, false);
  auto r = run(d, 1000, [](int k, int) { return k < 300 || k > 600 ? 0.0 : (k - 300) / 64.0; }, moving);
  ASSERT_FALSE(r.rows.empty());
  EXPECT_DOUBLE_EQ(r.rows[0].t_onset_estimate, 317 * kDt);  // (k - 300) / 64 > 0.25 from 317
  DetectorOptions o;
  o.onset_band = 0.125;  // --onset-band overrides the profile
  Detector d2(t, o, false);
  auto r2 = run(d2, 1000, [](int k, int) { return k < 300 || k > 600 ? 0.0 : (k - 300) / 64.0; }, moving);
  EXPECT_DOUBLE_EQ(r2.rows[0].t_onset_estimate, 309 * kDt);
}

TEST(Detector, NoisyStreamWithInjectedPulsesFindsEveryPulseAtItsOnset) {
  // Gaussian noise (sigma 0.1) on three joints; 20 pulses of 2 Nm on a random link i, felt by
  // joints 1..i; threshold 0.6 (6 sigma: no false alarm expected in 60000 x 3 samples).
  std::mt19937_64 rng(42);
  std::normal_distribution<double> noise(0.0, 0.1);
  std::uniform_int_distribution<int> link_of(1, 3);
  struct Pulse {
    int start, link;
  };
  std::vector<Pulse> pulses;
  for (int p = 0; p < 20; ++p) pulses.push_back({1000 + p * 3000, link_of(rng)});
  Thresholds t = constant({0.6, 0.6, 0.6});
  for (auto& J : t.joints) J.band = 0.26;  // about the p99 of |noise|
  Detector d(t, {}, false);
  const int rows = 62000;
  std::vector<double> x(3), dq(3, 0.5);
  std::vector<Event> onsets, ends;
  std::vector<std::vector<double>> history(3, std::vector<double>(rows));
  for (int k = 0; k < rows; ++k) {
    for (int j = 0; j < 3; ++j) {
      x[j] = noise(rng);
      for (const auto& p : pulses)
        if (k >= p.start && k < p.start + 300 && j < p.link) x[j] += 2.0;
      history[j][k] = x[j];
    }
    for (const Event& e : d.step(k * kDt, x.data(), dq.data())) (e.kind == EventKind::onset ? onsets : ends).push_back(e);
  }
  ASSERT_EQ(onsets.size(), pulses.size());
  ASSERT_EQ(ends.size(), pulses.size());
  for (std::size_t p = 0; p < pulses.size(); ++p) {
    const int start = pulses[p].start;
    // A 2 Nm step over 0.1 noise crosses 0.6 on its first row.
    EXPECT_DOUBLE_EQ(onsets[p].t_detect, start * kDt) << p;
    // The onset is the first row of the out-of-band run: the step row, unless the noise put
    // the rows just before it out of the band too (computed here from the same samples).
    int expected = start;
    while (expected > 0) {
      bool out = false;
      for (int j : onsets[p].joints) out = out || std::fabs(history[j - 1][expected - 1]) > 0.26;
      if (!out) break;
      --expected;
    }
    EXPECT_LE(onsets[p].t_onset_estimate, start * kDt) << p;
    EXPECT_GE(onsets[p].t_onset_estimate, expected * kDt - 1e-12) << p;
    EXPECT_EQ(ends[p].link, pulses[p].link) << p;
  }
}

TEST(Detector, EndRowAtEndOfInput) {
  Detector d(constant({1}), {}, false);
  auto r = run(d, 100, [](int k, int) { return k >= 90 ? 2.0 : 0.0; }, moving);
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_EQ(r.rows[1].ended_by, EndReason::eof);
  EXPECT_DOUBLE_EQ(r.rows[1].t_end, 99 * kDt);
  EXPECT_EQ(d.finish(EndReason::eof), nullptr);  // nothing open any more
}

TEST(Detector, EventsAreNumberedAndNeverInterleave) {
  DetectorOptions o;
  o.hold = 10 * kDt;
  Detector d(constant({1, 1}), o, false);
  auto r = run(d, 5000, [](int k, int j) { return (k / 500) % 2 == 1 && j == (k / 1000) % 2 ? 3.0 : 0.0; }, moving);
  ASSERT_EQ(r.rows.size(), 10u);
  for (std::size_t i = 0; i < r.rows.size(); ++i) {
    EXPECT_EQ(r.rows[i].id, i / 2 + 1);
    EXPECT_EQ(r.rows[i].kind, i % 2 ? EventKind::end : EventKind::onset);
  }
  EXPECT_EQ(d.events(), 5u);
}

TEST(Detector, NanResidualNeitherFiresNorKeepsAnEventOpen) {
  DetectorOptions o;
  o.hold = 0;
  Detector d(constant({1}), o, false);
  auto r = run(d, 100, [](int k, int) {
    if (k < 10) return std::nan("");
    return k < 20 ? 2.0 : std::nan("");
  }, moving);
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(r.rows[0].t_detect, 10 * kDt);
  EXPECT_DOUBLE_EQ(r.rows[1].t_end, 20 * kDt);
}

TEST(Detector, VelocityEnvelopeRaisesTheThresholdWithSpeed) {
  Thresholds t = constant({10});
  t.joints[0].envelope = JointThreshold::Envelope{1.0, 2.0};  // 1 + 2 |dq|
  // |x| = 2: quiet at |dq| = 0.6 (threshold 2.2), fires at |dq| = 0.4 (threshold 1.8).
  for (bool use : {true, false}) {
    DetectorOptions o;
    o.use_envelope = use;
    Detector d(t, o, true);
    auto r = run(d, 1000, [](int, int) { return 2.0; }, [](int k, int) { return k < 500 ? -0.6 : 0.4; });
    if (use) {
      ASSERT_EQ(r.rows.size(), 2u);
      EXPECT_DOUBLE_EQ(r.rows[0].t_detect, 500 * kDt);
    } else {
      EXPECT_TRUE(r.rows.empty());  // the constant 10 holds
    }
  }
  // Without velocities the constant applies.
  Detector d(t, {}, false);
  EXPECT_TRUE(run(d, 100, [](int, int) { return 2.0; }, moving).rows.empty());
}

namespace {
Thresholds with_rest(double moving, double rest, bool absolute = false) {
  Thresholds t = constant({moving});
  t.rest_rule = RestRule{0.01, 100 * kDt, 0};
  t.joints[0].rest = rest;
  t.joints[0].rest_absolute = absolute;
  return t;
}
auto still = [](int, int) { return 0.001; };
}  // namespace

TEST(Detector, RestStateJudgesTheChangeSinceTheJointSettled) {
  // At rest from row 0 with the residual at -1.9 Nm (static friction held). Rows 0..100 settle
  // (t >= 0.1 s at row 100); the baseline is -1.9. A push of +1 Nm at rows 2000..2499 moves
  // the residual to -0.9: under the moving threshold of 2 in magnitude, but 1 Nm off the
  // baseline, over the rest threshold of 0.5.
  Detector d(with_rest(2, 0.5), {}, true);
  auto r = run(d, 4000, [](int k, int) { return -1.9 + (k >= 2000 && k < 2500 ? 1.0 : 0.0); }, still);
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(r.rows[0].t_detect, 2000 * kDt);
  EXPECT_DOUBLE_EQ(r.rows[1].t_end, 2500 * kDt);
  EXPECT_EQ(d.rest_rows(0), 4000u - 100u);
  // The same stream judged by the moving rule alone: nothing.
  Detector blind(constant({2}), {}, true);
  EXPECT_TRUE(run(blind, 4000, [](int k, int) { return -1.9 + (k >= 2000 && k < 2500 ? 1.0 : 0.0); }, still).rows.empty());
}

TEST(Detector, RestBaselineIsTheMeanOverTheSettlingRows) {
  // Settling rows 0..100 alternate 0.4 and 0.6 (51 of 0.4, 50 of 0.6), then the residual sits
  // at 0.9: 0.9 - baseline = 0.40099... from the exact mean.
  const double baseline = (51 * 0.4 + 50 * 0.6) / 101;
  auto x = [](int k, int) { return k <= 100 ? (k % 2 ? 0.6 : 0.4) : 0.9; };
  Detector quiet(with_rest(5, 0.401), {}, true);
  EXPECT_TRUE(run(quiet, 1000, x, still).rows.empty());
  Detector fires(with_rest(5, 0.9 - baseline - 1e-9), {}, true);
  auto r = run(fires, 1000, x, still);
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(r.rows[0].t_detect, 101 * kDt);
}

TEST(Detector, AbsoluteRestStatistic) {
  // rest_absolute: |x| at rest against the rest threshold (3), the moving one (2) in motion.
  Detector d(with_rest(2, 3, true), {}, true);
  auto r = run(d, 4000, [](int k, int) { return k <= 100 ? 0.0 : 2.5; },
               [](int k, int) { return k < 3000 ? 0.001 : 0.5; });
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(r.rows[0].t_detect, 3000 * kDt);  // moving again: 2.5 > 2
}

TEST(Detector, LeavingRestEndsTheRestRuleAtOnce) {
  // Baseline 0 at rest; the joint moves from row 1000 with the residual at 1 (under the moving
  // threshold 2, over the rest threshold 0.5): no event.
  Detector d(with_rest(2, 0.5), {}, true);
  EXPECT_TRUE(run(d, 3000, [](int k, int) { return k < 1000 ? 0.0 : 1.0; },
                  [](int k, int) { return k < 1000 ? 0.0 : 0.3; }).rows.empty());
}

TEST(Detector, AFiredJointCannotSettleIntoItsContact) {
  // Moving, a contact of 3 Nm fires at row 500 and stops the joint at row 600; the contact
  // lasts to row 2000. Were the stopped joint allowed to rest, its baseline would absorb the
  // contact and the event would end near row 900; it must last to row 2000.
  Detector d(with_rest(2, 0.5), {}, true);
  auto r = run(d, 4000, [](int k, int) { return k >= 500 && k < 2000 ? 3.0 : 0.0; },
               [](int k, int) { return k < 600 ? 0.5 : 0.0; });
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(r.rows[1].t_end, 2000 * kDt);
  // After the event the joint settles and rests normally.
  EXPECT_GT(d.rest_rows(0), 1500u);
}

TEST(Detector, SlowStateHoldsForTheHangoverAfterTheJointPicksUpSpeed) {
  // Slow threshold 3, moving 1; the joint reverses (|dq| < 0.01) on rows 1000..1009 and the
  // residual spikes to 2 over rows 1000..1109: rows up to 1009 + 100 (hangover 100 rows) are
  // slow, so only row 1109 (moving again, 2 > 1) fires.
  Thresholds t = constant({1});
  t.rest_rule = RestRule{0.01, 1.0, 100 * kDt};
  t.joints[0].slow = 3;
  Detector d(t, {}, true);
  auto r = run(d, 3000, [](int k, int) { return k >= 1000 && k < 1110 ? 2.0 : 0.0; },
               [](int k, int) { return k >= 1000 && k < 1010 ? 0.0 : 0.5; });
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(r.rows[0].t_detect, 1109 * kDt);
  // With no hangover, the spike fires as soon as the joint is moving again.
  t.rest_rule.hangover = 0;
  Detector d0(t, {}, true);
  auto r0 = run(d0, 3000, [](int k, int) { return k >= 1000 && k < 1110 ? 2.0 : 0.0; },
                [](int k, int) { return k >= 1000 && k < 1010 ? 0.0 : 0.5; });
  ASSERT_EQ(r0.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(r0.rows[0].t_detect, 1010 * kDt);
}

TEST(Detector, SkipKeepsTheFirstSecondsFromFiring) {
  // An observer start-up transient over the threshold on rows 0..19; skip 30 rows.
  DetectorOptions o;
  o.skip = 30 * kDt;
  Detector d(constant({1}), o, false);
  auto r = run(d, 500, [](int k, int) { return k < 20 || (k >= 300 && k < 310) ? 2.0 : 0.0; }, moving);
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(r.rows[0].t_detect, 300 * kDt);
  // A contact still over the threshold when the skip ends fires on the first judged row.
  Detector late(constant({1}), o, false);
  auto r2 = run(late, 500, [](int k, int) { return k < 40 ? 2.0 : 0.0; }, moving);
  ASSERT_EQ(r2.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(r2.rows[0].t_detect, 30 * kDt);
}

TEST(Detector, ASecondContactInsideAnOpenEventIsItsOwnEvent) {
  // Joint 1 is pushed to 2 x threshold from row 1000 to 3000 and stays there; joint 3 is hit
  // at row 2000, 1 s later (beyond the join time): two contacts, two events. Then joint 1
  // falls back, rises again after 0.5 s back: a third.
  Detector d(constant({1, 1, 1}), {}, false);
  auto r = run(d, 6000, [](int k, int j) {
    if (j == 0 && ((k >= 1000 && k < 3000) || (k >= 3512 && k < 4000))) return 2.0;
    if (j == 2 && k >= 2000 && k < 2500) return 2.0;
    return 0.0;
  }, moving);
  std::vector<Event> onsets, ends;
  for (const auto& e : r.rows) (e.kind == EventKind::onset ? onsets : ends).push_back(e);
  ASSERT_EQ(onsets.size(), 3u);
  ASSERT_EQ(ends.size(), 3u);
  EXPECT_DOUBLE_EQ(onsets[0].t_detect, 1000 * kDt);
  EXPECT_DOUBLE_EQ(onsets[1].t_detect, 2000 * kDt);
  EXPECT_EQ(onsets[1].link, 3);
  EXPECT_EQ(ends[0].ended_by, EndReason::next);
  EXPECT_DOUBLE_EQ(ends[0].t_end, 2000 * kDt);
  EXPECT_DOUBLE_EQ(onsets[2].t_detect, 3512 * kDt);
  // Joints that fire together (within the join time) stay one event.
  Detector together(constant({1, 1, 1}), {}, false);
  auto t = run(together, 3000, [](int k, int j) { return k >= 1000 + 50 * j && k < 2000 ? 2.0 : 0.0; }, moving);
  ASSERT_EQ(t.rows.size(), 2u);
  EXPECT_EQ(t.rows[1].joints, std::vector<int>({1, 2, 3}));
}

TEST(Detector, AJointThatDipsBrieflyDoesNotReArm) {
  // A contact that sags under half the threshold for 0.1 s (less than the hold) is one event.
  Detector d(constant({1}), {}, false);
  auto r = run(d, 4000, [](int k, int) {
    if (k >= 1000 && k < 3000) return k >= 2000 && k < 2100 ? 0.3 : 2.0;
    return 0.0;
  }, moving);
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_EQ(r.rows[1].ended_by, EndReason::release);
}

namespace {
// The residual of a joint a contact loaded with `load` Nm from t = 1 s to 3 s, in the shape a
// position controller gives it after the release (mo-sim's plant, the UR10e's logs): back in
// its band for 0.3 s while the arm snaps back, then the torque its integrator built up and
// stiction now holds shows (rising at 0.3 s) and unloads at the integral time, 2 s.
double after_release(double t, double load, double held) {
  if (t < 1) return 0;
  if (t < 3) return load;
  const double s = t - 3.3;
  return s < 0 ? 0 : held * -std::expm1(-s / 0.3) * std::exp(-s / 2);
}
int count_onsets(const Run& r) {
  int onsets = 0;
  for (const auto& e : r.rows) onsets += e.kind == EventKind::onset;
  return onsets;
}
}  // namespace

TEST(Detector, TheControllersUnloadingAfterAReleaseIsNoNewEvent) {
  // Threshold 1; the push loads 3 Nm for 2 s, the controller then shows up to 1.6 x 0.8 ~ 1.2 Nm
  // (over the threshold) while it unloads. The held torque the detector allows for after the
  // event is 3 (1 - e^-1) = 1.9 Nm at its end, decaying at 2 s: the unloading stays under it.
  auto x = [](int k, int) { return after_release(k * kDt, 3, 1.6); };
  Detector with(constant({1}), {}, false);
  auto r = run(with, 10 * 1024, x, moving);
  EXPECT_EQ(count_onsets(r), 1);
  // Without the aftermath the unloading is a second event (the defect of issue 25).
  DetectorOptions off;
  off.aftermath = 0;
  Detector without(constant({1}), off, false);
  EXPECT_EQ(count_onsets(run(without, 10 * 1024, x, moving)), 2);
}

TEST(Detector, ASecondContactDuringTheAftermathIsStillFound) {
  // During the unloading, at t = 4.5 s, a second push of 3 Nm, a step or a ramp over 0.2 s. On
  // the side the first loaded, it is seen once it rises beyond threshold + held torque
  // (1 + 1.9 e^(-1.3/2) ~ 2.0 Nm, with the unloading's own ~1 Nm under it): the step on its
  // first row, the ramp within 0.1 s. On the other side nothing is held: the ramp is detected
  // on the first row where the residual is under -threshold. (Without the aftermath the
  // unloading opens an event of its own that is still open at 4.5 s: the push goes unseen.)
  const int at = static_cast<int>(4.5 * 1024);
  for (double sign : {1.0, -1.0}) {
    for (double ramp : {0.0, 0.2}) {
      auto x = [&](int k, int) {
        const double t = k * kDt, s = t - at * kDt;
        const double push = s < 0 || s > 1 ? 0 : (ramp > 0 ? std::min(1.0, s / ramp) : 1.0) * 3;
        return after_release(t, 3, 1.6) + sign * push;
      };
      Detector d(constant({1}), {}, false);
      auto r = run(d, 10 * 1024, x, moving);
      std::vector<Event> onsets;
      for (const auto& e : r.rows)
        if (e.kind == EventKind::onset) onsets.push_back(e);
      ASSERT_EQ(onsets.size(), 2u) << sign << " " << ramp;
      const double delay = onsets[1].t_detect - at * kDt;
      if (ramp == 0) {
        EXPECT_EQ(delay, 0) << sign;
      } else if (sign > 0) {
        EXPECT_GT(delay, 0);
        EXPECT_LT(delay, 0.1);
      } else {
        // The first row where the residual itself is under -threshold: nothing added.
        int k = at;
        while (!(x(k, 0) < -1)) ++k;
        EXPECT_DOUBLE_EQ(onsets[1].t_detect, k * kDt);
      }
    }
  }
}

TEST(Detector, AJointAtRestJudgesTheLevelItSettledAtAfterAContact) {
  // At rest, absolute rest statistic (threshold 0.5). A push of 3 Nm from 1 s to 3 s; after it
  // stiction holds 0.9 Nm for good (over the threshold): torque the controller built up against
  // that push, no new contact. With the aftermath it is judged by its change from the level it
  // settles at too: one event. A second push of 2 Nm at 8 s is found at once.
  auto held = [](int k, int) {
    const double t = k * kDt;
    double x = t >= 1 && t < 3 ? 3.0 : (t >= 3.3 ? 0.9 * -std::expm1(-(t - 3.3) / 0.3) : 0.0);
    return x + (t >= 8 && t < 9 ? 2.0 : 0.0);
  };
  Detector d(with_rest(5, 0.5, true), {}, true);
  auto r = run(d, 12 * 1024, held, still);
  std::vector<Event> onsets;
  for (const auto& e : r.rows)
    if (e.kind == EventKind::onset) onsets.push_back(e);
  ASSERT_EQ(onsets.size(), 2u);
  EXPECT_DOUBLE_EQ(onsets[0].t_detect, 1.0);
  EXPECT_DOUBLE_EQ(onsets[1].t_detect, 8.0);
  // Without it the held level is taken for a contact on its own, and the event it opens stays
  // open over the second push, which then goes unreported.
  DetectorOptions off;
  off.aftermath = 0;
  Detector without(with_rest(5, 0.5, true), off, true);
  auto w = run(without, 12 * 1024, held, still);
  ASSERT_EQ(count_onsets(w), 2);
  EXPECT_LT(w.rows[2].t_detect, 4.0);
  EXPECT_EQ(w.rows[2].kind, EventKind::onset);
}
