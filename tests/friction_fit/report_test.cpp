// The profile update (merging the friction section, refusing mixed or incomplete results, the
// worse-fit check) and the report's JSON and text forms.
#include <gtest/gtest.h>

#include <cmath>

#include "momentum/core/error.hpp"
#include "momentum/friction_fit/report.hpp"

namespace friction_fit = momentum::friction_fit;
namespace mf = momentum::friction;
using nlohmann::json;

namespace {

friction_fit::JointFit joint_fit(int joint, mf::Kind kind, double tau_c) {
  friction_fit::JointFit f;
  f.joint = joint;
  f.model.kind = kind;
  f.model.parameters = {9e4, 200, 1.5, tau_c, tau_c + 1, 0.05};
  double x[friction_fit::kParameterCount];
  f.model.parameters.to_array(x);
  const auto used = friction_fit::model_parameters(kind);
  for (int i = 0; i < 6; ++i) {
    auto& e = f.model.estimates[static_cast<std::size_t>(i)];
    e.value = x[i];
    e.used = std::find(used.begin(), used.end(), i) != used.end();
    e.free = e.used;
    e.standard_error = 0.01 * x[i];
    e.uncertainty = 0.02 * x[i];
  }
  f.model.free = used;
  f.model.correlation = Eigen::MatrixXd::Identity(static_cast<Eigen::Index>(used.size()),
                                                  static_cast<Eigen::Index>(used.size()));
  f.model.metrics = {1000, 5.0, 0.1, 0.4, 0.999};
  return f;
}

const json kLugreSection = json::parse(R"({
  "model": "lugre", "update": "semi-implicit", "velocity_cutoff_hz": 20,
  "joints": [{"sigma0": 1e5, "sigma1": 100, "sigma2": 1, "tau_c": 2, "tau_s": 3, "w_s": 0.05, "note": "kept"},
             {"sigma0": 1e5, "sigma1": 100, "sigma2": 1, "tau_c": 2, "tau_s": 3, "w_s": 0.05}]})");

}  // namespace

TEST(MergeFriction, ReplacesFittedJointsKeepsTheRest) {
  const auto section = friction_fit::merged_friction_section(&kLugreSection, 2, {joint_fit(2, mf::Kind::lugre, 5.0)},
                                                    mf::Kind::lugre, {});
  EXPECT_EQ(section["update"], "semi-implicit");     // the profile's options stay
  EXPECT_EQ(section["velocity_cutoff_hz"], 20);
  EXPECT_EQ(section["joints"][0]["tau_c"], 2);        // joint 1 untouched
  EXPECT_EQ(section["joints"][0]["note"], "kept");
  EXPECT_EQ(section["joints"][1]["tau_c"], 5.0);
  EXPECT_EQ(section["joints"][1]["sigma0"], 9e4);
  const auto model = mf::friction_from_json(section);
  EXPECT_EQ(model.joints[1].tau_s, 6.0);
}

TEST(MergeFriction, NewSectionAndModelChanges) {
  // No section yet: every joint must be fitted.
  EXPECT_THROW(friction_fit::merged_friction_section(nullptr, 2, {joint_fit(1, mf::Kind::lugre, 5)}, mf::Kind::lugre, {}),
               momentum::Error);
  const auto fresh = friction_fit::merged_friction_section(
      nullptr, 2, {joint_fit(1, mf::Kind::stribeck, 5), joint_fit(2, mf::Kind::stribeck, 6)}, mf::Kind::stribeck, {});
  EXPECT_EQ(fresh["model"], "stribeck");
  EXPECT_FALSE(fresh["joints"][0].contains("sigma0"));  // unused by Stribeck
  EXPECT_EQ(fresh["joints"][1]["tau_c"], 6);
  // Another model for some joints only would mix models.
  EXPECT_THROW(friction_fit::merged_friction_section(&kLugreSection, 2, {joint_fit(1, mf::Kind::stribeck, 5)},
                                            mf::Kind::stribeck, {}),
               momentum::Error);
  // For every joint it replaces the model.
  const auto all = friction_fit::merged_friction_section(
      &kLugreSection, 2, {joint_fit(1, mf::Kind::coulomb_viscous, 5), joint_fit(2, mf::Kind::coulomb_viscous, 6)},
      mf::Kind::coulomb_viscous, {});
  EXPECT_EQ(all["model"], "coulomb-viscous");
  EXPECT_FALSE(all["joints"][1].contains("w_s"));
  // A joint the robot does not have.
  EXPECT_THROW(friction_fit::merged_friction_section(&kLugreSection, 2, {joint_fit(3, mf::Kind::lugre, 5)}, mf::Kind::lugre, {}),
               momentum::Error);
}

TEST(Report, WorseThanCurrent) {
  friction_fit::FitReport r;
  friction_fit::JointReport a, b, c;
  a.fit = joint_fit(1, mf::Kind::lugre, 5);
  b.fit = joint_fit(2, mf::Kind::lugre, 5);
  c.fit = joint_fit(3, mf::Kind::lugre, 5);
  a.current = friction_fit::FitMetrics{1000, 4.0, 0.09, 0.3, 0.999};  // current better than 0.1 rms
  a.current_kind = mf::Kind::lugre;
  b.current = friction_fit::FitMetrics{1000, 6.0, 0.11, 0.3, 0.999};  // current worse
  b.current_kind = mf::Kind::stribeck;
  r.joints = {a, b, c};                                       // c: no current friction
  EXPECT_EQ(friction_fit::worse_than_current(r), (std::vector<int>{1}));
}

TEST(Report, JsonAndText) {
  friction_fit::FitReport r;
  r.inputs = {"a.csv"};
  r.profile = "arm.json";
  friction_fit::JointReport j;
  j.fit = joint_fit(1, mf::Kind::lugre, 5);
  j.fit.model.estimates[1].standard_error = std::nan("");
  j.fit.model.estimates[0].at_bound = +1;
  j.fit.model.estimates[0].identifiable = false;
  j.fit.model.estimates[0].note = "not identifiable: test";
  j.fit.static_model = joint_fit(1, mf::Kind::stribeck, 5).model;
  j.fit.static_model->metrics.rms = 0.2;
  j.sample_rate_hz = 125;
  r.joints = {j};
  r.outcome = "profile not written";
  const json out = friction_fit::report_json(r);
  EXPECT_EQ(out["model"], "lugre");
  EXPECT_EQ(out["search"]["population"], 200);
  const json& p = out["joints"][0]["fit"]["parameters"];
  EXPECT_EQ(p["sigma0"]["at_bound"], "upper");
  EXPECT_EQ(p["sigma0"]["identifiable"], false);
  EXPECT_TRUE(p["sigma1"]["standard_error"].is_null());  // NaN -> null
  EXPECT_EQ(p["tau_c"]["value"], 5.0);
  EXPECT_EQ(out["joints"][0]["fit"]["metrics"]["rms"], 0.1);
  EXPECT_EQ(out["joints"][0]["static"]["model"], "stribeck");
  EXPECT_FALSE(out["joints"][0]["static"]["parameters"].contains("sigma0"));
  EXPECT_EQ(out["joints"][0]["fit"]["correlation"]["parameters"].size(), 6u);
  const std::string text = friction_fit::report_text(r);
  EXPECT_NE(text.find("joint 1: lugre"), std::string::npos) << text;
  EXPECT_NE(text.find("not identifiable: test"), std::string::npos) << text;
  EXPECT_NE(text.find("static (stribeck): rms 0.2 Nm"), std::string::npos) << text;
  EXPECT_NE(text.find("(lugre: -50.0% rms)"), std::string::npos) << text;
  EXPECT_NE(text.find("profile not written"), std::string::npos) << text;
  const json details = friction_fit::provenance_details(r, "2:8");
  EXPECT_EQ(details["logs"][0], "a.csv");
  EXPECT_EQ(details["window"], "2:8");
  EXPECT_EQ(details["joints"][0]["rms"], 0.1);
}

TEST(SteadyCovariance, FromTheReportedUncertaintiesAndCorrelationsOfTheSteadyStateParameters) {
  friction_fit::JointFit f = joint_fit(1, mf::Kind::lugre, 5.0);
  // No covariance computed: none.
  EXPECT_FALSE(friction_fit::steady_covariance(f.model));
  f.model.covariance_ok = true;
  f.model.correlation(4, 5) = f.model.correlation(5, 4) = -0.5;  // tau_s with w_s (positions in `free`)
  const auto c = friction_fit::steady_covariance(f.model);
  ASSERT_TRUE(c);
  // sigma0 and sigma1 shape only the transients: left out.
  EXPECT_EQ(c->parameters, (std::vector<int>{2, 3, 4, 5}));
  ASSERT_EQ(c->matrix.size(), 16u);
  const double u_tau_s = 0.02 * 6.0, u_w_s = 0.02 * 0.05, u_sigma2 = 0.02 * 1.5;
  EXPECT_DOUBLE_EQ(c->matrix[0], u_sigma2 * u_sigma2);
  EXPECT_DOUBLE_EQ(c->matrix[2 * 4 + 3], -0.5 * u_tau_s * u_w_s);
  EXPECT_DOUBLE_EQ(c->matrix[3 * 4 + 2], c->matrix[2 * 4 + 3]);
  EXPECT_DOUBLE_EQ(c->matrix[0 * 4 + 1], 0.0);
  // Written with the fitted joint, and read back.
  const auto section = friction_fit::merged_friction_section(&kLugreSection, 2, {f}, mf::Kind::lugre, {});
  EXPECT_FALSE(section["joints"][1].contains("covariance"));
  const auto model = mf::friction_from_json(section);
  ASSERT_EQ(model.covariance.size(), 2u);
  ASSERT_TRUE(model.covariance[0]);
  EXPECT_EQ(model.covariance[0]->matrix, c->matrix);
  // Correlations whose halves differ by rounding (near zero, not in their leading digit): the
  // matrix written is symmetric to the bit, and read back.
  f.model.correlation(2, 3) = 1e-13;
  f.model.correlation(3, 2) = -4e-13;
  const auto rounded = friction_fit::steady_covariance(f.model);
  ASSERT_TRUE(rounded);
  for (std::size_t a = 0; a < 4; ++a)
    for (std::size_t b = 0; b < 4; ++b) EXPECT_EQ(rounded->matrix[a * 4 + b], rounded->matrix[b * 4 + a]);
  EXPECT_NO_THROW(mf::friction_from_json(friction_fit::merged_friction_section(&kLugreSection, 2, {f}, mf::Kind::lugre, {})));
  // A NaN uncertainty gives none.
  f.model.estimates[5].uncertainty = NAN;
  EXPECT_FALSE(friction_fit::steady_covariance(f.model));
}
