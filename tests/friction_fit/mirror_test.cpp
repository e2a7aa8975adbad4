// The mirror check (paper's ref. 37) on logs built from a closed-form joint: rigid-body torque
// even in the velocity plus friction. For memoryless friction the reference is exact.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <unistd.h>

#include "momentum/core/error.hpp"
#include "momentum/friction_fit/mirror.hpp"

namespace friction_fit = momentum::friction_fit;
namespace mf = momentum::friction;

namespace {

constexpr double kDuration = 6.0, kDt = 0.004;

double q_of(double t) { return 0.4 * std::sin(2 * std::numbers::pi * 0.25 * t) + 0.05 * t * t; }
double dq_of(double t) { return 0.4 * 2 * std::numbers::pi * 0.25 * std::cos(2 * std::numbers::pi * 0.25 * t) + 0.1 * t; }
double ddq_of(double t) {
  const double w = 2 * std::numbers::pi * 0.25;
  return -0.4 * w * w * std::sin(w * t) + 0.1;
}
// Rigid-body part: inertia, a velocity-squared term (even) and gravity.
double rigid(double q, double dq, double ddq) { return 0.7 * ddq + 0.3 * dq * dq + 4.0 * std::sin(q); }

// Writes a log (t, q1, dq1, and tau_m1 or i1) of the forward or the mirrored motion, with the
// friction of `kind`/`p` run along it. Returns the path.
std::string write_log(const std::string& name, bool mirrored, mf::Kind kind, const mf::Parameters<double>& p,
                      double current_scale = 0, double time_offset = 0) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("momentum-mirror-" + std::to_string(::getpid()) + "-" + name + ".csv");
  std::ofstream out(path);
  out << "t,q1,dq1," << (current_scale > 0 ? "i1" : "tau_m1") << "\n";
  mf::JointFriction<double> f(kind, p);
  const int n = static_cast<int>(std::lround(kDuration / kDt));
  out.precision(17);
  for (int k = 0; k <= n; ++k) {
    const double t = k * kDt;
    const double s = mirrored ? kDuration - t : t;
    const double q = q_of(s), dq = mirrored ? -dq_of(s) : dq_of(s), ddq = ddq_of(s);
    const double tau = rigid(q, dq, ddq) + f.step(dq, k ? kDt : 0.0);
    out << t + time_offset << "," << q << "," << dq << "," << (current_scale > 0 ? tau / current_scale : tau) << "\n";
  }
  return path.string();
}

friction_fit::MirrorReference reference_of(const std::string& a, const std::string& b, std::vector<double> k_i = {}) {
  auto fa = momentum::stream::Reader::open(a);
  auto fb = momentum::stream::Reader::open(b);
  return friction_fit::mirror_reference(*fa, *fb, {1}, k_i);
}

const mf::Parameters<double> kStribeck{0, 0, 1.2, 3.0, 4.0, 0.05};
const mf::Parameters<double> kLugre{1e5, 300, 1.2, 3.0, 4.0, 0.05};

}  // namespace

TEST(Mirror, ExactForMemorylessFriction) {
  const auto a = write_log("fwd", false, mf::Kind::stribeck, kStribeck);
  const auto b = write_log("mir", true, mf::Kind::stribeck, kStribeck, 0, 100.0);  // its own clock
  const auto ref = reference_of(a, b);
  ASSERT_EQ(ref.t.size(), 1501u);
  EXPECT_LT(ref.max_position_mismatch, 1e-9);
  EXPECT_LT(ref.max_velocity_mismatch, 1e-9);
  // The reference is the friction itself, and the model that made it matches it.
  for (std::size_t k = 0; k < ref.t.size(); ++k)
    ASSERT_NEAR(ref.friction[0][k], mf::stribeck_torque(kStribeck, ref.dq[0][k]), 1e-9) << k;
  const auto check = friction_fit::compare_mirror(ref, 0, mf::Kind::stribeck, kStribeck, {});
  EXPECT_EQ(check.samples, 1501u);
  EXPECT_LT(check.rms, 1e-9);
  mf::Parameters<double> off = kStribeck;
  off.tau_c *= 1.1;  // 0.3 Nm too much Coulomb friction
  const auto worse = friction_fit::compare_mirror(ref, 0, mf::Kind::stribeck, off, {});
  EXPECT_GT(worse.rms, 0.2);
  EXPECT_LT(worse.rms, 0.31);
  std::filesystem::remove(a);
  std::filesystem::remove(b);
}

TEST(Mirror, CurrentsAndLugreMemory) {
  // Currents through a torque constant; LuGre friction, whose memory makes the check
  // approximate near reversals but close elsewhere.
  const auto a = write_log("fwd-i", false, mf::Kind::lugre, kLugre, 12.5);
  const auto b = write_log("mir-i", true, mf::Kind::lugre, kLugre, 12.5);
  const auto ref = reference_of(a, b, {12.5});
  const auto check = friction_fit::compare_mirror(ref, 0, mf::Kind::lugre, kLugre, {}, 0.5);
  EXPECT_GT(check.samples, 1300u);
  // Hysteresis near the reversals: under a tenth of the friction level (4 Nm).
  EXPECT_LT(check.rms, 0.4);
  mf::Parameters<double> off = kLugre;
  off.tau_c *= 1.3;
  off.sigma2 *= 1.3;
  EXPECT_GT(friction_fit::compare_mirror(ref, 0, mf::Kind::lugre, off, {}, 0.5).rms, 2 * check.rms);
  EXPECT_THROW(reference_of(a, b), momentum::Error);  // currents without a torque constant
  std::filesystem::remove(a);
  std::filesystem::remove(b);
}

TEST(Mirror, RejectsLogsOfDifferentLength) {
  const auto a = write_log("fwd-l", false, mf::Kind::stribeck, kStribeck);
  const auto path = std::filesystem::temp_directory_path() / ("momentum-mirror-short-" + std::to_string(::getpid()) + ".csv");
  std::ofstream(path) << "t,q1,dq1,tau_m1\n0,0,0,0\n1,0,0,0\n";
  EXPECT_THROW(reference_of(a, path.string()), momentum::Error);
  std::filesystem::remove(a);
  std::filesystem::remove(path);
}
