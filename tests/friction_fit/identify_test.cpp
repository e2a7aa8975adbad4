// Search boxes scaled to the robot and the data, and fits that end on a bound (fit/identify.hpp):
// a joint whose friction is larger than the paper's box (a UR10e's: about 21 Nm s/rad viscous,
// 13 Nm Coulomb) is refitted in a wider box until it is inside, or reported as failed.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "momentum/friction_fit/identify.hpp"
#include "synthetic.hpp"

namespace friction_fit = momentum::friction_fit;
namespace mf = momentum::friction;
using friction_fit::testing::make_synthetic;
using friction_fit::testing::SyntheticOptions;

namespace {

const momentum::observer::Gains kObserver{50.0, 0.0, 0.0};
constexpr double kInf = std::numeric_limits<double>::infinity();

// Coulomb-viscous friction of a large arm's shoulder, on the paper's motion (peak 0.75 rad/s).
friction_fit::testing::Synthetic large_friction() {
  mf::Parameters<double> truth{};
  truth.sigma2 = 21.0;
  truth.tau_c = 13.0;
  SyntheticOptions so;
  so.kind = mf::Kind::coulomb_viscous;
  so.r_noise = 0.2;
  so.samples = 1500;
  return make_synthetic(truth, kObserver, so);
}

friction_fit::IdentifyOptions coulomb_viscous() {
  friction_fit::IdentifyOptions o;
  o.fit.kind = mf::Kind::coulomb_viscous;
  o.fit.global.genetic = friction_fit::quick_search();
  o.threads = 1;
  return o;
}

}  // namespace

TEST(ScaledBounds, FollowTheFormulaAndTheLimits) {
  friction_fit::JointScale s;
  s.residual_scale = 30;  // T = 60 Nm
  s.speed_scale = 0.5;
  const auto b = friction_fit::scaled_bounds(s);
  EXPECT_DOUBLE_EQ(b.upper[3], 60);
  EXPECT_DOUBLE_EQ(b.upper[4], 60);
  EXPECT_DOUBLE_EQ(b.upper[2], 120);          // 60 Nm / 0.5 rad/s
  EXPECT_DOUBLE_EQ(b.upper[5], 0.1);          // w_s and the bristles: the paper's box
  EXPECT_DOUBLE_EQ(b.upper[0], 1e5);
  EXPECT_DOUBLE_EQ(b.upper[1], 500.0);
  EXPECT_DOUBLE_EQ(b.lower[0], 6e4);
  EXPECT_DOUBLE_EQ(b.upper[6], 18);
  EXPECT_DOUBLE_EQ(b.lower[6], -18);
  s.effort_limit = 40;                        // the drive cannot do more
  s.velocity_limit = 0.05;
  const auto limited = friction_fit::scaled_bounds(s);
  EXPECT_DOUBLE_EQ(limited.upper[3], 40);
  EXPECT_DOUBLE_EQ(limited.upper[5], 0.05);
  // No scale in the data: the paper's box.
  const auto paper = friction_fit::scaled_bounds(friction_fit::JointScale{});
  EXPECT_EQ(paper.upper, friction_fit::paper_bounds().upper);
}

TEST(ScaledBounds, MeasureScaleUsesCountedSamplesOnly) {
  friction_fit::JointSeries s;
  for (int k = 0; k < 100; ++k) {
    s.t.push_back(0.01 * k);
    s.dq.push_back(k < 50 ? 100.0 : 1.0);
    s.r.push_back(k < 50 ? 1000.0 : 2.0);
    s.restart.push_back(k == 0 ? 2 : 0);
    s.scored.push_back(k < 50 ? 0 : 1);
  }
  const auto scale = friction_fit::measure_scale(s, 330, kInf);
  EXPECT_DOUBLE_EQ(scale.residual_scale, 2.0);
  EXPECT_DOUBLE_EQ(scale.speed_scale, 1.0);
  EXPECT_DOUBLE_EQ(scale.effort_limit, 330);
  EXPECT_TRUE(std::isinf(scale.velocity_limit));
}

TEST(IdentifyFriction, ThePapersBoxClipsALargeArmAndTheFitSaysSo) {
  const auto data = large_friction();
  auto o = coulomb_viscous();
  o.robot_bounds = false;  // the paper's box: sigma2, tau_c <= 10
  o.max_widenings = 0;
  const auto r = friction_fit::identify_friction({data.series}, {kObserver}, {kInf}, {kInf}, o);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].widenings, 0);
  EXPECT_NE(r[0].failure.find("ends on its upper bound 10"), std::string::npos) << r[0].failure;
}

TEST(IdentifyFriction, WideningTheBoxFindsTheFrictionInside) {
  const auto data = large_friction();
  auto o = coulomb_viscous();
  o.robot_bounds = false;  // start from the paper's box, and let the widening do the work
  const auto r = friction_fit::identify_friction({data.series}, {kObserver}, {kInf}, {kInf}, o);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].widenings, 1);  // 10 -> 40 holds 21 and 13
  EXPECT_TRUE(r[0].failure.empty()) << r[0].failure;
  const auto& m = r[0].fit.model;
  EXPECT_NEAR(m.parameters.sigma2, 21.0, 3 * m.estimates[2].uncertainty);
  EXPECT_NEAR(m.parameters.tau_c, 13.0, 3 * m.estimates[3].uncertainty);
}

TEST(IdentifyFriction, TheScaledBoxHoldsALargeArmAtOnce) {
  const auto data = large_friction();
  const auto r = friction_fit::identify_friction({data.series}, {kObserver}, {330.0}, {3.14}, coulomb_viscous());
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].widenings, 0);
  EXPECT_TRUE(r[0].failure.empty()) << r[0].failure;
  EXPECT_GT(r[0].bounds.upper[2], 21.0);
  EXPECT_GT(r[0].bounds.upper[3], 13.0);
  EXPECT_NEAR(r[0].fit.model.parameters.sigma2, 21.0, 3 * r[0].fit.model.estimates[2].uncertainty);
}

TEST(IdentifyFriction, BoundsTheUserGaveAreNotWidened) {
  const auto data = large_friction();
  auto o = coulomb_viscous();
  o.user_bounds[2] = true;  // sigma2 in the paper's [0, 10], as --bounds sigma2=0:10 says
  const auto r = friction_fit::identify_friction({data.series}, {kObserver}, {kInf}, {kInf}, o);
  EXPECT_DOUBLE_EQ(r[0].bounds.upper[2], 10.0);
  EXPECT_NE(r[0].failure.find("sigma2 ends on its upper bound 10 (given by --bounds)"), std::string::npos)
      << r[0].failure;
}

// The sub-sample term of a bristle parameter held by a bound measures the model, not the box:
// it is where the finer model (Problem::resolve_slow) puts the parameter against where the
// fit's own model does, both refitted in the same wider box. The paper's joint 2 with soft
// bristles (sigma0 45,000) at 1 kHz, without noise, fitted in a box whose lower bound on sigma0
// is 60,000 or 52,000: the fit holds sigma0 on that bound, and the term is the same for both
// boxes. (Measured from the bound, as before, it differed by the 8,000 between the bounds; on
// the paper arm's 8 h that hid the two models' disagreement, and the box was widened for a
// stiffness only the one-step discretisation wants lower.)
TEST(IdentifyFriction, SubSampleTermOfABristleOnABoundDoesNotDependOnTheBound) {
  SyntheticOptions so;
  so.dt = 0.001;
  so.samples = 14000;
  so.seed = 7;
  const mf::Parameters<double> truth{45000, 300, 6.1838, 8.1855, 4.5407, 0.0996};
  const auto data = make_synthetic(truth, kObserver, so);
  std::vector<double> term;
  for (double lower : {60000.0, 52000.0}) {
    friction_fit::IdentifyOptions o;
    o.fit.global.genetic = friction_fit::quick_search();
    o.max_widenings = 0;
    o.user_bounds[0] = true;
    o.fit.bounds.lower[0] = lower;
    const auto r = friction_fit::identify_friction({data.series}, {kObserver}, {1000.0}, {3.0}, o);
    const auto& sigma0 = r[0].fit.model.estimates[0];
    EXPECT_EQ(sigma0.at_bound, -1) << lower;
    EXPECT_DOUBLE_EQ(sigma0.value, lower);
    ASSERT_TRUE(std::isfinite(sigma0.discretization_shift)) << sigma0.note;
    term.push_back(sigma0.discretization_shift);
  }
  std::printf("sub-sample term of sigma0 on its bound: %.0f (bound 60,000), %.0f (bound 52,000)\n", term[0], term[1]);
  EXPECT_NEAR(term[0], term[1], 0.05 * std::abs(term[0]));
}
