// The URDF's collision shapes: primitives placed in their body's frame, STL meshes read (binary
// and ASCII) and found (relative, file://, package:// on ROS_PACKAGE_PATH), and a mesh that
// cannot be read named, not fatal.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "momentum/core/error.hpp"
#include "momentum/model/collision.hpp"
#include "momentum/model/model.hpp"

namespace {

namespace fs = std::filesystem;
namespace mm = momentum::model;

// A unit right tetrahedron: 4 triangles, 12 vertices.
const std::vector<Eigen::Vector3d> kTetrahedron = {
    {0, 0, 0}, {0, 1, 0}, {1, 0, 0}, {0, 0, 0}, {1, 0, 0}, {0, 0, 1},
    {0, 0, 0}, {0, 0, 1}, {0, 1, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};

void write_binary_stl(const fs::path& path, const std::vector<Eigen::Vector3d>& vertices, std::size_t cut = 0) {
  std::string bytes(80, ' ');
  const auto count = static_cast<std::uint32_t>(vertices.size() / 3);
  bytes.append(reinterpret_cast<const char*>(&count), 4);
  for (std::size_t t = 0; t < count; ++t) {
    const float normal[3] = {0, 0, 0};
    bytes.append(reinterpret_cast<const char*>(normal), sizeof normal);
    for (int v = 0; v < 3; ++v) {
      const float xyz[3] = {static_cast<float>(vertices[3 * t + v].x()), static_cast<float>(vertices[3 * t + v].y()),
                            static_cast<float>(vertices[3 * t + v].z())};
      bytes.append(reinterpret_cast<const char*>(xyz), sizeof xyz);
    }
    bytes.append(2, '\0');
  }
  bytes.resize(bytes.size() - cut);
  std::ofstream(path, std::ios::binary) << bytes;
}

class Collision : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("momentum_collision_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  fs::path dir;
};

TEST_F(Collision, ReadsBinaryAndAsciiStl) {
  write_binary_stl(dir / "t.stl", kTetrahedron);
  const auto binary = mm::read_stl(dir / "t.stl");
  ASSERT_EQ(binary.size(), 12u);
  for (std::size_t i = 0; i < 12; ++i) EXPECT_TRUE(binary[i].isApprox(kTetrahedron[i])) << i;
  std::ofstream ascii(dir / "a.stl");
  ascii << "solid t\n";
  for (std::size_t t = 0; t < 4; ++t) {
    ascii << " facet normal 0 0 0\n  outer loop\n";
    for (int v = 0; v < 3; ++v) ascii << "   vertex " << kTetrahedron[3 * t + v].transpose() << "\n";
    ascii << "  endloop\n endfacet\n";
  }
  ascii << "endsolid t\n";
  ascii.close();
  EXPECT_EQ(mm::read_stl(dir / "a.stl"), binary);
}

TEST_F(Collision, BadStlFilesAreErrorsNamingThem) {
  write_binary_stl(dir / "cut.stl", kTetrahedron, 7);
  try {
    mm::read_stl(dir / "cut.stl");
    FAIL() << "no error";
  } catch (const momentum::Error& e) {
    EXPECT_EQ(std::string(e.what()),
              (dir / "cut.stl").string() + ": not an STL file (a binary STL of 4 triangles is 284 bytes, this one 277)");
  }
  auto nan = kTetrahedron;
  nan[4].y() = NAN;
  write_binary_stl(dir / "nan.stl", nan);
  EXPECT_THROW(mm::read_stl(dir / "nan.stl"), momentum::Error);
  EXPECT_THROW(mm::read_stl(dir / "missing.stl"), momentum::Error);
  std::ofstream(dir / "empty.stl") << "solid e\nendsolid e\n";
  EXPECT_THROW(mm::read_stl(dir / "empty.stl"), momentum::Error);
}

TEST_F(Collision, ShapesArePlacedInTheirBodyAndUnreadMeshesNamed) {
  fs::create_directories(dir / "share/arm_description/meshes");
  write_binary_stl(dir / "share/arm_description/meshes/b.stl", kTetrahedron);
  write_binary_stl(dir / "c.stl", kTetrahedron);
  const std::string inertial =
      R"(<inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>)";
  const std::string urdf = R"(<robot name="r">
<link name="base"/>
<link name="a">)" + inertial + R"(
  <collision><origin xyz="0 0 0.2" rpy="0 0 0"/><geometry><cylinder radius="0.05" length="0.4"/></geometry></collision>
  <collision><origin xyz="0.1 0 0" rpy="0 0 0"/><geometry><sphere radius="0.03"/></geometry></collision>
</link>
<link name="b">)" + inertial + R"(
  <collision><geometry><mesh filename="package://arm_description/meshes/b.stl" scale="2 2 2"/></geometry></collision>
</link>
<link name="b_tool"><collision><origin xyz="0 0 0.1" rpy="0 0 0"/><geometry><box size="0.1 0.2 0.3"/></geometry></collision></link>
<link name="c">)" + inertial + R"(
  <collision><geometry><mesh filename="c.stl"/></geometry></collision>
  <collision><geometry><mesh filename="package://nowhere/c.stl"/></geometry></collision>
</link>
<joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 0.4"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
<joint name="tool" type="fixed"><parent link="b"/><child link="b_tool"/><origin xyz="0 0 0.5"/></joint>
<joint name="j3" type="revolute"><parent link="b_tool"/><child link="c"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>)";
  std::ofstream(dir / "r.urdf") << urdf;
  ::setenv("ROS_PACKAGE_PATH", (dir / "nothing").string().append(":").append((dir / "share").string()).c_str(), 1);
  const mm::Model model = mm::build_model(
      mm::profile_from_document({{"urdf", "r.urdf"}, {"root", "base"}, {"tip", "c"}}, dir / "r.json"));
  ::unsetenv("ROS_PACKAGE_PATH");
  ASSERT_EQ(model.nq, 3);
  using Kind = mm::CollisionShape::Kind;
  const auto& a = model.bodies[0].collision;
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a[0].kind, Kind::cylinder);
  EXPECT_TRUE(a[0].size.isApprox(Eigen::Vector3d(0.05, 0.4, 0)));
  EXPECT_TRUE(a[0].placement.translation.isApprox(Eigen::Vector3d(0, 0, 0.2)));
  EXPECT_EQ(a[1].kind, Kind::sphere);
  EXPECT_DOUBLE_EQ(a[1].size.x(), 0.03);
  const auto& b = model.bodies[1].collision;  // the mesh, and the fixed tool's box 0.5 m up
  ASSERT_EQ(b.size(), 2u);
  EXPECT_EQ(b[0].kind, Kind::mesh);
  ASSERT_EQ(b[0].triangles.size(), 12u);
  EXPECT_TRUE(b[0].triangles[1].isApprox(Eigen::Vector3d(0, 2, 0)));  // scaled by 2
  EXPECT_EQ(b[1].kind, Kind::box);
  EXPECT_TRUE(b[1].placement.translation.isApprox(Eigen::Vector3d(0, 0, 0.6)));
  EXPECT_TRUE(model.bodies[1].unread_meshes.empty());
  ASSERT_EQ(model.bodies[2].collision.size(), 1u);  // c.stl, relative to the URDF
  EXPECT_EQ(model.bodies[2].unread_meshes, std::vector<std::string>{"package://nowhere/c.stl"});
}

}  // namespace
