// The mirrored trajectory (mo-sim --mirror, for the paper's friction check): the same motion
// played backwards in time, against the forward trajectory evaluated at the mirrored instant.
#include <gtest/gtest.h>

#include "momentum/sim/trajectory.hpp"
#include "paper_arm.hpp"

namespace momentum::sim {
namespace {

using Eigen::VectorXd;

TEST(MirrorTrajectory, IsTheForwardMotionBackwardsInTime) {
  auto arm = testing::paper_arm();
  for (TrajectoryKind kind : {TrajectoryKind::paper, TrajectoryKind::multisine, TrajectoryKind::hold}) {
    TrajectoryOptions o;
    o.kind = kind;
    o.duration = 12.0;
    Trajectory forward(o, arm.model, arm.section.home, 3);
    o.mirror = true;
    Trajectory mirror(o, arm.model, arm.section.home, 3);
    VectorXd q, dq, ddq, qm, dqm, ddqm;
    for (double t = 0.0; t <= 12.0; t += 0.0371) {
      forward.evaluate(12.0 - t, q, dq, ddq);
      mirror.evaluate(t, qm, dqm, ddqm);
      for (int j = 0; j < 3; ++j) {
        EXPECT_EQ(qm[j], q[j]) << trajectory_name(kind) << " t " << t;
        EXPECT_EQ(dqm[j], -dq[j]) << trajectory_name(kind) << " t " << t;
        EXPECT_EQ(ddqm[j], ddq[j]) << trajectory_name(kind) << " t " << t;
      }
    }
    // The mirror starts where the forward motion ends, at rest.
    mirror.evaluate(0.0, qm, dqm, ddqm);
    forward.evaluate(12.0, q, dq, ddq);
    EXPECT_EQ(qm, q);
    EXPECT_EQ(dqm.norm(), 0.0);
  }
}

TEST(MirrorTrajectory, PtpCannotBeMirrored) {
  TrajectoryOptions o;
  o.kind = TrajectoryKind::ptp;
  o.mirror = true;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("mirror"), std::string::npos);
}

}  // namespace
}  // namespace momentum::sim
