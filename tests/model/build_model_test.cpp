// Building the chain from a URDF: structure, merging of fixed and locked links, limits, drive
// parameters, and every validation error.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <Eigen/Geometry>

#include "momentum/core/error.hpp"
#include "momentum/model/model.hpp"

namespace {

namespace fs = std::filesystem;
namespace mm = momentum::model;

mm::Model load(const std::string& name) {
  return mm::build_model(mm::load_profile(std::string(MOMENTUM_TEST_DATA) + "/" + name + ".json"));
}

Eigen::Matrix3d rot_x(double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()).matrix(); }
Eigen::Matrix3d rot_y(double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).matrix(); }

TEST(BuildModel, Ur5) {
  const mm::Model model = load("ur5");
  ASSERT_EQ(model.nq, 6);
  EXPECT_EQ(model.robot_name, "ur5");
  EXPECT_EQ(model.joints[0].name, "shoulder_pan_joint");
  EXPECT_EQ(model.joints[5].name, "wrist_3_joint");
  EXPECT_EQ(model.bodies[0].name, "shoulder_link");
  EXPECT_EQ(model.joints[1].axis, Eigen::Vector3d(0, 1, 0));
  EXPECT_EQ(model.joints[2].limits.lower, -3.14159265359);
  EXPECT_EQ(model.joints[2].limits.upper, 3.14159265359);
  EXPECT_EQ(model.joints[2].limits.velocity, 3.15);
  EXPECT_EQ(model.joints[2].limits.effort, 150.0);
  EXPECT_NEAR(model.total_mass(), 3.7 + 8.393 + 2.275 + 1.219 + 1.219 + 0.1879, 1e-12);
  // ee_link and tool0 (massless) are merged into wrist_3_link; tool0 is 0.0823 m along y.
  EXPECT_EQ(model.bodies[5].merged_links, (std::vector<std::string>{"ee_link", "tool0"}));
  EXPECT_NEAR((model.tip_placement.translation - Eigen::Vector3d(0, 0.0823, 0)).norm(), 0, 1e-15);
  EXPECT_NEAR((model.tip_placement.rotation - rot_x(-1.57079632679)).norm(), 0, 1e-12);
  EXPECT_TRUE(model.locked_joints.empty());
  EXPECT_EQ(model.rotor_inertia, Eigen::VectorXd::Zero(6));
  EXPECT_EQ(model.k_i, Eigen::VectorXd::Ones(6));
  EXPECT_EQ(model.joint_index("elbow_joint"), 2);
  EXPECT_EQ(model.joint_index("nope"), -1);
}

TEST(BuildModel, PandaLocksFingers) {
  const mm::Model model = load("panda");
  ASSERT_EQ(model.nq, 7);
  EXPECT_EQ(model.locked_joints,
            (std::vector<std::string>{"panda_finger_joint1", "panda_finger_joint2"}));
  std::vector<std::string> merged = model.bodies[6].merged_links;
  std::sort(merged.begin(), merged.end());  // urdfdom's child order is not specified
  EXPECT_EQ(merged, (std::vector<std::string>{"panda_hand", "panda_hand_tcp", "panda_leftfinger",
                                              "panda_link8", "panda_rightfinger"}));
  EXPECT_NEAR(model.bodies[6].mass, 0.735522 + 0.73 + 0.015 + 0.015, 1e-12);
  EXPECT_NEAR((model.tip_placement.translation - Eigen::Vector3d(0, 0, 0.107)).norm(), 0, 1e-15);
}

TEST(BuildModel, MixedChainMergesAndComposes) {
  const mm::Model model = load("mixed_chain");
  ASSERT_EQ(model.nq, 3);
  EXPECT_EQ(model.joints[0].name, "spin");
  EXPECT_TRUE(model.joints[0].continuous);
  EXPECT_EQ(model.joints[0].type, mm::JointType::revolute);
  EXPECT_TRUE(std::isinf(model.joints[0].limits.lower) && model.joints[0].limits.lower < 0);
  EXPECT_TRUE(std::isinf(model.joints[0].limits.upper) && model.joints[0].limits.upper > 0);
  EXPECT_EQ(model.joints[1].type, mm::JointType::prismatic);
  EXPECT_NEAR((model.joints[1].axis - Eigen::Vector3d(0.6, 0, 0.8)).norm(), 0, 1e-15);
  // Joint 1 sits on the fixed mount: (0.1, 0, 0.2) rotated 0.3 about z, then 0.1 up.
  EXPECT_NEAR((model.joints[0].placement.translation - Eigen::Vector3d(0.1, 0, 0.3)).norm(), 0,
              1e-15);
  // The wrist joint frame composes the fixed bracket joint with its own origin.
  const Eigen::Vector3d wrist = Eigen::Vector3d(0, 0.1, 0.05) + rot_x(0.3) * Eigen::Vector3d(0, 0, 0.12);
  EXPECT_NEAR((model.joints[2].placement.translation - wrist).norm(), 0, 1e-15);
  EXPECT_NEAR((model.joints[2].placement.rotation - rot_x(0.3) * rot_y(0.5)).norm(), 0, 1e-12);
  // The carriage body carries the bracket: mass and centre of mass are the weighted sums.
  const Eigen::Vector3d bracket_com =
      Eigen::Vector3d(0, 0.1, 0.05) + rot_x(0.3) * Eigen::Vector3d(0.01, 0, 0.02);
  const Eigen::Vector3d com = (1.5 * Eigen::Vector3d(0, 0.03, 0.02) + 0.5 * bracket_com) / 2.0;
  EXPECT_NEAR(model.bodies[1].mass, 2.0, 1e-15);
  EXPECT_NEAR((model.bodies[1].com - com).norm(), 0, 1e-15);
  EXPECT_EQ(model.bodies[1].merged_links, std::vector<std::string>{"bracket"});
  // Parallel axis theorem for the merged inertia, about the merged com.
  Eigen::Matrix3d carriage, bracket;
  carriage << 0.004, 0, 0.0003, 0, 0.005, 0, 0.0003, 0, 0.003;
  bracket << 0.0006, 0, 0, 0, 0.0008, 0, 0, 0, 0.0005;
  const Eigen::Matrix3d R = rot_x(0.3) * rot_y(0.4);
  auto shift = [](double m, const Eigen::Vector3d& d) {
    return m * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
  };
  const Eigen::Matrix3d inertia = carriage + shift(1.5, Eigen::Vector3d(0, 0.03, 0.02) - com) +
                                  R * bracket * R.transpose() + shift(0.5, bracket_com - com);
  EXPECT_NEAR((model.bodies[1].inertia - inertia).norm(), 0, 1e-15);
  EXPECT_EQ(model.locked_joints, std::vector<std::string>{"finger_joint"});
  EXPECT_NEAR(model.bodies[2].mass, 0.9, 1e-15);
  EXPECT_NEAR((model.tip_placement.translation - Eigen::Vector3d(0.15, 0, 0)).norm(), 0, 1e-15);
  EXPECT_EQ(model.rotor_inertia, Eigen::Vector3d(0.01, 0.4, 0.003));
  EXPECT_EQ(model.k_i, Eigen::Vector3d(2.0, 50.0, 1.5));
  EXPECT_EQ(model.gravity, Eigen::Vector3d(0.3, -0.2, -9.7));
}

TEST(BuildModel, PhysicalInertia) {
  std::string why;
  EXPECT_TRUE(mm::is_physical_inertia(Eigen::Vector3d(1, 1, 1.9).asDiagonal().toDenseMatrix(), &why));
  EXPECT_FALSE(mm::is_physical_inertia(Eigen::Vector3d(1, 1, 2.1).asDiagonal().toDenseMatrix(), &why));
  EXPECT_EQ(why, "principal moments violate the triangle inequality");
  EXPECT_FALSE(mm::is_physical_inertia(Eigen::Vector3d(1, 0, 1).asDiagonal().toDenseMatrix(), &why));
  EXPECT_EQ(why, "not positive definite");
  Eigen::Matrix3d skewed = Eigen::Matrix3d::Identity();
  skewed(0, 1) = 0.1;
  EXPECT_FALSE(mm::is_physical_inertia(skewed, &why));
  EXPECT_EQ(why, "not symmetric");
  // Off-diagonal terms large enough to make it indefinite.
  Eigen::Matrix3d indefinite;
  indefinite << 1, 2, 0, 2, 1, 0, 0, 0, 1;
  EXPECT_FALSE(mm::is_physical_inertia(indefinite, nullptr));
}

// Validation errors, each on a small URDF written for the case.
class Validation : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir = fs::temp_directory_path() /
          ("momentum_model_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }

  static std::string link(const std::string& name, const std::string& inertial =
                              R"(<inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>)") {
    return "<link name=\"" + name + "\">" + inertial + "</link>\n";
  }
  static std::string joint(const std::string& name, const std::string& type,
                           const std::string& parent, const std::string& child) {
    return "<joint name=\"" + name + "\" type=\"" + type + "\"><parent link=\"" + parent +
           "\"/><child link=\"" + child +
           "\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" "
           "velocity=\"1\"/></joint>\n";
  }
  // base -j1(revolute)- a -j2(type2)- b
  std::string two_joint(const std::string& type2, const std::string& inertial_b = "") {
    return "<robot name=\"r\">" + link("base") + link("a") +
           (inertial_b.empty() ? link("b") : link("b", inertial_b)) +
           joint("j1", "revolute", "base", "a") + joint("j2", type2, "a", "b") + "</robot>";
  }
  mm::Profile profile(const std::string& urdf_text, const std::string& root = "base",
                      const std::string& tip = "b", int joints = -1) {
    std::ofstream(dir / "r.urdf") << urdf_text;
    nlohmann::json document = {{"urdf", "r.urdf"}, {"root", root}, {"tip", tip}};
    if (joints >= 0) {
      document["joints"] = nlohmann::json::array();
      for (int j = 0; j < joints; ++j) document["joints"].push_back({{"k_i", 2.0}});
    }
    return mm::profile_from_document(document, dir / "r.json");
  }
  std::string error_of(const mm::Profile& p) {
    try {
      mm::build_model(p);
    } catch (const momentum::Error& e) {
      return e.what();
    }
    return "(no error)";
  }
  std::string urdf() const { return (dir / "r.urdf").string(); }
  fs::path dir;
};

TEST_F(Validation, ValidTwoJointChain) {
  const mm::Model model = mm::build_model(profile(two_joint("prismatic"), "base", "b", 2));
  EXPECT_EQ(model.nq, 2);
  EXPECT_EQ(model.k_i, Eigen::Vector2d(2.0, 2.0));
}

TEST_F(Validation, MissingUrdf) {
  const mm::Profile p = mm::profile_from_document(
      {{"urdf", "missing.urdf"}, {"root", "a"}, {"tip", "b"}}, dir / "r.json");
  EXPECT_EQ(error_of(p),
            (dir / "missing.urdf").string() + ": cannot open urdf: No such file or directory");
}

TEST_F(Validation, UnparsableUrdf) {
  EXPECT_EQ(error_of(profile("<robot name=\"r\"><link name=\"a\"></robot>")).rfind(
                urdf() + ": cannot parse urdf: ", 0),
            0u);
  EXPECT_EQ(error_of(profile("not xml at all")).rfind(urdf() + ": cannot parse urdf: ", 0), 0u);
}

TEST_F(Validation, UnknownLinks) {
  EXPECT_EQ(error_of(profile(two_joint("revolute"), "nope", "b")),
            urdf() + ": unknown root link 'nope' (the urdf's links: a, b, base)");
  EXPECT_EQ(error_of(profile(two_joint("revolute"), "base", "nope")),
            urdf() + ": unknown tip link 'nope' (the urdf's links: a, b, base)");
}

TEST_F(Validation, TipNotBelowRoot) {
  EXPECT_EQ(error_of(profile(two_joint("revolute"), "b", "base")),
            urdf() + ": tip link 'base' is not below root link 'b'");
  EXPECT_EQ(error_of(profile(two_joint("revolute"), "a", "a")),
            urdf() + ": no moving joint between root 'a' and tip 'a'");
}

TEST_F(Validation, UnsupportedJointTypes) {
  EXPECT_EQ(error_of(profile(two_joint("floating"))),
            urdf() + ": joint 'j2' on the chain is floating; only revolute, continuous, "
                     "prismatic and fixed joints are supported");
  EXPECT_EQ(error_of(profile(two_joint("planar"))),
            urdf() + ": joint 'j2' on the chain is planar; only revolute, continuous, "
                     "prismatic and fixed joints are supported");
}

TEST_F(Validation, WrongJointCount) {
  EXPECT_EQ(error_of(profile(two_joint("revolute"), "base", "b", 3)),
            (dir / "r.json").string() +
                ": \"joints\" has 3 entries but the chain base -> b has 2 moving joints");
}

TEST_F(Validation, BadMass) {
  const std::string inertia = R"(<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/>)";
  EXPECT_EQ(error_of(profile(two_joint("revolute", "<inertial><mass value=\"-1\"/>" + inertia +
                                                       "</inertial>"))),
            urdf() + ": link 'b': negative mass -1");
  EXPECT_EQ(error_of(profile(two_joint("revolute", "<inertial><mass value=\"0\"/>" + inertia +
                                                       "</inertial>"))),
            urdf() + ": link 'b': zero mass with a nonzero inertia");
  // A body whose links have no mass at all.
  EXPECT_EQ(error_of(profile(two_joint("revolute", "<visual><geometry><box size=\"1 1 1\"/>"
                                                   "</geometry></visual>"))),
            urdf() + ": body 'b' moved by joint 'j2' has no mass");
}

TEST_F(Validation, NonPhysicalInertia) {
  EXPECT_EQ(error_of(profile(two_joint(
                "revolute",
                R"(<inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.3"/></inertial>)"))),
            urdf() + ": link 'b': non-physical inertia: principal moments violate the "
                     "triangle inequality");
  EXPECT_EQ(error_of(profile(two_joint(
                "revolute",
                R"(<inertial><mass value="1"/><inertia ixx="-0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>)"))),
            urdf() + ": link 'b': non-physical inertia: not positive definite");
}

}  // namespace
