// Reading the fitter's input: column selection, skip and window, NaN rows, restarts, gaps,
// several logs, slow-sample exclusion and the velocity-noise estimate.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <unistd.h>

#include "momentum/core/error.hpp"
#include "momentum/friction_fit/data.hpp"

namespace friction_fit = momentum::friction_fit;

namespace {

// A CSV file in the temporary folder, removed at the end of the test.
class TempCsv {
 public:
  explicit TempCsv(const std::string& text) {
    path_ = std::filesystem::temp_directory_path() /
            ("momentum-fit-data-" + std::to_string(::getpid()) + "-" + std::to_string(counter_++) + ".csv");
    std::ofstream(path_) << text;
  }
  ~TempCsv() { std::filesystem::remove(path_); }
  std::string path() const { return path_.string(); }

 private:
  std::filesystem::path path_;
  static inline int counter_ = 0;
};

std::vector<friction_fit::JointSeries> read(const std::string& text, const friction_fit::SelectOptions& o = {}) {
  TempCsv file(text);
  auto in = momentum::stream::Reader::open(file.path());
  return friction_fit::read_series(*in, o);
}

}  // namespace

TEST(ReadSeries, AllJointsWithDqAndR) {
  const auto s = read("t,q1,dq1,dq2,r1,r2,dq3\n0,0,1,2,3,4,5\n0.01,0,1.5,2.5,3.5,4.5,5.5\n");
  ASSERT_EQ(s.size(), 2u);  // joint 3 has no r3
  EXPECT_EQ(s[0].joint, 1);
  EXPECT_EQ(s[1].joint, 2);
  EXPECT_EQ(s[1].dq, (std::vector<double>{2, 2.5}));
  EXPECT_EQ(s[1].r, (std::vector<double>{4, 4.5}));
  EXPECT_EQ(s[0].restart, (std::vector<std::uint8_t>{2, 0}));
  EXPECT_EQ(s[0].scored_count(), 2u);
  EXPECT_DOUBLE_EQ(s[0].median_dt(), 0.01);
}

TEST(ReadSeries, SelectedJointsSkipAndWindow) {
  std::string text = "t,dq1,r1,dq2,r2\n";
  for (int k = 0; k <= 100; ++k) text += std::to_string(k * 0.1) + ",1,2,3,4\n";
  friction_fit::SelectOptions o;
  o.joints = {2};
  o.skip = 1.0;
  auto s = read(text, o);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].joint, 2);
  EXPECT_EQ(s[0].size(), 101u);
  EXPECT_EQ(s[0].scored_count(), 91u);  // t >= 1.0 counts (1.0 .. 10.0)
  o.skip = 0;
  o.window_begin = 2.0;
  o.window_end = 4.0;
  s = read(text, o);
  EXPECT_EQ(s[0].size(), 41u);          // rows after the window are not kept
  EXPECT_EQ(s[0].scored_count(), 21u);  // 2.0 .. 4.0
  EXPECT_EQ(s[0].scored[19], 0);
  EXPECT_EQ(s[0].scored[20], 1);
}

TEST(ReadSeries, NanRowsGapsAndRestartColumn) {
  const auto s = read(
      "t,dq1,r1,dq2,r2,restart\n"
      "0.00,1,1,1,1,1\n"
      "0.01,1,nan,1,1,0\n"   // joint 1 loses this row only
      "0.02,1,1,1,1,0\n"     // joint 1 restarts here
      "0.03,1,1,1,1,1\n"     // the observer said so
      "0.04,1,1,1,1,0\n"
      "0.05,1,1,1,1,0\n"
      "0.06,1,1,1,1,0\n"
      "0.50,1,1,1,1,0\n");   // a gap of 44 steps
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[0].size(), 7u);
  EXPECT_EQ(s[1].size(), 8u);
  EXPECT_EQ(s[0].restart, (std::vector<std::uint8_t>{2, 1, 1, 0, 0, 0, 1}));
  EXPECT_EQ(s[1].restart, (std::vector<std::uint8_t>{2, 0, 0, 1, 0, 0, 0, 1}));
}

TEST(ReadSeries, TimeNotIncreasingIsRejected) {
  TempCsv file("t,dq1,r1\n0,1,1\n0.01,1,1\n0.01,1,1\n0.005,1,1\n0.02,1,1\n");
  auto in = momentum::stream::Reader::open(file.path());
  const auto s = friction_fit::read_series(*in, {});
  EXPECT_EQ(s[0].size(), 3u);
  EXPECT_EQ(in->rows_skipped(), 2u);
}

TEST(ReadSeries, Errors) {
  EXPECT_THROW(read("t,q1\n0,1\n"), momentum::Error);               // no dq/r
  EXPECT_THROW(read("dq1,r1\n0,1\n"), momentum::Error);             // no t
  friction_fit::SelectOptions o;
  o.joints = {2};
  EXPECT_THROW(read("t,dq1,r1\n0,1,1\n", o), momentum::Error);      // no joint 2
  o = {};
  o.skip = 10;
  EXPECT_THROW(read("t,dq1,r1\n0,1,1\n1,1,1\n", o), momentum::Error);  // nothing left
  o = {};
  o.window_begin = 2;
  o.window_end = 1;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_THROW(read("t,dq1,r1\n0,1,1\n", o), momentum::Error);
}

TEST(AppendSeries, ShiftsTimeAndRestarts) {
  auto a = read("t,dq1,r1\n0,1,1\n0.1,1,1\n0.2,1,1\n")[0];
  const auto b = read("t,dq1,r1\n5,2,2\n5.1,2,2\n")[0];
  friction_fit::append_series(a, b);
  ASSERT_EQ(a.size(), 5u);
  EXPECT_NEAR(a.t[3], 0.3, 1e-12);
  EXPECT_NEAR(a.t[4], 0.4, 1e-12);
  EXPECT_EQ(a.restart, (std::vector<std::uint8_t>{2, 0, 0, 2, 0}));
  EXPECT_EQ(a.dq[3], 2.0);
}

TEST(ExcludeSlowSamples, SlowAndSettling) {
  std::string text = "t,dq1,r1\n";
  for (int k = 0; k < 20; ++k) text += std::to_string(k * 0.01) + "," + (k == 5 ? "0.001" : "1") + ",0\n";
  auto s = read(text)[0];
  // Sample 5 is slow; 0.025 s after it (samples 6, 7) are settling.
  const auto removed = friction_fit::exclude_slow_samples(s, 0.01, 0.025);
  EXPECT_EQ(removed, 3u);
  for (int k = 0; k < 20; ++k) EXPECT_EQ(s.scored[static_cast<std::size_t>(k)], (k >= 5 && k <= 7) ? 0 : 1) << k;
}

TEST(VelocityNoise, EstimatesWhiteNoiseOnSmoothMotion) {
  friction_fit::JointSeries s;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 0.002);
  for (int k = 0; k < 5000; ++k) {
    const double t = k * 0.008;
    s.t.push_back(t);
    s.dq.push_back(0.75 * std::cos(1.2566 * t) + noise(rng));
    s.r.push_back(0);
    s.restart.push_back(k == 0 ? 2 : 0);
    s.scored.push_back(1);
  }
  EXPECT_NEAR(friction_fit::estimate_velocity_noise(s), 0.002, 0.0001);
  for (std::size_t k = 0; k < s.size(); ++k) s.dq[k] = 0.75 * std::cos(1.2566 * s.t[k]);
  EXPECT_LT(friction_fit::estimate_velocity_noise(s), 1e-4);
}

TEST(ReadSeries, LongLogsAreThinnedToEvenlySpreadWindows) {
  // 100 s at 100 Hz, one sample more than the budget allows many times over.
  std::string text = "t,dq1,r1\n";
  for (int k = 0; k <= 10000; ++k) text += std::to_string(k / 100.0) + ",1," + std::to_string(k) + "\n";
  friction_fit::SelectOptions o;
  o.max_samples = 2500;
  o.thin_window = 1.0;
  o.thin_warmup = 0.1;
  const auto s = read(text, o);
  ASSERT_EQ(s.size(), 1u);
  const auto& j = s[0];
  EXPECT_LE(j.size(), o.max_samples);
  EXPECT_GE(j.size(), o.max_samples / 2);  // thinning halves at most once past the budget
  // Whole windows, their starts evenly spaced over the log, each a fresh start whose first
  // 0.1 s (10 samples) do not count; r still holds the row it was read from.
  std::vector<double> starts;
  for (std::size_t k = 0; k < j.size(); ++k) {
    EXPECT_DOUBLE_EQ(j.r[k], std::round(j.t[k] * 100));
    const bool start = k == 0 || j.t[k] - j.t[k - 1] > 0.015;
    EXPECT_EQ(j.restart[k], start ? 2 : 0) << "at t " << j.t[k];
    if (start) starts.push_back(j.t[k]);
    const double into_window = j.t[k] - starts.back();
    if (k > 0 && into_window < 0.1 - 1e-9) {
      EXPECT_EQ(j.scored[k], 0) << "at t " << j.t[k];
    } else if (into_window > 0.1 + 1e-9) {
      EXPECT_EQ(j.scored[k], 1) << "at t " << j.t[k];
    }
  }
  ASSERT_GE(starts.size(), 10u);
  const double spacing = starts[1] - starts[0];
  EXPECT_GE(spacing, 2.0);
  for (std::size_t w = 1; w < starts.size(); ++w) EXPECT_NEAR(starts[w] - starts[w - 1], spacing, 1e-9);
  EXPECT_GT(starts.back(), 100.0 - 2 * spacing);  // the spread reaches the end of the log
  for (std::size_t w = 0; w + 1 < starts.size(); ++w) EXPECT_NEAR(starts[w], std::floor(starts[w]), 1e-9);
}

TEST(ReadSeries, ThinningNeedsWindowsLongerThanTheirWarmUp) {
  friction_fit::SelectOptions o;
  o.thin_window = 1.0;
  o.thin_warmup = 1.0;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("warm-up"), std::string::npos);
}

TEST(ReadSeries, ThinningKeepsAFirstWindowLongerThanTheBudget) {
  std::string text = "t,dq1,r1\n";
  for (int k = 0; k <= 3000; ++k) text += std::to_string(k / 100.0) + ",1,0\n";
  friction_fit::SelectOptions o;
  o.max_samples = 500;
  o.thin_window = 10.0;  // 1000 samples a window, twice the budget
  o.thin_warmup = 0.1;
  const auto s = read(text, o);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].size(), 1000u);  // the first window, whole; the two after it dropped
  EXPECT_DOUBLE_EQ(s[0].t.back(), 9.99);
}

TEST(ThinToBudget, ManyLogsOfOneWindowKeepEvenlySpreadLogsWithinTheBudget) {
  // Eight logs (an hour each, say) that each kept one window of 1000 samples, over the budget of
  // 3000 together: every second log goes, then every fourth, until the budget holds (2000).
  // Two joints share their positions; joint 2 misses the first sample of log 5 (NaN), which
  // does not move the segments it keeps.
  std::vector<friction_fit::JointSeries> day;
  for (int log = 0; log < 8; ++log) {
    std::string text = "t,q1,q2,dq1,r1,dq2,r2\n";
    for (int k = 0; k < 1000; ++k) {
      const std::string r = std::to_string(1000 * log + k);
      text += std::to_string(k / 100.0) + "," + r + ",0,1," + r + "," + (log == 4 && k == 0 ? "nan" : "1") + "," + r + "\n";
    }
    friction_fit::append_log(day, read(text));
  }
  ASSERT_EQ(day.size(), 2u);
  ASSERT_EQ(day[0].size(), 8000u);
  ASSERT_TRUE(day[0].positions);
  EXPECT_EQ(friction_fit::thin_to_budget(day, 3000), 6000u);
  for (const auto& s : day) {
    // Logs 0 and 4, whole, in order, each starting afresh; their r tells which rows they are.
    ASSERT_EQ(s.size(), s.joint == 1 ? 2000u : 1999u);
    for (std::size_t k = 0; k < s.size(); ++k) {
      const int log = s.r[k] < 4000 ? 0 : 4;
      EXPECT_GE(s.r[k], 1000 * log);
      EXPECT_LT(s.r[k], 1000 * log + 1000);
      if (k > 0) {
        EXPECT_GT(s.r[k], s.r[k - 1]);
      }
      const bool log_start = s.r[k] == 1000 * log || (s.joint == 2 && s.r[k] == 4001);
      EXPECT_EQ(s.restart[k] == 2, log_start) << "joint " << s.joint << " r " << s.r[k];
      ASSERT_TRUE(s.positions);
      EXPECT_EQ((*s.positions)[0][k], s.r[k]);  // the positions kept with their samples
    }
  }
  // Nothing to do within the budget, nor with one segment over it.
  EXPECT_EQ(friction_fit::thin_to_budget(day, 4000), 0u);
  EXPECT_EQ(friction_fit::thin_to_budget(day, 0), 0u);
  std::vector<friction_fit::JointSeries> one = {day[0]};
  one[0].restart.assign(one[0].size(), 0);
  EXPECT_EQ(friction_fit::thin_to_budget(one, 10), 0u);
}
