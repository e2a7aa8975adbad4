// StreamDetector, mo-detect's driver: options, events written as they come, the annotator's
// place beside the detector (rows, annotations, the class decided for the hooks), the summary.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "momentum/detect/stream_detector.hpp"
#include "momentum/stream/error.hpp"

using namespace momentum::detect;

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

// Records what the driver hands it, and decides the class on a chosen row.
class FakeAnnotator final : public EventAnnotator {
 public:
  explicit FakeAnnotator(int* rows) : rows_(rows) {}
  void add(double, const double*, const double*, const double*) override { ++*rows_; }
  void annotate(Event& event) override { event.contact.seen = "point"; }
  std::optional<std::string_view> decide() override {
    if (*rows_ == 3) return "collision";
    return std::nullopt;
  }
  bool classifies() const override { return true; }

 private:
  int* rows_;
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
  EXPECT_NE(text.find(",seen\n"), std::string::npos) << text;  // with the contact columns
  EXPECT_NE(text.find(",onset,1,"), std::string::npos) << text;
  EXPECT_NE(text.find("point\n"), std::string::npos) << text;
  EXPECT_EQ(read_text(hooks), "collision collision\n");
  std::filesystem::remove_all(dir);
}

}  // namespace
