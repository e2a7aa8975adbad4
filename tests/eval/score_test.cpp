// mo-eval's matching on a hand-made case whose every count is worked out by hand, and the
// readers on the formats they must accept.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "momentum/core/error.hpp"
#include "momentum/eval/score.hpp"

namespace momentum::eval {
namespace {

std::string write_temp(const std::string& name, const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / ("momentum-eval-test-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto path = dir / name;
  std::ofstream(path) << text;
  return path.string();
}

// Five contacts over 100 s (see the events below for the outcome of each).
const char* kTruth =
    "# mo-sim (hand-made)\n"
    "# duration: 100\n"
    "t_onset,t_end,link,clamp,f_peak,tau_peak1,tau_peak2\n"
    "10,10.5,2,0,80,-12.5,3\n"
    "20,21,3,0,60,1,2\n"
    "30,30.2,3,0,40,0.5,-0.75\n"
    "40,42,2,1,120,4,5\n"
    "50,50.3,3,0,90,6,7\n";

// In mo-detect's format, out of order, with end rows that must be ignored.
const char* kEvents =
    "# mo-detect (hand-made)\n"
    "t_onset_estimate,t_detect,link,joints,kind,event,t_end,ended_by,peak1,peak2,peak3\n"
    "4.9,5,1,1,onset,1,,,9,0,0\n"            // before any contact: false alarm
    "4.9,5,1,1,end,1,5.2,release,9,0,0\n"
    "10.02,10.08,2,1;2,onset,2,,,9,9,0\n"    // contact 1: 80 ms, link right
    "10.02,10.3,2,1;2,end,2,10.9,release,9,9,0\n"
    "20.01,20.05,2,1;2,onset,3,,,9,9,0\n"    // contact 2: 50 ms, link wrong (2 for 3)
    "10.25,10.3,2,1;2,onset,4,,,9,9,0\n"     // contact 1 again: a repeat
    "40.7,40.8,2,1;2,onset,5,,,9,9,0\n"      // contact 4 after its 0.5 s window: late, missed
    "50.4,50.5,2,1;2,onset,6,,,9,9,0\n"      // contact 5 at the window's edge: 500 ms, link 2
    "50.4,50.5,3,1;2;3,end,6,51,release,9,9,9\n"  // ... then joint 3 fires: final link 3, right
    "59.9,60,1,1,onset,7,,,9,0,0\n";         // collision-free: false alarm
// Contact 3 (t 30) has no event: missed.

TEST(Score, HandMadeCase) {
  const Truth truth = read_truth(write_temp("truth.csv", kTruth));
  ASSERT_EQ(truth.contacts.size(), 5u);
  ASSERT_TRUE(truth.duration.has_value());
  EXPECT_EQ(*truth.duration, 100.0);
  const auto events = read_detections(write_temp("events.csv", kEvents));
  ASSERT_EQ(events.size(), 7u);  // onset rows only
  const Score s = score(truth, events, {});
  EXPECT_EQ(s.contacts, 5);
  EXPECT_EQ(s.detected, 3);
  EXPECT_EQ(s.missed, 2);
  EXPECT_EQ(s.false_alarms, 2);
  EXPECT_EQ(s.repeats, 1);
  EXPECT_EQ(s.late, 1);
  EXPECT_EQ(s.isolated, 2);               // contacts 1 and 5 (by its end row)
  EXPECT_EQ(s.isolated_at_detection, 1);  // contact 1 only
  EXPECT_NEAR(s.delay.min, 0.05, 1e-12);
  EXPECT_NEAR(s.delay.median, 0.08, 1e-12);
  EXPECT_NEAR(s.delay.max, 0.5, 1e-12);
  EXPECT_NEAR(s.delay.p95, 0.08 + 0.9 * (0.5 - 0.08), 1e-12);  // sorted .05 .08 .5, position 1.9
  // Busy spans [onset, end + 0.5]: 1 + 1.5 + 0.7 + 2.5 + 0.8 = 6.5 s of 100.
  ASSERT_TRUE(s.collision_free.has_value());
  EXPECT_NEAR(*s.collision_free, 93.5, 1e-12);
  EXPECT_NEAR(*s.false_alarms_per_hour, 2 / (93.5 / 3600), 1e-9);
  EXPECT_EQ(s.false_alarm_times, (std::vector<double>{5, 60}));
  // Onset estimates: |10.02 - 10|, |20.01 - 20|, |50.4 - 50| -> median 0.02.
  EXPECT_NEAR(s.onset_error.median, 0.02, 1e-12);
  ASSERT_EQ(s.by_link.size(), 2u);
  EXPECT_EQ(s.by_link[0].link, 2);
  EXPECT_EQ(s.by_link[0].contacts, 2);
  EXPECT_EQ(s.by_link[0].detected, 1);
  EXPECT_EQ(s.by_link[0].isolated, 1);
  EXPECT_EQ(s.by_link[1].contacts, 3);
  EXPECT_EQ(s.by_link[1].detected, 2);
  EXPECT_EQ(s.by_link[1].isolated, 1);

  // A tighter window loses contact 5 (500 ms) and its event becomes late.
  ScoreOptions narrow;
  narrow.window = 0.2;
  const Score t = score(truth, events, narrow);
  EXPECT_EQ(t.detected, 2);
  EXPECT_EQ(t.late, 2);
  EXPECT_EQ(t.false_alarms, 2);

  const auto json = to_json(s);
  EXPECT_EQ(json["detected"], 3);
  EXPECT_EQ(json["false_alarms"], 2);
  EXPECT_NEAR(json["delay_s"]["median"].get<double>(), 0.08, 1e-12);
  const std::string table = format_table(s, true);
  EXPECT_NE(table.find("detected      3 of 5 (60.0%)"), std::string::npos) << table;
  EXPECT_NE(table.find("contact t 30.000 link 3 40.0 N (joints up to 0.8 Nm): MISSED\n"), std::string::npos) << table;
  EXPECT_NE(table.find("contact t 10.000 link 2 80.0 N (joints up to 12.5 Nm): detected after 80.0 ms, link 2\n"), std::string::npos) << table;
  EXPECT_NE(table.find("contact t 50.000 link 3 90.0 N (joints up to 7.0 Nm): detected after 500.0 ms, link 3, link 2 at detection\n"),
            std::string::npos) << table;
  EXPECT_NE(table.find("contact t 40.000 link 2 120.0 N (joints up to 5.0 Nm) clamp: MISSED\n"), std::string::npos) << table;
  EXPECT_NE(table.find("false alarm t 60.000\n"), std::string::npos) << table;
}

TEST(Score, MinimalEventFilesAndEventNumbers) {
  // The least a detector must write: t_detect and link, in any column order, extra columns
  // ignored.
  auto events = read_detections(write_temp("minimal.csv", "link,score,t_detect\n2,0.9,10.1\n3,0.5,20.2\n"));
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].link, 2);
  EXPECT_EQ(events[1].t_detect, 20.2);
  EXPECT_TRUE(std::isnan(events[0].t_onset_estimate));
  // Without a kind column, the first row of each event number counts.
  events = read_detections(write_temp("numbered.csv", "event,t_detect,link\n1,10.1,2\n1,10.1,3\n2,20.2,3\n"));
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].link, 2);
}

TEST(Score, BadRowsAreReportedAndSkippedOrStopStrictMode) {
  const std::string path = write_temp("bad.csv", "t_detect,link\n10.1,2\nsoon,3\n20.2,3,7\n30,2\n");
  std::vector<std::string> warnings;
  auto previous = set_warning_sink([&](std::string_view m) { warnings.emplace_back(m); });
  const auto events = read_detections(path);
  set_warning_sink(previous);
  EXPECT_EQ(events.size(), 2u);
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_NE(warnings[0].find("bad.csv:3: bad t_detect 'soon'; row skipped"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[1].find("bad.csv:4: 3 fields, header has 2; row skipped"), std::string::npos) << warnings[1];
  EXPECT_THROW(read_detections(path, true), Error);
  EXPECT_THROW(read_detections(write_temp("nolink.csv", "t_detect,joints\n1,2\n")), Error);
}

TEST(Score, NoDurationNoRateAndPercentiles) {
  Truth truth;
  truth.contacts.push_back({1.0, 1.2, 2, false, NAN});
  const Score s = score(truth, {}, {});
  EXPECT_EQ(s.missed, 1);
  EXPECT_FALSE(s.false_alarms_per_hour.has_value());
  EXPECT_TRUE(to_json(s)["false_alarms_per_hour"].is_null());
  // numpy.percentile([1, 2, 3, 4], [50, 95]) = 2.5, 3.85
  EXPECT_DOUBLE_EQ(percentile({4, 1, 3, 2}, 50), 2.5);
  EXPECT_NEAR(percentile({4, 1, 3, 2}, 95), 3.85, 1e-12);
  EXPECT_TRUE(std::isnan(percentile({}, 50)));
  ScoreOptions bad;
  bad.window = 0;
  EXPECT_THROW(score(truth, {}, bad), Error);
}

}  // namespace
}  // namespace momentum::eval

namespace momentum::eval {
namespace {

// Calibration on five statements worked out by hand.
TEST(Score, CalibrationOfHandMadeStatements) {
  const Calibration c = calibration({{0.9, true}, {0.9, true}, {0.9, false}, {0.2, false}, {0.2, true}, {NAN, true}});
  EXPECT_EQ(c.statements, 5);  // the NaN is left out
  EXPECT_EQ(c.came_true, 3);
  // (0.1^2 + 0.1^2 + 0.9^2 + 0.2^2 + 0.8^2) / 5
  EXPECT_NEAR(c.brier, (0.01 + 0.01 + 0.81 + 0.04 + 0.64) / 5, 1e-12);
  EXPECT_NEAR(c.log_loss, -(2 * std::log(0.9) + std::log(0.1) + std::log(0.8) + std::log(0.2)) / 5, 1e-12);
  ASSERT_EQ(c.bins.size(), 5u);
  EXPECT_EQ(c.bins[1].statements, 2);  // 0.2 falls in [0.2, 0.4)
  EXPECT_EQ(c.bins[1].came_true, 1);
  EXPECT_NEAR(c.bins[1].mean_stated, 0.2, 1e-12);
  EXPECT_EQ(c.bins[4].statements, 3);
  EXPECT_EQ(c.bins[4].came_true, 2);
  EXPECT_NEAR(c.bins[4].mean_stated, 0.9, 1e-12);
  EXPECT_EQ(c.bins[0].statements, 0);
  EXPECT_TRUE(std::isnan(c.bins[0].mean_stated));
  // Certainty that came true: no loss; certainty that did not: the log-loss's floor.
  EXPECT_NEAR(calibration({{1.0, true}}).log_loss, -std::log(1 - 1e-6), 1e-12);
  EXPECT_NEAR(calibration({{1.0, false}}).log_loss, -std::log(1e-6), 1e-9);
}

// Three contacts; the events state link sets and probabilities in mo-detect's columns.
TEST(Score, LinkSetsAgainstTheTruth) {
  const char* truth =
      "t_onset,t_end,link,clamp,f_peak\n"
      "10,10.5,2,0,80\n"
      "20,21,3,1,60\n"
      "30,30.5,4,1,60\n";
  const char* events =
      "t_onset_estimate,t_detect,link,joints,kind,event,t_end,ended_by,peak1,peak2,peak3,peak4,peak5,"
      "class,rise,width,f,fx,fy,fz,f_sd,px,py,pz,p_sd,f_peak,impulse,fit,seen,links,link_set,p_set,p_collision\n"
      // truth 2 in the set {2, 3}
      "10,10.05,2,1;2,onset,1,,,1,1,0,0,0,,,,,,,,,,,,,,,,,,,,\n"
      "10,10.05,2,1;2,end,1,10.6,release,1,1,0,0,0,contact,,,,,,,,,,,,,,,force,2:0.6;3:0.35;4:0.05,2;3,0.95,0.25\n"
      // truth 3 not even a candidate
      "20,20.05,4,1;2;3;4,onset,2,,,1,1,1,1,0,,,,,,,,,,,,,,,,,,,,\n"
      "20,20.05,4,1;2;3;4,end,2,21.1,release,1,1,1,1,0,collision,,,,,,,,,,,,,,,point,4:0.95;5:0.05,4,0.95,0.75\n"
      // truth 4 in a set of three
      "30,30.05,5,1;2;3;4;5,onset,3,,,1,1,1,1,1,,,,,,,,,,,,,,,,,,,,\n"
      "30,30.05,5,1;2;3;4;5,end,3,30.6,release,1,1,1,1,1,collision,,,,,,,,,,,,,,,point,5:0.5;4:0.3;3:0.2,3;4;5,1,\n";
  const Score s = score(read_truth(write_temp("sets-truth.csv", truth)),
                        read_detections(write_temp("sets-events.csv", events)), {});
  ASSERT_EQ(s.detected, 3);
  const LinkSetStats& l = s.link_sets;
  EXPECT_EQ(l.with_set, 3);
  EXPECT_EQ(l.truth_in_set, 2);
  EXPECT_EQ(l.truth_in_pair, 1);
  EXPECT_NEAR(l.mean_size, (2 + 1 + 3) / 3.0, 1e-12);
  EXPECT_NEAR(l.mean_stated, (0.95 + 0.95 + 1) / 3, 1e-12);
  // 3 + 2 + 3 candidates, and one statement of 0 for the true link 3 that was none.
  EXPECT_EQ(l.links.statements, 9);
  EXPECT_EQ(l.links.came_true, 3);
  const double brier = (0.4 * 0.4 + 0.35 * 0.35 + 0.05 * 0.05) + (0.95 * 0.95 + 0.05 * 0.05 + 1) +
                       (0.5 * 0.5 + 0.7 * 0.7 + 0.2 * 0.2);
  EXPECT_NEAR(l.links.brier, brier / 9, 1e-12);
  // p_collision: 0.25 for a contact, 0.75 for a collision; the third states none.
  EXPECT_EQ(l.classes.statements, 2);
  EXPECT_NEAR(l.classes.brier, (0.25 * 0.25 + 0.25 * 0.25) / 2, 1e-12);
  EXPECT_NE(format_table(s, true).find("link sets     truth in 2 of 3"), std::string::npos) << format_table(s, true);
}

}  // namespace
}  // namespace momentum::eval

#include <random>

#include "momentum/eval/classes.hpp"

namespace momentum::eval {
namespace {

// Candidate links whose stated probabilities (written at temperature 1) overstate what they
// know: the true link is drawn at temperature 5. The learnt temperature comes back near 5; where
// the statements are right it stays at 1 (never below: the floor).
TEST(Score, LinkTemperatureFromSimulatedOverconfidence) {
  for (const double truth_temperature : {5.0, 1.0}) {
    std::mt19937_64 random(11);
    std::normal_distribution<double> evidence(0.0, 6.0);
    Truth truth;
    std::vector<Detection> detections;
    for (int k = 0; k < 3000; ++k) {
      std::vector<double> e(4), written(4), drawn(4);
      for (double& v : e) v = evidence(random);
      double zw = 0, zd = 0;
      for (int i = 0; i < 4; ++i) zw += written[i] = std::exp(e[i]), zd += drawn[i] = std::exp(e[i] / truth_temperature);
      const int link = 1 + static_cast<int>(std::discrete_distribution<int>(drawn.begin(), drawn.end())(random));
      TruthContact c;
      c.t_onset = 10.0 * (k + 1), c.t_end = c.t_onset + 1, c.link = link;
      truth.contacts.push_back(c);
      Detection d;
      d.t_detect = c.t_onset + 0.01;
      d.link = d.final_link = 1;
      for (int i = 0; i < 4; ++i) d.link_probabilities.emplace_back(i + 1, written[i] / zw);
      detections.push_back(d);
    }
    const LinkTemperature t = learn_link_temperature(truth, detections);
    EXPECT_EQ(t.events, 3000);
    EXPECT_NEAR(t.temperature, truth_temperature, 0.1 * truth_temperature) << truth_temperature;
    EXPECT_LE(t.log_loss, t.log_loss_written + 1e-6);
    // Written at temperature 2 already: the same temperature comes out.
    for (auto& d : detections)
      for (auto& [link, p] : d.link_probabilities) p = std::pow(p, 0.5);
    for (auto& d : detections) {
      double z = 0;
      for (auto& lp : d.link_probabilities) z += lp.second;
      for (auto& lp : d.link_probabilities) lp.second /= z;
    }
    if (truth_temperature > 2) {
      EXPECT_NEAR(learn_link_temperature(truth, detections, 2.0).temperature, truth_temperature, 0.1 * truth_temperature);
    }
  }
}

}  // namespace
}  // namespace momentum::eval

namespace momentum::eval {
namespace {

// Two contacts with stated uncertainties: the first's peak force error (5 N) is within its
// f_peak_sd (6 N) and its point error (0.05 m) outside its p_sd (0.03 m); the second the other
// way round. Their f_sd (the strongest row's force's, 100 N) is not what f_peak is held to.
TEST(Score, CoverageOfTheStatedUncertainties) {
  const char* truth =
      "t_onset,t_end,link,clamp,px,py,pz,f_peak\n"
      "10,10.5,1,0,0,0,0,80\n"
      "20,21,1,1,0.1,0,0,60\n";
  const char* events =
      "t_onset_estimate,t_detect,link,joints,kind,event,t_end,ended_by,peak1,"
      "class,rise,width,f,fx,fy,fz,f_sd,px,py,pz,p_sd,f_peak,impulse,fit,seen,links,link_set,p_set,p_collision,f_peak_sd\n"
      "10,10.05,1,1,onset,1,,,1,,,,,,,,,,,,,,,,,,,,,\n"
      "10,10.05,1,1,end,1,10.6,release,1,,,,,,,,100,0.05,0,0,0.03,85,,,point,,,,,6\n"
      "20,20.05,1,1,onset,2,,,1,,,,,,,,,,,,,,,,,,,,,\n"
      "20,20.05,1,1,end,2,21.1,release,1,,,,,,,,100,0.1,0.02,0,0.03,50,,,point,,,,,2\n";
  const Score s = score(read_truth(write_temp("sd-truth.csv", truth)),
                        read_detections(write_temp("sd-events.csv", events)), {});
  ASSERT_EQ(s.detected, 2);
  EXPECT_EQ(s.identification.force_with_sd, 2);
  EXPECT_EQ(s.identification.force_covered, 1);
  EXPECT_EQ(s.identification.point_with_sd, 2);
  EXPECT_EQ(s.identification.point_covered, 1);
  EXPECT_NE(format_table(s, false).find("within 1 sd   force 1 of 2 (50.0%), point 1 of 2 (50.0%)"), std::string::npos)
      << format_table(s, false);
}

}  // namespace
}  // namespace momentum::eval
