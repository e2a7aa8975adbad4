// The kinematic chain from the profile's root link to its tip link, built from the URDF by
// urdfdom: one moving body per revolute/continuous/prismatic joint, fixed joints merged into
// their parent body, and everything hanging off the chain (including moving joints that are not
// on it, e.g. gripper fingers) locked at zero and merged too. Read-only once built; the
// dynamics (dynamics.hpp) take it by const reference together with a scratch Data.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "momentum/model/profile.hpp"

namespace momentum::model {

enum class JointType { revolute, prismatic };

// A rigid transform: x_parent = rotation * x_child + translation. Metres.
struct Placement {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
};

// Joint limits as in the URDF. A continuous joint has lower = -inf and upper = +inf; velocity
// and effort are +inf when the URDF gives none (or gives 0 for a continuous joint).
struct JointLimits {
  double lower = 0.0;     // rad or m
  double upper = 0.0;     // rad or m
  double velocity = 0.0;  // rad/s or m/s
  double effort = 0.0;    // Nm or N
};

struct Joint {
  std::string name;
  JointType type = JointType::revolute;
  bool continuous = false;        // revolute without position limits
  Eigen::Vector3d axis;           // unit vector, in the joint (= child body) frame
  JointLimits limits;
  // Joint frame in the parent body frame at q = 0 (fixed joints between them folded in). For
  // joint 1 the parent body is the root link.
  Placement placement;
};

// One <collision> element of a link, in the frame of the body it was merged into. Used to place
// candidate contact points (contact/locate); the dynamics ignore it.
struct CollisionShape {
  enum class Kind { sphere, box, cylinder, mesh };
  Kind kind = Kind::sphere;
  Placement placement;  // the shape's frame in the body frame
  // sphere: (radius, 0, 0); box: its full extents along x, y, z; cylinder: (radius, length, 0),
  // its axis along z and centred on the origin; mesh: unused. m.
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
  // mesh: 3 vertices per triangle, in the shape's frame, the URDF's scale applied, m.
  std::vector<Eigen::Vector3d> triangles;
};

// A moving body: the link a joint moves plus every link merged into it. Inertial parameters
// are expressed in the body frame (= the frame of the joint that moves it).
struct Body {
  std::string name;                      // the URDF link directly after the joint
  std::vector<std::string> merged_links; // further links folded in (fixed or locked joints)
  double mass = 0.0;                     // kg, > 0
  Eigen::Vector3d com = Eigen::Vector3d::Zero();          // centre of mass, m
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();      // rotational inertia about com, kg m^2
  std::vector<CollisionShape> collision;  // its links' <collision> shapes that could be read
  // Mesh files named by its links' <collision> elements that could not be read (a package://
  // outside ROS_PACKAGE_PATH, a missing file, not an STL), as written in the URDF.
  std::vector<std::string> unread_meshes;
};

struct Model {
  std::filesystem::path urdf;    // the URDF file it was built from
  std::string robot_name;        // <robot name="..."> of the URDF
  std::string root;              // root link (fixed, its frame is the world frame)
  std::string tip;               // tip link
  int nq = 0;                    // number of moving joints = bodies = degrees of freedom
  std::vector<Joint> joints;     // nq joints, root to tip
  std::vector<Body> bodies;      // nq bodies; bodies[i] is moved by joints[i]
  Placement tip_placement;       // tip link frame in the last body's frame
  std::vector<std::string> locked_joints;  // moving URDF joints off the chain, held at q = 0
  Eigen::Vector3d gravity{0.0, 0.0, -9.81};  // in the root frame, m/s^2
  Eigen::VectorXd rotor_inertia; // nq, reflected rotor inertia (kg m^2 or kg), added to M's diagonal
  Eigen::VectorXd k_i;           // nq, torque constants (Nm/A or N/A)
  // The profile's active payload, already combined into bodies[payload_body] (parallel-axis
  // theorem); empty and -1 without one.
  std::string payload;
  int payload_body = -1;

  // Sum of the moving bodies' masses, kg (the root link's mass is not part of the dynamics).
  double total_mass() const;
  // Index of the joint with this name, or -1.
  int joint_index(const std::string& name) const;
  // The joints' URDF names, root to tip (nq names).
  std::vector<std::string> joint_names() const;
};

// Builds the chain of profile.root .. profile.tip from profile.urdf. Throws momentum::Error
// whose message names the profile or URDF file when: the URDF is missing or unparsable; its
// joints do not form a tree (a link with two parent joints, a cycle, a joint naming a link that
// is not there: `file: joint 'j': message`, checked before anything walks the tree); root
// or tip is not a link of it; tip is not below root; a joint on the chain is floating or
// planar; the profile's "joints" list has a different length than the chain's moving joints;
// an inertial element has a negative mass, a mass of zero with a nonzero inertia, or a
// rotational inertia that is not positive definite or violates the triangle inequality; a
// moving body ends up with no mass. A chain with no moving joint is an error too. The active
// payload (Profile::payload()) is merged into the body its link belongs to; a payload link that
// is not in the URDF, not on or below the chain, or on the fixed base is an error naming the
// profile file. The profile's "inertial_corrections" (mo-dynfit) are then added to the bodies'
// standard parameters (inertial_corrections.hpp; a body left non-physical is an error).
Model build_model(const Profile& profile);

// The URDF-to-chain step of build_model on URDF text (messages name profile.urdf, or "<urdf>"
// when it is empty), without the profile's inertial corrections. Throws what build_model
// throws. For tests and the fuzz target.
Model build_model_from_urdf_text(const Profile& profile, const std::string& urdf_text);

// Checks one rotational inertia (about its com, any frame): symmetric, positive definite, and
// principal moments satisfying the triangle inequality (each <= sum of the others, with a
// relative tolerance of 1e-9). Returns false with the reason in `why` (when non-null).
bool is_physical_inertia(const Eigen::Matrix3d& inertia, std::string* why);

}  // namespace momentum::model
