// The one reader of mo-sim's truth files: required and optional columns, onset order, the
// duration comment, and errors located at their row.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "momentum/core/error.hpp"
#include "momentum/eval/truth.hpp"

using namespace momentum::eval;

namespace {

std::string write_temp(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / ("momentum_truth_" + std::to_string(::getpid()) + "_" + name);
  std::ofstream(path) << text;
  return path.string();
}

TEST(Truth, ColumnsOrderAndDuration) {
  const std::string path = write_temp("full.csv",
                                      "# duration: 60\n"
                                      "t_onset,t_end,link,clamp,px,py,pz,f_peak,tau_peak1,tau_peak2\n"
                                      "20,21,3,0,0.1,0.2,0.3,60,1,-2.5\n"
                                      "10,10.5,2,1,0,0,0,80,-12.5,3\n");
  const Truth truth = read_truth(path);
  ASSERT_EQ(truth.contacts.size(), 2u);
  ASSERT_TRUE(truth.duration.has_value());
  EXPECT_EQ(*truth.duration, 60.0);
  const TruthContact& first = truth.contacts[0];  // in onset order
  EXPECT_EQ(first.t_onset, 10.0);
  EXPECT_EQ(first.link, 2);
  EXPECT_TRUE(first.clamp);
  EXPECT_EQ(first.peak_torque, 12.5);
  const TruthContact& second = truth.contacts[1];
  EXPECT_EQ(second.peak_force, 60.0);
  EXPECT_EQ(second.point.y(), 0.2);
  EXPECT_EQ(second.peak_torque, 2.5);
  std::remove(path.c_str());
}

TEST(Truth, FewestColumnsAndErrors) {
  std::string path = write_temp("least.csv", "t_onset,t_end,link\n1,2,4\n");
  const Truth truth = read_truth(path);
  ASSERT_EQ(truth.contacts.size(), 1u);
  EXPECT_FALSE(truth.duration.has_value());
  EXPECT_FALSE(truth.contacts[0].clamp);
  EXPECT_TRUE(std::isnan(truth.contacts[0].peak_force));
  EXPECT_TRUE(std::isnan(truth.contacts[0].point.x()));
  EXPECT_TRUE(std::isnan(truth.contacts[0].peak_torque));
  std::remove(path.c_str());
  path = write_temp("backwards.csv", "t_onset,t_end,link\n1,2,4\n3,2,4\n");
  try {
    read_truth(path);
    ADD_FAILURE();
  } catch (const momentum::Error& e) {
    EXPECT_NE(std::string(e.what()).find(":3: contact ends"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
  path = write_temp("link.csv", "t_onset,t_end,link\n1,2,0.5\n");
  EXPECT_THROW(read_truth(path), momentum::Error);
  std::remove(path.c_str());
  path = write_temp("nolink.csv", "t_onset,t_end\n1,2\n");
  EXPECT_THROW(read_truth(path), momentum::Error);
  std::remove(path.c_str());
}

}  // namespace
