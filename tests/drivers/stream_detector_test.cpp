// StreamDetector, mo-detect's driver: options, events written as they come, the annotator's
// place beside the detector (rows, annotations, the class decided for the hooks), the summary.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "momentum/core/error.hpp"
#include "momentum/drivers/stream_detector.hpp"

using namespace momentum::detect;
using namespace momentum::drivers;

namespace {

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("momentum_stream_detector_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(StreamDetector, OptionsAreChecked) {
  StreamDetectorOptions options;
  std::string why;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_EQ(why, "give a profile (-p) or --threshold");
  options.constant_thresholds = {1};
  EXPECT_TRUE(options.IsValid(&why));
  options.events_path = "events.csv";
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_EQ(why, "--events goes with --pass (events are the output)");
  options.events_path.clear();
  options.pass = true;
  EXPECT_FALSE(options.IsValid(&why));  // no output to pass the stream to
  options.pass = false;
  options.detector.release = 0;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_THROW(StreamDetector{options}, momentum::Error);
}

TEST(StreamDetector, EventsSummaryAndAThresholdPerJoint) {
  const std::string input = temp_path("in.csv"), output = temp_path("events.csv");
  std::ofstream(input) << "t,mu1,mu2\n0,0,0\n0.01,5,0\n0.02,5,3\n0.03,0,0\n0.04,0,0\n";
  StreamDetectorOptions options;
  options.constant_thresholds = {1, 2};
  options.detector.hold = 0;
  options.output = output;
  options.comments = {" test"};
  const StreamDetectorSummary summary = StreamDetector(options).run(input);
  EXPECT_TRUE(summary.finished);
  EXPECT_FALSE(summary.interrupted);
  EXPECT_EQ(summary.rows, 5u);
  EXPECT_NEAR(summary.seconds, 0.04, 1e-12);  // four steps of 0.01 s
  EXPECT_EQ(summary.events, 1u);
  EXPECT_EQ(summary.collisions, 1u);
  EXPECT_TRUE(summary.rest_rows.empty());  // no dq columns
  const std::string text = read_text(output);
  EXPECT_EQ(text.rfind("# test\nt_onset_estimate,t_detect,link,joints,kind,event,t_end,ended_by,peak1,peak2\n", 0), 0u)
      << text;
  EXPECT_NE(text.find(",0.01,1,1,onset,1,,,5,0\n"), std::string::npos) << text;
  EXPECT_NE(text.find(",0.01,2,1;2,end,1,0.03,release,5,3\n"), std::string::npos) << text;
  const std::string stats = format_stream_detector_stats(summary, "mo-detect");
  EXPECT_EQ(stats.rfind("mo-detect: 5 rows over 0.04 s, 0 bad rows skipped, 1 events\n", 0), 0u) << stats;
  // The rows are timed only when asked (mo-detect --stats): two clock reads a row.
  EXPECT_EQ(summary.latency_max, 0.0);
  options.measure_latency = true;
  const StreamDetectorSummary timed = StreamDetector(options).run(input);
  EXPECT_GT(timed.latency_max, 0.0);
  EXPECT_LE(timed.latency_median, timed.latency_p99);
  EXPECT_LE(timed.latency_p99, timed.latency_max);
  std::remove(input.c_str());
  std::remove(output.c_str());
}

// Records what the driver hands it, and decides the class on a chosen row. identify() records
// what the output files held when it ran: the onset row must be out by then.
class FakeAnnotator final : public EventAnnotator {
 public:
  FakeAnnotator(int* rows, std::vector<std::string>* seen_at_identify = nullptr, std::vector<std::string> files = {})
      : rows_(rows), seen_(seen_at_identify), files_(std::move(files)) {}
  void add(double, const double*, const double*, const double*) override { ++*rows_; }
  void annotate(Event& event) override {
    if (event.kind == EventKind::end) event.contact.seen = "point";
  }
  void identify(Event& event) override {
    EXPECT_EQ(event.kind, EventKind::identified);
    event.link = 1;
    event.contact.force = 12.5;
    event.contact.seen = "force";
    if (seen_)
      for (const std::string& file : files_) seen_->push_back(read_text(file));
  }
  std::optional<std::string_view> decide() override {
    if (*rows_ == 3) return "collision";
    return std::nullopt;
  }
  bool classifies() const override { return true; }

 private:
  int* rows_;
  std::vector<std::string>* seen_;
  std::vector<std::string> files_;
};

TEST(StreamDetector, AnnotatorSeesEveryRowAndFillsTheEvents) {
  const std::string dir = temp_path("chain");
  std::filesystem::create_directories(dir);
  // A one-joint chain: the annotator is built only with the profile's chain and q columns.
  std::ofstream(dir + "/arm.urdf")
      << "<robot name=\"arm\"><link name=\"base\"/><link name=\"tip\"><inertial><mass value=\"1\"/>"
         "<origin xyz=\"0.5 0 0\"/><inertia ixx=\"0.01\" iyy=\"0.01\" izz=\"0.01\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/>"
         "</inertial></link><joint name=\"j1\" type=\"revolute\"><parent link=\"base\"/><child link=\"tip\"/>"
         "<axis xyz=\"0 0 1\"/><limit lower=\"-3\" upper=\"3\" effort=\"10\" velocity=\"1\"/></joint></robot>\n";
  std::ofstream(dir + "/arm.json") << R"({"urdf": "arm.urdf", "root": "base", "tip": "tip"})";
  const std::string input = dir + "/in.csv", output = dir + "/events.csv", hooks = dir + "/hooks";
  std::ofstream(input) << "t,q1,mu1\n0,0,0\n0.01,0,5\n0.02,0,5\n0.03,0,0\n";
  int rows = 0;
  StreamDetectorOptions options;
  options.constant_thresholds = {1};
  options.profile_path = dir + "/arm.json";
  options.detector.hold = 0;
  options.output = output;
  options.on_collision = "echo collision $MOMENTUM_CLASS >> " + hooks;
  options.annotator = [&](const momentum::model::Model& chain, const momentum::model::Profile&,
                          const Thresholds& thresholds, const FrictionBand&) -> std::unique_ptr<EventAnnotator> {
    EXPECT_EQ(chain.nq, 1);
    EXPECT_EQ(thresholds.joints.size(), 1u);
    return std::make_unique<FakeAnnotator>(&rows);
  };
  const StreamDetectorSummary summary = StreamDetector(options).run(input);
  EXPECT_EQ(rows, 4);
  EXPECT_EQ(summary.collisions, 1u);
  EXPECT_EQ(summary.hooks_run, 1u);  // on the row the class was decided, not at detection
  const std::string text = read_text(output);
  EXPECT_NE(text.find(",seen,links,link_set,p_set,p_collision,f_peak_sd\n"), std::string::npos) << text;  // with the contact columns
  // The onset row without a fit, then the identified row, then the end row with the whole
  // event's identification.
  EXPECT_NE(text.find("0.01,0.01,1,1,onset,1,,,5,,,,,,,,,,,,,,,,,,,,,\n"
                      "0.01,0.01,1,1,identified,1,,,5,,,,12.5,,,,,,,,,,,,force,,,,,\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find(",end,1,0.03,release,5,,,,,,,,,,,,,,,,point,,,,,\n"), std::string::npos) << text;
  EXPECT_EQ(read_text(hooks), "collision collision\n");
  std::filesystem::remove_all(dir);
}

// The row that crosses the threshold sends its onset row (and with --pass its stream row) out
// before identification starts: identification takes up to tens of milliseconds, the onset
// row and its hook must not wait for it (issue 27: it did, 19 ms).
TEST(StreamDetector, OnsetRowIsOutBeforeIdentification) {
  const std::string dir = temp_path("first");
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/arm.urdf")
      << "<robot name=\"arm\"><link name=\"base\"/><link name=\"tip\"><inertial><mass value=\"1\"/>"
         "<origin xyz=\"0.5 0 0\"/><inertia ixx=\"0.01\" iyy=\"0.01\" izz=\"0.01\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/>"
         "</inertial></link><joint name=\"j1\" type=\"revolute\"><parent link=\"base\"/><child link=\"tip\"/>"
         "<axis xyz=\"0 0 1\"/><limit lower=\"-3\" upper=\"3\" effort=\"10\" velocity=\"1\"/></joint></robot>\n";
  std::ofstream(dir + "/arm.json") << R"({"urdf": "arm.urdf", "root": "base", "tip": "tip"})";
  const std::string input = dir + "/in.csv", events = dir + "/events.csv", passed = dir + "/passed.csv";
  std::ofstream(input) << "t,q1,mu1\n0,0,0\n0.01,0,5\n0.02,0,5\n0.03,0,0\n";
  int rows = 0;
  std::vector<std::string> seen;
  StreamDetectorOptions options;
  options.constant_thresholds = {1};
  options.profile_path = dir + "/arm.json";
  options.detector.hold = 0;
  options.output = passed;
  options.pass = true;
  options.events_path = events;
  options.open_output = [&](momentum::stream::Reader&) {
    momentum::stream::WriterOptions w;
    w.line_buffered = true;  // as a live pipe: every row flushed
    return momentum::stream::Writer::open(passed, w);
  };
  options.annotator = [&](const momentum::model::Model&, const momentum::model::Profile&, const Thresholds&,
                          const FrictionBand&) -> std::unique_ptr<EventAnnotator> {
    return std::make_unique<FakeAnnotator>(&rows, &seen, std::vector<std::string>{events, passed});
  };
  StreamDetector(options).run(input);
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_NE(seen[0].find(",onset,1,"), std::string::npos) << seen[0];
  EXPECT_EQ(seen[0].find(",identified,"), std::string::npos) << seen[0];
  EXPECT_NE(seen[1].find("\n0.01,0,5,1\n"), std::string::npos) << seen[1];  // the row with its collision link
  const std::string text = read_text(events);
  EXPECT_LT(text.find(",onset,1,"), text.find(",identified,1,"));
  EXPECT_LT(text.find(",identified,1,"), text.find(",end,1,"));
  std::filesystem::remove_all(dir);
}

// Rows of `t,mu1,mu2` every 10 ms from t0 for `count` rows; mu1 = `value(t)`, mu2 = 0.
std::string rows_from(double t0, int count, const std::function<std::string(int)>& mu1) {
  std::string text;
  char line[64];
  for (int k = 0; k < count; ++k) {
    std::snprintf(line, sizeof line, "%.2f,%s,0\n", t0 + 0.01 * k, mu1(k).c_str());
    text += line;
  }
  return text;
}

std::vector<std::string> onsets(const std::string& events) {
  std::vector<std::string> out;
  std::istringstream lines(events);
  for (std::string line; std::getline(lines, line);)
    if (line.find(",onset,") != std::string::npos) out.push_back(line);
  return out;
}

// A second log appended to a first whose clock ran far ahead (a controller clock reset): the
// detector starts again at the step, its start-up skip counted from the new time line. Before,
// the skip was measured from the first log's first time, so that t - 1000 < skip held for the
// whole second log and its collision went unseen.
TEST(StreamDetector, AClockStepBackStartsANewLog) {
  const std::string input = temp_path("step.csv"), output = temp_path("step-events.csv");
  auto pulse = [](int from, int to) {
    return [from, to](int k) { return std::string(k >= from && k < to ? "5" : "0"); };
  };
  std::ofstream(input) << "t,mu1,mu2\n" + rows_from(1000, 51, pulse(20, 25)) + rows_from(0, 51, pulse(30, 35));
  std::vector<std::string> warnings;
  auto old = momentum::set_warning_sink([&](std::string_view m) { warnings.emplace_back(m); });
  StreamDetectorOptions options;
  options.constant_thresholds = {1, 1};
  options.detector.skip = 0.1;
  options.detector.hold = 0.05;
  options.output = output;
  const StreamDetectorSummary summary = StreamDetector(options).run(input);
  momentum::set_warning_sink(old);
  const auto found = onsets(read_text(output));
  ASSERT_EQ(found.size(), 2u) << read_text(output);
  EXPECT_EQ(found[0], "1000.2,1000.2,1,1,onset,1,,,5,0");
  EXPECT_EQ(found[1], "0.3,0.3,1,1,onset,2,,,5,0");  // numbered on from the first log
  EXPECT_EQ(summary.rows, 102u);
  EXPECT_EQ(summary.events, 2u);
  EXPECT_NEAR(summary.seconds, 1.0, 1e-9);  // 0.5 s per log; the step adds none
  // The step is a blind span: the new log's start-up skip.
  EXPECT_EQ(summary.blind_spans, 1u);
  EXPECT_EQ(summary.blind_per_cause[static_cast<int>(BlindCause::clock_step)], 1u);
  EXPECT_NEAR(summary.blind_seconds, 0.1, 1e-12);
  EXPECT_NEAR(summary.blind_share, 0.1, 1e-9);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], input + ":53: blind from t=0 to t=0.1 (0.1 s): clock step back: the clock stepped back from "
                                 "t=1000.5 to t=0");
  std::remove(input.c_str());
  std::remove(output.c_str());
}

// An event open at the step ends there (ended_by clock_step); the next log's hold times do not
// reach back into the first.
TEST(StreamDetector, AnEventOpenAtAClockStepEndsThere) {
  const std::string input = temp_path("step-open.csv"), output = temp_path("step-open-events.csv");
  std::ofstream(input) << "t,mu1,mu2\n" + rows_from(10, 11, [](int k) { return std::string(k >= 5 ? "5" : "0"); }) +
                              rows_from(0, 30, [](int k) { return std::string(k >= 10 && k < 12 ? "5" : "0"); });
  StreamDetectorOptions options;
  options.constant_thresholds = {1, 1};
  options.detector.hold = 0.05;
  options.output = output;
  momentum::WarningSink old = momentum::set_warning_sink([](std::string_view) {});
  StreamDetector(options).run(input);
  momentum::set_warning_sink(old);
  const std::string text = read_text(output);
  EXPECT_NE(text.find("10.05,10.05,1,1,end,1,10.1,clock_step,5,0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("0.1,0.1,1,1,onset,2,,,5,0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("0.1,0.1,1,1,end,2,0.12,release,5,0\n"), std::string::npos) << text;
  std::remove(input.c_str());
  std::remove(output.c_str());
}

// A drive dropout: mu1 NaN from t=0.5 to 0.7. Before, the run said nothing at all (0 events,
// no warning, "0 bad rows"): now the span is reported when it begins and when it ends, and
// summed up. mu2 is judged throughout: its collision inside the span is found.
TEST(StreamDetector, NonFiniteResidualsAreABlindSpan) {
  const std::string input = temp_path("nan.csv"), output = temp_path("nan-events.csv");
  std::string text = "t,mu1,mu2\n";
  for (int k = 0; k <= 100; ++k) {
    char line[64];
    std::snprintf(line, sizeof line, "%.2f,%s,%s\n", 0.01 * k, k >= 50 && k < 70 ? "nan" : "0", k == 60 ? "5" : "0");
    text += line;
  }
  std::ofstream(input) << text;
  std::vector<std::string> warnings;
  auto old = momentum::set_warning_sink([&](std::string_view m) { warnings.emplace_back(m); });
  StreamDetectorOptions options;
  options.constant_thresholds = {1, 1};
  options.detector.hold = 0;
  options.output = output;
  const StreamDetectorSummary summary = StreamDetector(options).run(input);
  momentum::set_warning_sink(old);
  EXPECT_EQ(summary.collisions, 1u);
  EXPECT_EQ(onsets(read_text(output)), std::vector<std::string>{"0.6,0.6,2,2,onset,1,,,0,5"});
  EXPECT_EQ(summary.blind_spans, 1u);
  EXPECT_EQ(summary.blind_per_cause[static_cast<int>(BlindCause::not_finite)], 1u);
  EXPECT_NEAR(summary.blind_seconds, 0.2, 1e-12);
  EXPECT_NEAR(summary.blind_share, 0.2, 1e-12);
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_EQ(warnings[0], input + ":52: blind from t=0.5: residuals not finite: mu1 not finite: detection goes on where "
                                 "it can");
  EXPECT_EQ(warnings[1], input + ":52: blind from t=0.5 to t=0.7 (0.2 s): residuals not finite: mu1 not finite on 20 rows");
  EXPECT_EQ(summary.blind_text,
            "blind 1 time for 0.2 s of 1 s (20%): 1 residuals not finite\n  from t=0.5 to t=0.7 (0.2 s): residuals not finite");
  std::remove(input.c_str());
  std::remove(output.c_str());
}

// A bad row costs the time between its neighbours; a cut last row is where the input stopped.
TEST(StreamDetector, SkippedRowsAndACutLastRowAreBlindSpans) {
  const std::string input = temp_path("cut.csv"), output = temp_path("cut-events.csv");
  std::ofstream(input) << "t,mu1,mu2\n0,0,0\n0.01,0,0\n0.02,x,0\n0.03,0,0\n0.04,0,0\n0.05,0";
  StreamDetectorOptions options;
  options.constant_thresholds = {1, 1};
  options.output = output;
  momentum::WarningSink old = momentum::set_warning_sink([](std::string_view) {});
  momentum::RowWarningSink old_rows = momentum::set_row_warning_sink([](std::string_view, std::string_view) {});
  const StreamDetectorSummary summary = StreamDetector(options).run(input);
  momentum::set_warning_sink(old);
  momentum::set_row_warning_sink(old_rows);
  EXPECT_EQ(summary.rows, 4u);
  EXPECT_EQ(summary.rows_skipped, 2u);
  EXPECT_EQ(summary.blind_spans, 2u);
  EXPECT_EQ(summary.blind_per_cause[static_cast<int>(BlindCause::rows_skipped)], 1u);
  EXPECT_EQ(summary.blind_per_cause[static_cast<int>(BlindCause::input_stopped)], 1u);
  EXPECT_NEAR(summary.blind_seconds, 0.02, 1e-12);  // 0.01 to 0.03; the cut row is a point
  std::remove(input.c_str());
  std::remove(output.c_str());
}

TEST(BlindWatch, SpansPerCauseWithTheirTimes) {
  std::vector<std::pair<BlindSpan, bool>> reports;
  BlindWatch watch([&](const BlindSpan& span, bool ended) { reports.emplace_back(span, ended); }, 2);
  EXPECT_TRUE(watch.row(0, 0, "", "a:1"));
  EXPECT_TRUE(watch.row(1, 3, "", "a:5"));     // three rows lost between 0 and 1
  EXPECT_FALSE(watch.row(2, 0, "mu1", "a:6"));  // opens
  EXPECT_FALSE(watch.row(3, 0, "mu1", "a:7"));
  watch.clock_step(3, 0.5, 0.25, "a:8");  // closes the open span at the old line's last row
  EXPECT_TRUE(watch.row(0.5, 0, "", "a:8"));
  watch.input_stopped(0.5, "no row for 2 s", "a");
  EXPECT_TRUE(watch.row(4.5, 0, "", "a:9"));
  watch.finish(1, "a");
  ASSERT_EQ(reports.size(), 7u);
  EXPECT_EQ(reports[0].first.cause, BlindCause::rows_skipped);
  EXPECT_EQ(reports[0].first.t_start, 0);
  EXPECT_EQ(reports[0].first.t_end, 1);
  EXPECT_EQ(reports[0].first.rows, 3u);
  EXPECT_FALSE(reports[1].second);  // the NaN span as it opens
  EXPECT_TRUE(std::isnan(reports[1].first.t_end));
  EXPECT_EQ(reports[2].first.cause, BlindCause::not_finite);
  EXPECT_EQ(reports[2].first.t_end, 3);
  EXPECT_EQ(reports[2].first.rows, 2u);
  EXPECT_EQ(reports[3].first.cause, BlindCause::clock_step);
  EXPECT_EQ(reports[3].first.seconds(), 0.25);
  EXPECT_FALSE(reports[4].second);
  EXPECT_EQ(reports[5].first.cause, BlindCause::input_stopped);
  EXPECT_EQ(reports[5].first.seconds(), 4);
  EXPECT_EQ(reports[6].first.cause, BlindCause::input_stopped);  // the cut row at the end: a point
  EXPECT_EQ(reports[6].first.seconds(), 0);
  EXPECT_EQ(watch.spans(), 5u);
  EXPECT_EQ(watch.seconds(), 1 + 1 + 0.25 + 4);
  EXPECT_EQ(watch.kept().size(), 2u);
  EXPECT_EQ(format_blind_summary(watch, 10),
            "blind 5 times for 6.25 s of 10 s (62.5%): 1 rows skipped, 1 residuals not finite, 1 clock step back, "
            "2 input stopped\n  from t=0 to t=1 (1 s): rows skipped\n  from t=2 to t=3 (1 s): residuals not finite\n"
            "  and 3 more");
}

}  // namespace
