// The log check (mo-model --check) on logs made from the model itself: a motion of sums of
// sines with the motor torque its exact inverse dynamics plus friction, so that every scale
// is 1 by construction; then the same log with one torque constant's sign flipped and with two
// joints' columns swapped.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "momentum/model/dynamics.hpp"
#include "momentum/model/log_check.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"
#include "momentum/stream/reader.hpp"

namespace mm = momentum::model;

namespace {

// Writes a CSV of 10 s at 125 Hz: q_j = 0.4 sin(w_j t + j) (+ a pose), tau = tau_id + 3 dq +
// 2 tanh(dq / 0.01), as currents i = tau / k_i; `sign` multiplies joint `flipped`'s current,
// and `swap` exchanges the columns of joints 2 and 3.
std::string write_log(const mm::Model& model, const std::string& name, int flipped, double sign, bool swap) {
  const int n = model.nq;
  const std::string path = ::testing::TempDir() + name;
  std::ofstream out(path);
  auto col = [&](int j) { return swap && j == 1 ? 2 : swap && j == 2 ? 1 : j; };
  out << "t";
  for (const char* p : {"q", "dq", "i"})
    for (int j = 0; j < n; ++j) out << "," << p << j + 1;
  out << "\n";
  mm::Data data(model);
  Eigen::VectorXd q(n), dq(n), ddq(n), tau(n);
  for (int k = 0; k < 1250; ++k) {
    const double t = k / 125.0;
    for (int j = 0; j < n; ++j) {
      const double w = 1.3 + 0.4 * j;
      q[j] = (j == 1 ? -1.0 : 0.3) + 0.4 * std::sin(w * t + j);
      dq[j] = 0.4 * w * std::cos(w * t + j);
      ddq[j] = -0.4 * w * w * std::sin(w * t + j);
    }
    mm::inverse_dynamics(model, data, q, dq, ddq, tau);
    std::vector<double> row(3 * n);
    for (int j = 0; j < n; ++j) {
      const double torque = tau[j] + 3 * dq[j] + 2 * std::tanh(dq[j] / 0.01);
      row[col(j)] = q[j];
      row[n + col(j)] = dq[j];
      row[2 * n + col(j)] = (j == flipped ? sign : 1.0) * torque / model.k_i[j];
    }
    char text[32];
    std::snprintf(text, sizeof text, "%.17g", t);
    out << text;
    for (double v : row) {
      std::snprintf(text, sizeof text, "%.17g", v);
      out << "," << text;
    }
    out << "\n";
  }
  return path;
}

mm::LogCheckSummary check(const mm::Model& model, const std::string& path) {
  auto in = momentum::stream::Reader::open(path);
  return mm::check_log(*in, model);
}

}  // namespace

TEST(LogCheck, TheModelsOwnLogAgreesFlippedSignAndSwappedJointsAreFound) {
  const mm::Model model = mm::build_model(mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/ur5.json"));
  ASSERT_EQ(model.nq, 6);

  const auto clean = check(model, write_log(model, "log_check_clean.csv", -1, 1, false));
  EXPECT_TRUE(clean.findings.empty()) << clean.findings.front().message;
  for (int j = 0; j < 6; ++j) EXPECT_NEAR(clean.velocity_scale[static_cast<std::size_t>(j)], 1.0, 1e-3);
  // Joint 2 carries the arm: its scale is determined, and 1 up to the central differences'
  // error in ddq (h^2 w^2 / 6, under 1e-3 here) and the friction's shape; every scale
  // determined is near 1.
  ASSERT_TRUE(clean.torque[1].determined());
  int determined = 0;
  for (int j = 0; j < 6; ++j) {
    const mm::ScaleFit& fit = clean.torque[static_cast<std::size_t>(j)];
    if (!fit.determined()) continue;
    ++determined;
    EXPECT_NEAR(fit.scale, 1.0, 0.02) << "joint " << j + 1;
  }
  EXPECT_GE(determined, 1);

  const auto flipped = check(model, write_log(model, "log_check_flipped.csv", 1, -1, false));
  ASSERT_EQ(flipped.findings.size(), 1u);
  EXPECT_EQ(flipped.findings[0].kind, "torque");
  EXPECT_EQ(flipped.findings[0].joint, 2);
  EXPECT_NEAR(flipped.torque[1].scale, -1.0, 0.02);
  EXPECT_NE(flipped.findings[0].message.find("sign is flipped"), std::string::npos);

  const auto swapped = check(model, write_log(model, "log_check_swapped.csv", -1, 1, true));
  ASSERT_EQ(swapped.findings.size(), 1u);
  EXPECT_EQ(swapped.findings[0].kind, "order");
  EXPECT_EQ(swapped.better_order, (std::vector<int>{1, 3, 2, 4, 5, 6}));
  EXPECT_NEAR(swapped.torque[1].scale, 1.0, 0.02);  // in the order found
}
