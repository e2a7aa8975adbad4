// The identification's noise model is the robot's own: noise_scale reads each joint's residual
// scale from the thresholds mo-calibrate computed on collision-free data, so the scales that
// weigh a contact's fit are those the calibration data show, joint by joint.
#include <gtest/gtest.h>

#include <random>

#include "momentum/contact/event_contact.hpp"
#include "momentum/calibrate/calibration.hpp"

namespace {

// Simulated truth: ten minutes at 125 Hz of collision-free residual, Gaussian with a known
// standard deviation per joint (0.5, 2 and 8 Nm), calibrated as mo-calibrate does (moving
// state only: no velocities). The noise scales come back within 3%.
TEST(Noise, ScalesRecoveredFromSimulatedCollisionFreeData) {
  const double sigma[3] = {0.5, 2.0, 8.0};
  momentum::calibrate::CalibrationOptions options;
  options.rest_state = false;
  options.margin_nm = 0;
  momentum::calibrate::Calibrator calibrator(momentum::detect::Signal::mu, 3, options);
  calibrator.begin_stream("free", false);
  std::mt19937_64 random(29);
  std::normal_distribution<double> noise(0.0, 1.0);
  const double dt = 1 / 125.0;
  for (long k = 0; k < static_cast<long>(600 / dt); ++k) {
    const double x[3] = {sigma[0] * noise(random), sigma[1] * noise(random), sigma[2] * noise(random)};
    calibrator.add(k * dt, x, nullptr, [k] { return "free:" + std::to_string(k + 2); });
  }
  const auto result = calibrator.result();
  const Eigen::VectorXd scale = momentum::contact::noise_scale(result.thresholds);
  ASSERT_EQ(scale.size(), 3);
  for (int j = 0; j < 3; ++j) EXPECT_NEAR(scale[j] / sigma[j], 1.0, 0.03) << "joint " << j + 1;
}

}  // namespace
