#include "momentum/model/describe.hpp"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"

namespace momentum::model {

namespace {

std::string triple(const Eigen::Vector3d& v) {
  return core::short_number(v.x()) + " " + core::short_number(v.y()) + " " + core::short_number(v.z());
}

// Roll-pitch-yaw as in URDF: R = Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Vector3d rpy(const Eigen::Matrix3d& r) {
  const double pitch = std::atan2(-r(2, 0), std::hypot(r(0, 0), r(1, 0)));
  double roll = std::atan2(r(2, 1), r(2, 2));
  double yaw = std::atan2(r(1, 0), r(0, 0));
  if (std::abs(std::abs(pitch) - M_PI / 2) < 1e-9) {  // gimbal lock: put it all in yaw
    roll = 0.0;
    yaw = std::atan2(-r(0, 1), r(1, 1));
  }
  return {roll, pitch, yaw};
}

// Left-aligned columns two spaces apart, each as wide as its widest cell.
std::string table(const std::vector<std::vector<std::string>>& rows) {
  std::vector<std::size_t> width;
  for (const auto& row : rows) {
    width.resize(std::max(width.size(), row.size()), 0);
    for (std::size_t c = 0; c < row.size(); ++c) width[c] = std::max(width[c], row[c].size());
  }
  std::string out;
  for (const auto& row : rows) {
    std::string line;
    for (std::size_t c = 0; c < row.size(); ++c) {
      line += row[c];
      if (c + 1 < row.size()) line.append(width[c] - row[c].size() + 2, ' ');
    }
    out += line + "\n";
  }
  return out;
}

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : ", ") + item;
  return out.empty() ? "-" : out;
}

}  // namespace

std::string describe_chain(const Model& model, const Profile& profile) {
  std::string out;
  out += "robot      " + model.robot_name + " (" + model.urdf.string() + ")\n";
  out += "chain      " + model.root + " -> " + model.tip + ", " + std::to_string(model.nq) +
         " moving joints\n";
  out += "gravity    " + triple(model.gravity) + " m/s^2\n";
  out += "profile    " + profile.path.string() + "\n\n";

  std::vector<std::vector<std::string>> joints = {
      {"j", "joint", "type", "axis", "lower", "upper", "velocity", "effort", "k_i",
       "rotor_inertia"}};
  for (int j = 0; j < model.nq; ++j) {
    const Joint& joint = model.joints[j];
    joints.push_back({std::to_string(j + 1), joint.name,
                      joint.type == JointType::prismatic ? "prismatic"
                      : joint.continuous                 ? "continuous"
                                                         : "revolute",
                      triple(joint.axis), core::short_number(joint.limits.lower), core::short_number(joint.limits.upper),
                      core::short_number(joint.limits.velocity), core::short_number(joint.limits.effort),
                      core::short_number(model.k_i[j]), core::short_number(model.rotor_inertia[j])});
  }
  out += table(joints) + "\n";

  std::vector<std::vector<std::string>> bodies = {
      {"j", "body", "mass", "com", "principal_inertia", "merged_links"}};
  for (int j = 0; j < model.nq; ++j) {
    const Body& body = model.bodies[j];
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(body.inertia,
                                                                Eigen::EigenvaluesOnly);
    bodies.push_back({std::to_string(j + 1), body.name, core::short_number(body.mass), triple(body.com),
                      triple(solver.eigenvalues()), join(body.merged_links)});
  }
  out += table(bodies) + "\n";
  out += "total mass " + core::short_number(model.total_mass()) + " kg (moving bodies)\n";
  out += "tip        " + model.tip + " in " + model.bodies.back().name + " frame: xyz " +
         triple(model.tip_placement.translation) + ", rpy " +
         triple(rpy(model.tip_placement.rotation)) + "\n";
  out += "locked     " + join(model.locked_joints) + "\n";
  std::vector<std::string> names;
  for (const Payload& p : profile.payloads) names.push_back(p.name);
  if (const Payload* payload = profile.payload(); payload && model.payload_body >= 0) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(payload->inertia,
                                                                Eigen::EigenvaluesOnly);
    out += "payload    " + payload->name + ": " + core::short_number(payload->mass) + " kg, com " +
           triple(payload->com) + " m in " + (payload->link.empty() ? model.tip : payload->link) +
           ", principal_inertia " + triple(solver.eigenvalues()) + " kg m^2, in body " +
           std::to_string(model.payload_body + 1) + " (included above)\n";
  } else {
    out += "payload    none\n";
  }
  out += "payloads   " + join(names) + "\n";
  return out;
}

}  // namespace momentum::model
