#include "momentum/model/model.hpp"

#include <console_bridge/console.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/model/collision.hpp"
#include "momentum/model/inertial_corrections.hpp"

namespace momentum::model {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

std::string in_quotes(const std::string& text) { return "'" + text + "'"; }

// Collects urdfdom's console_bridge messages while parsing instead of letting them go to
// stderr, so that a bad URDF yields one error line that names the file.
class CapturingHandler : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR && messages.empty()) messages = text;
  }
  std::string messages;
};

// The joints must form a tree before anything walks it (urdfdom links what it finds, so a cycle
// below the root makes a recursive walk run forever, and a link with two parent joints is
// reached twice). Names the first offending joint (in name order, so the message is stable).
void check_urdf_tree(const urdf::ModelInterface& model, const std::string& where) {
  auto fail = [&](const std::string& joint, const std::string& message) {
    throw Error(located(where, 0, "joint " + in_quotes(joint) + ": " + message));
  };
  std::map<std::string, std::string> parent_joint;  // child link -> the joint that names it
  for (const auto& [name, joint] : model.joints_) {
    if (!joint) fail(name, "empty joint");
    if (joint->parent_link_name.empty() || !model.getLink(joint->parent_link_name))
      fail(name, "parent link " + in_quotes(joint->parent_link_name) + " is not in the urdf");
    if (joint->child_link_name.empty() || !model.getLink(joint->child_link_name))
      fail(name, "child link " + in_quotes(joint->child_link_name) + " is not in the urdf");
    if (joint->parent_link_name == joint->child_link_name)
      fail(name, "link " + in_quotes(joint->child_link_name) + " is its own parent");
    const auto [it, inserted] = parent_joint.emplace(joint->child_link_name, name);
    if (!inserted)
      fail(name, "link " + in_quotes(joint->child_link_name) + " already has a parent (joint " +
                     in_quotes(it->second) + "): the joints do not form a tree");
  }
  // With one parent per link, a walk up from any link ends at a link without a parent unless
  // it runs into a cycle: more steps than joints.
  for (const auto& [link, joint] : parent_joint) {
    std::string at = link;
    std::size_t steps = 0;
    for (auto up = parent_joint.find(at); up != parent_joint.end(); up = parent_joint.find(at)) {
      if (++steps > parent_joint.size())
        fail(joint, "the joints form a cycle through link " + in_quotes(link) + ": the urdf is not a tree");
      at = model.joints_.at(up->second)->parent_link_name;
    }
  }
}

// Parses URDF text under a process-wide lock (console_bridge's handler is process-wide) and
// checks the tree. `where` names the file in messages.
urdf::ModelInterfaceSharedPtr parse_urdf_text(const std::string& text, const std::string& where) {
  static std::mutex mutex;
  std::lock_guard<std::mutex> lock(mutex);
  CapturingHandler handler;
  console_bridge::OutputHandler* previous = console_bridge::getOutputHandler();
  console_bridge::useOutputHandler(&handler);
  urdf::ModelInterfaceSharedPtr model;
  try {
    model = urdf::parseURDF(text);
  } catch (...) {
    console_bridge::useOutputHandler(previous);
    throw;
  }
  console_bridge::useOutputHandler(previous);
  if (!model) {
    std::string why = handler.messages.empty() ? std::string("not a valid urdf") : handler.messages;
    std::transform(why.begin(), why.begin() + std::min<std::size_t>(1, why.size()), why.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    while (!why.empty() && (why.back() == '.' || why.back() == '\n' || why.back() == ' ')) {
      why.pop_back();
    }
    throw Error(located(where, 0, "cannot parse urdf: " + why));
  }
  check_urdf_tree(*model, where);
  return model;
}

urdf::ModelInterfaceSharedPtr parse_urdf(const std::filesystem::path& urdf_path) {
  const std::string where = urdf_path.string();
  std::ifstream file(urdf_path, std::ios::binary);
  if (!file) throw Error(located(where, 0, std::string("cannot open urdf: ") + std::strerror(errno)));
  std::ostringstream text;
  text << file.rdbuf();
  if (!file && !file.eof()) throw Error(located(where, 0, "cannot read urdf"));
  return parse_urdf_text(text.str(), where);
}

Placement to_placement(const urdf::Pose& pose) {
  Placement placement;
  const Eigen::Quaterniond rotation(pose.rotation.w, pose.rotation.x, pose.rotation.y,
                                    pose.rotation.z);
  placement.rotation = rotation.normalized().toRotationMatrix();
  placement.translation = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  return placement;
}

Placement compose(const Placement& a, const Placement& b) {
  Placement c;
  c.rotation = a.rotation * b.rotation;
  c.translation = a.translation + a.rotation * b.translation;
  return c;
}

// Mass properties being accumulated for one body, in its frame.
struct MassAccumulator {
  double mass = 0.0;
  Eigen::Vector3d first_moment = Eigen::Vector3d::Zero();
  // Second moment about the body origin: sum over parts of (I_c + m [c]x^T [c]x).
  Eigen::Matrix3d inertia_origin = Eigen::Matrix3d::Zero();

  void add(double m, const Eigen::Vector3d& com, const Eigen::Matrix3d& inertia_com) {
    mass += m;
    first_moment += m * com;
    inertia_origin += inertia_com + m * (com.squaredNorm() * Eigen::Matrix3d::Identity() -
                                         com * com.transpose());
  }
};

struct Builder {
  const Profile& profile;
  const urdf::ModelInterface& urdf;
  std::string where;  // URDF file, for messages
  // Where each URDF link ended up: the index of the body it was merged into (-1 on the fixed
  // base) and its frame in that body's frame. For attaching the payload.
  struct LinkFrame {
    int body = -1;
    Placement in_body;
  };
  mutable std::map<std::string, LinkFrame> link_frames;

  [[noreturn]] void fail(const std::string& message) const {
    throw Error(located(where, 0, message));
  }

  // Adds `link`'s own inertial, placed by `link_in_body`, to `body`.
  void add_inertial(const urdf::Link& link, const Placement& link_in_body,
                    MassAccumulator& body) const {
    if (!link.inertial) return;
    const urdf::Inertial& inertial = *link.inertial;
    Eigen::Matrix3d inertia;
    inertia << inertial.ixx, inertial.ixy, inertial.ixz, inertial.ixy, inertial.iyy,
        inertial.iyz, inertial.ixz, inertial.iyz, inertial.izz;
    const std::string name = in_quotes(link.name);
    if (!std::isfinite(inertial.mass) || !inertia.allFinite()) {
      fail("link " + name + ": mass and inertia must be finite");
    }
    if (inertial.mass < 0.0) fail("link " + name + ": negative mass " + core::short_number(inertial.mass));
    if (inertial.mass == 0.0) {
      // A massless frame (tool0, ee_link, ...) is fine; inertia without mass is not physical.
      if (!inertia.isZero(0.0)) fail("link " + name + ": zero mass with a nonzero inertia");
      return;
    }
    std::string why;
    if (!is_physical_inertia(inertia, &why)) fail("link " + name + ": non-physical inertia: " + why);
    const Placement frame = compose(link_in_body, to_placement(inertial.origin));
    body.add(inertial.mass, frame.translation,
             frame.rotation * inertia * frame.rotation.transpose());
  }

  // Adds `link`'s collision shapes, placed by `link_in_body`, to `body`. A mesh whose file
  // cannot be found or read is named in body.unread_meshes: identification then falls back to
  // the body's segment, which costs precision, not the model.
  void add_collision(const urdf::Link& link, const Placement& link_in_body, Body& body) const {
    for (const auto& element : link.collision_array) {
      if (!element || !element->geometry) continue;
      CollisionShape shape;
      shape.placement = compose(link_in_body, to_placement(element->origin));
      const urdf::Geometry& geometry = *element->geometry;
      switch (geometry.type) {
        case urdf::Geometry::SPHERE:
          shape.kind = CollisionShape::Kind::sphere;
          shape.size.x() = static_cast<const urdf::Sphere&>(geometry).radius;
          break;
        case urdf::Geometry::BOX: {
          const auto& dim = static_cast<const urdf::Box&>(geometry).dim;
          shape.kind = CollisionShape::Kind::box;
          shape.size = Eigen::Vector3d(dim.x, dim.y, dim.z);
          break;
        }
        case urdf::Geometry::CYLINDER: {
          const auto& cylinder = static_cast<const urdf::Cylinder&>(geometry);
          shape.kind = CollisionShape::Kind::cylinder;
          shape.size = Eigen::Vector3d(cylinder.radius, cylinder.length, 0);
          break;
        }
        case urdf::Geometry::MESH: {
          const auto& mesh = static_cast<const urdf::Mesh&>(geometry);
          shape.kind = CollisionShape::Kind::mesh;
          const auto file = resolve_mesh(mesh.filename, std::filesystem::path(where));
          try {
            if (!file) throw Error("not found");
            shape.triangles = read_stl(*file);
          } catch (const Error&) {
            body.unread_meshes.push_back(mesh.filename);
            continue;
          }
          const Eigen::Vector3d scale(mesh.scale.x, mesh.scale.y, mesh.scale.z);
          for (auto& v : shape.triangles) v = v.cwiseProduct(scale);
          break;
        }
        default:
          continue;
      }
      if (!shape.size.allFinite() || (shape.kind != CollisionShape::Kind::mesh && !(shape.size.x() > 0))) {
        fail("link " + in_quotes(link.name) + ": a collision shape of no size");
      }
      body.collision.push_back(std::move(shape));
    }
  }

  // Adds `link` and everything below it except the child on the chain (`next_on_chain`, may
  // be null) to `body`. Moving joints off the chain are locked at q = 0.
  void add_subtree(const urdf::Link& link, const Placement& link_in_body,
                   const urdf::Link* next_on_chain, MassAccumulator& body, Body* named,
                   std::vector<std::string>& locked, int body_index) const {
    link_frames[link.name] = {body_index, link_in_body};
    add_inertial(link, link_in_body, body);
    if (named) add_collision(link, link_in_body, *named);
    for (const auto& child : link.child_links) {
      if (child.get() == next_on_chain) continue;
      const urdf::Joint& joint = *child->parent_joint;
      if (joint.type != urdf::Joint::FIXED) locked.push_back(joint.name);
      if (named) named->merged_links.push_back(child->name);
      add_subtree(*child, compose(link_in_body, to_placement(joint.parent_to_joint_origin_transform)),
                  nullptr, body, named, locked, body_index);
    }
  }

  // Fixes the payload to its link: its mass, com and inertia join the body the link belongs to,
  // exactly as a URDF link on a fixed joint would.
  void add_payload(const Payload& payload, Model& model, std::vector<MassAccumulator>& mass) const {
    const std::string& link = payload.link.empty() ? profile.tip : payload.link;
    auto fail_here = [&](const std::string& message) {
      throw Error(located(profile.path.string(), 0,
                          "payload " + in_quotes(payload.name) + ": " + message));
    };
    const auto it = link_frames.find(link);
    if (it == link_frames.end()) {
      if (urdf.getLink(link)) {
        fail_here("link " + in_quotes(link) + " is not part of the chain " + profile.root + " -> " +
                  profile.tip + " or what hangs off it");
      }
      fail_here("unknown link " + in_quotes(link) + " in " + where);
    }
    if (it->second.body < 0) {
      fail_here("link " + in_quotes(link) + " does not move (it is on the fixed base)");
    }
    const Placement& frame = it->second.in_body;
    mass[static_cast<std::size_t>(it->second.body)].add(
        payload.mass, frame.rotation * payload.com + frame.translation,
        frame.rotation * payload.inertia * frame.rotation.transpose());
    model.payload = payload.name;
    model.payload_body = it->second.body;
  }

  // The URDF's links, for a message about a name that is not one of them.
  std::string link_names() const {
    std::string names;
    for (const auto& item : urdf.links_) names += (names.empty() ? "" : ", ") + item.first;
    return names.empty() ? "the urdf has no links" : "the urdf's links: " + names;
  }

  Model build() const {
    const urdf::LinkConstSharedPtr root = urdf.getLink(profile.root);
    const urdf::LinkConstSharedPtr tip = urdf.getLink(profile.tip);
    if (!root) fail("unknown root link " + in_quotes(profile.root) + " (" + link_names() + ")");
    if (!tip) fail("unknown tip link " + in_quotes(profile.tip) + " (" + link_names() + ")");

    // Links from the tip up to the root.
    std::vector<const urdf::Link*> chain;
    for (const urdf::Link* link = tip.get(); link; link = link->getParent().get()) {
      chain.push_back(link);
      if (link == root.get()) break;
    }
    if (chain.back() != root.get()) {
      fail("tip link " + in_quotes(profile.tip) + " is not below root link " + in_quotes(profile.root));
    }
    std::reverse(chain.begin(), chain.end());

    Model model;
    model.urdf = profile.urdf;
    model.robot_name = urdf.getName();
    model.root = profile.root;
    model.tip = profile.tip;
    model.gravity = profile.gravity;

    std::vector<MassAccumulator> mass;
    Placement link_in_body;  // current chain link in the current body frame (root: world)
    for (std::size_t k = 0; k < chain.size(); ++k) {
      const urdf::Link& link = *chain[k];
      if (k > 0) {
        const urdf::Joint& joint = *link.parent_joint;
        const Placement origin = to_placement(joint.parent_to_joint_origin_transform);
        switch (joint.type) {
          case urdf::Joint::FIXED:
            link_in_body = compose(link_in_body, origin);
            break;
          case urdf::Joint::REVOLUTE:
          case urdf::Joint::CONTINUOUS:
          case urdf::Joint::PRISMATIC: {
            Joint j;
            j.name = joint.name;
            j.type = joint.type == urdf::Joint::PRISMATIC ? JointType::prismatic
                                                          : JointType::revolute;
            j.continuous = joint.type == urdf::Joint::CONTINUOUS;
            const Eigen::Vector3d axis(joint.axis.x, joint.axis.y, joint.axis.z);
            if (!(axis.norm() > 1e-12) || !axis.allFinite()) {
              fail("joint " + in_quotes(joint.name) + " has no valid axis");
            }
            j.axis = axis.normalized();
            j.placement = compose(link_in_body, origin);
            if (j.continuous) {
              j.limits.lower = -kInfinity;
              j.limits.upper = kInfinity;
              j.limits.velocity = kInfinity;
              j.limits.effort = kInfinity;
              if (joint.limits) {
                if (joint.limits->velocity > 0.0) j.limits.velocity = joint.limits->velocity;
                if (joint.limits->effort > 0.0) j.limits.effort = joint.limits->effort;
              }
            } else if (joint.limits) {
              j.limits.lower = joint.limits->lower;
              j.limits.upper = joint.limits->upper;
              j.limits.velocity = joint.limits->velocity > 0.0 ? joint.limits->velocity : kInfinity;
              j.limits.effort = joint.limits->effort > 0.0 ? joint.limits->effort : kInfinity;
            }
            model.joints.push_back(j);
            Body body;
            body.name = link.name;
            model.bodies.push_back(body);
            mass.emplace_back();
            link_in_body = Placement{};
            break;
          }
          case urdf::Joint::FLOATING:
          case urdf::Joint::PLANAR:
          default:
            fail("joint " + in_quotes(joint.name) + " on the chain is " +
                 (joint.type == urdf::Joint::FLOATING ? "floating"
                  : joint.type == urdf::Joint::PLANAR ? "planar"
                                                      : "of an unknown type") +
                 "; only revolute, continuous, prismatic and fixed joints are supported");
        }
      }
      const urdf::Link* next = k + 1 < chain.size() ? chain[k + 1] : nullptr;
      if (model.bodies.empty()) {  // still on the fixed base: its mass does not matter
        link_frames[link.name] = {-1, link_in_body};
        continue;
      }
      Body& body = model.bodies.back();
      if (link.name != body.name) body.merged_links.push_back(link.name);
      add_subtree(link, link_in_body, next, mass.back(), &body, model.locked_joints,
                  static_cast<int>(model.bodies.size()) - 1);
    }
    if (model.joints.empty()) {
      fail("no moving joint between root " + in_quotes(profile.root) + " and tip " +
           in_quotes(profile.tip));
    }
    model.tip_placement = link_in_body;
    model.nq = static_cast<int>(model.joints.size());
    if (const Payload* payload = profile.payload()) add_payload(*payload, model, mass);

    for (std::size_t i = 0; i < model.bodies.size(); ++i) {
      Body& body = model.bodies[i];
      const MassAccumulator& acc = mass[i];
      if (!(acc.mass > 0.0)) {
        fail("body " + in_quotes(body.name) + " moved by joint " + in_quotes(model.joints[i].name) +
             " has no mass");
      }
      body.mass = acc.mass;
      body.com = acc.first_moment / acc.mass;
      const Eigen::Vector3d& c = body.com;
      body.inertia = acc.inertia_origin -
                     acc.mass * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
      body.inertia = 0.5 * (body.inertia + body.inertia.transpose()).eval();
    }

    const auto n = static_cast<std::size_t>(model.nq);
    if (!profile.joints.empty() && profile.joints.size() != n) {
      throw Error(located(profile.path.string(), 0,
                          "\"joints\" has " + std::to_string(profile.joints.size()) +
                              " entries but the chain " + profile.root + " -> " + profile.tip +
                              " has " + std::to_string(n) + " moving joints"));
    }
    model.rotor_inertia = Eigen::VectorXd::Zero(model.nq);
    model.k_i = Eigen::VectorXd::Ones(model.nq);
    for (std::size_t i = 0; i < profile.joints.size(); ++i) {
      model.rotor_inertia[static_cast<Eigen::Index>(i)] = profile.joints[i].rotor_inertia;
      model.k_i[static_cast<Eigen::Index>(i)] = profile.joints[i].k_i;
    }
    return model;
  }
};

}  // namespace

double Model::total_mass() const {
  double total = 0.0;
  for (const Body& body : bodies) total += body.mass;
  return total;
}

int Model::joint_index(const std::string& name) const {
  for (std::size_t i = 0; i < joints.size(); ++i) {
    if (joints[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

std::vector<std::string> Model::joint_names() const {
  std::vector<std::string> names;
  for (const Joint& joint : joints) names.push_back(joint.name);
  return names;
}

bool is_physical_inertia(const Eigen::Matrix3d& inertia, std::string* why) {
  if (!inertia.allFinite()) return invalid(why, "not finite");
  const double scale = inertia.cwiseAbs().maxCoeff();
  if (!((inertia - inertia.transpose()).cwiseAbs().maxCoeff() <= 1e-12 * scale)) {
    return invalid(why, "not symmetric");
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(inertia,
                                                              Eigen::EigenvaluesOnly);
  const Eigen::Vector3d moments = solver.eigenvalues();  // ascending
  if (!(moments[0] > 0.0)) return invalid(why, "not positive definite");
  const double tolerance = 1e-9 * moments.sum();
  if (moments[2] > moments[0] + moments[1] + tolerance) {
    return invalid(why, "principal moments violate the triangle inequality");
  }
  return true;
}

Model build_model(const Profile& profile) {
  const urdf::ModelInterfaceSharedPtr urdf = parse_urdf(profile.urdf);
  Model model = Builder{profile, *urdf, profile.urdf.string(), {}}.build();
  apply_inertial_corrections(profile, model);  // mo-dynfit's corrections, if any
  return model;
}

Model build_model_from_urdf_text(const Profile& profile, const std::string& urdf_text) {
  const std::string where = profile.urdf.empty() ? std::string("<urdf>") : profile.urdf.string();
  const urdf::ModelInterfaceSharedPtr urdf = parse_urdf_text(urdf_text, where);
  return Builder{profile, *urdf, where, {}}.build();
}

}  // namespace momentum::model
