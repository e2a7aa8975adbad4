// Rigid-body dynamics of a Model, templated on the scalar S (double, or ceres::Jet for
// automatic differentiation). Pinocchio-style: a read-only Model, a scratch DataTpl<S> made once
// per thread, and free functions that write their results into output arguments. After the
// first call with a given output vector no function allocates.
//
//   M(q) ddq + C(q,dq) dq + g(q) = tau,   M = M_links + diag(rotor_inertia),
//   p = M dq,   beta = g - C^T dq,   dM/dt = C + C^T   (Christoffel-consistent C).
//
// Implementation: recursive algorithms in world (= root frame) coordinates. Forward pass: body
// poses, world joint axes z_i, angular velocities w_i and velocities v_i of the body origins
// (which sit on the joint axes). Backward pass: composite quantities of the subtree of each
// joint (mass, first moment, momentum h^c about the world origin) projected on the joint's
// motion subspace S_i; e.g. p_i = S_i^T h^c_i and (C^T dq)_i = dT/dq_i = (h^c_i)^T (v_i x S_i).
// No finite differences anywhere.
//
// Units: q rad (revolute) or m (prismatic), dq per s, ddq per s^2; torques Nm (N), momenta
// Nms (Ns), energies J. Size mismatches (q.size() != model.nq, ...) throw std::invalid_argument.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "momentum/model/model.hpp"

namespace momentum::model {

template <class S>
using VectorX = Eigen::Matrix<S, Eigen::Dynamic, 1>;
template <class S>
using MatrixX = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic>;
template <class S>
using Matrix3X = Eigen::Matrix<S, 3, Eigen::Dynamic>;
// Input vectors: any contiguous vector of S (a VectorX, a segment, a Map) binds without a copy.
// The scalar is deduced from the Data argument only (std::type_identity), so expressions such
// as VectorXd::Zero(n) are accepted too (evaluated into a temporary).
template <class S>
using InVector = const Eigen::Ref<const typename std::type_identity<VectorX<S>>::type>&;
template <class S>
using InVector3 = const typename std::type_identity<Eigen::Matrix<S, 3, 1>>::type&;

// Scratch space for the dynamics of one Model. Holds the model's constants cast to S (so a Jet
// computation casts nothing per call) and the per-body results of the last forward pass, which
// callers may read after forward_kinematics, mass_matrix, gravity_torque, inverse_dynamics,
// coriolis_times_velocity, the energies and the point functions: rotation[i], position[i] =
// pose of body i in the world frame, axis[i] = world joint axis. momentum_and_beta and
// coriolis_transpose_times_velocity work in joint-aligned body frames instead (see `aligned_*`)
// and leave the world-frame fields as they were.
// Not thread-safe: one Data per thread. Must only be used with the Model it was made from.
template <class S>
struct DataTpl {
  using Vector3 = Eigen::Matrix<S, 3, 1>;
  using Matrix3 = Eigen::Matrix<S, 3, 3>;

  explicit DataTpl(const Model& model);

  // Constants per joint/body, from the Model.
  std::vector<Matrix3> joint_rotation;       // R0: joint frame in parent frame at q = 0
  std::vector<Matrix3> joint_rotation_k;     // R0 [a]x
  std::vector<Matrix3> joint_rotation_k2;    // R0 [a]x^2
  std::vector<Vector3> joint_translation;    // t0
  std::vector<Vector3> joint_axis_parent;    // R0 a
  std::vector<unsigned char> revolute;      // 1 revolute, 0 prismatic
  std::vector<S> mass;
  std::vector<Vector3> com;                  // in body frame
  std::vector<Matrix3> inertia;              // about com, body frame
  VectorX<S> rotor_inertia;
  Vector3 gravity;
  Matrix3 tip_rotation;
  Vector3 tip_translation;

  // Results of the last forward pass, world frame.
  std::vector<Matrix3> rotation;   // body i orientation
  std::vector<Vector3> position;   // body i origin (a point on joint i's axis)
  std::vector<Vector3> axis;       // joint i axis
  std::vector<Vector3> com_offset; // rotation[i] * com[i]: body origin to com
  std::vector<Vector3> omega;      // angular velocity of body i
  std::vector<Vector3> velocity;   // linear velocity of body i's origin
  std::vector<Vector3> domega;     // angular acceleration (inverse dynamics)
  std::vector<Vector3> accel;      // linear acceleration of the origin (inverse dynamics)
  std::vector<Vector3> linear;     // per-body linear momentum or force
  std::vector<Vector3> angular;    // per-body angular momentum or moment about world origin

  // The momentum pass (momentum_and_beta) runs in body frames rotated so that every joint axis
  // is z (frame i' = body frame i times A_i, A_i e_z = axis_i), which makes the joint rotation
  // and the projections on the axis nearly free. Constants:
  std::vector<Matrix3> aligned_joint_rotation;  // A_{i-1}^T R0_i A_i
  std::vector<Vector3> aligned_translation;     // A_{i-1}^T t0_i
  std::vector<Vector3> aligned_slide;           // A_{i-1}^T R0_i a_i (prismatic direction)
  std::vector<Vector3> aligned_com;             // A_i^T com_i
  std::vector<Matrix3> aligned_inertia;         // A_i^T I_i A_i
  // Per-call results, in frame i' (rotation: frame i' in frame (i-1)').
  std::vector<Matrix3> aligned_rotation;
  std::vector<Vector3> aligned_omega, aligned_velocity, aligned_gravity;
  std::vector<Vector3> aligned_linear, aligned_angular;  // body momentum about its origin
  Matrix3 tip_rotation_world;
  Vector3 tip_position_world;
};
using Data = DataTpl<double>;

// Body poses in the world frame into data.rotation/position/axis/com_offset, and the tip frame
// into data.tip_rotation_world/tip_position_world.
template <class S>
void forward_kinematics(const Model& model, DataTpl<S>& data, InVector<S> q);

// Joint-space mass matrix M(q) (nq x nq, symmetric), rotor inertia on the diagonal. CRBA.
template <class S>
void mass_matrix(const Model& model, DataTpl<S>& data, InVector<S> q, MatrixX<S>& M);

// Gravity torque g(q) = dV/dq (nq).
template <class S>
void gravity_torque(const Model& model, DataTpl<S>& data, InVector<S> q, VectorX<S>& g);

// C(q,dq) dq (nq): the velocity-product torques (RNEA with ddq = 0 and no gravity).
template <class S>
void coriolis_times_velocity(const Model& model, DataTpl<S>& data, InVector<S> q,
                             InVector<S> dq, VectorX<S>& c);

// C(q,dq)^T dq (nq) for the Christoffel-consistent C, i.e. dT/dq with T = dq^T M dq / 2.
template <class S>
void coriolis_transpose_times_velocity(const Model& model, DataTpl<S>& data,
                                       InVector<S> q, InVector<S> dq,
                                       VectorX<S>& ct);

// Generalized momentum p = M(q) dq and beta = g(q) - C(q,dq)^T dq, both nq, in one O(n)
// forward + backward pass (the momentum observer's hot path).
template <class S>
void momentum_and_beta(const Model& model, DataTpl<S>& data, InVector<S> q,
                       InVector<S> dq, VectorX<S>& p, VectorX<S>& beta);

// tau = M(q) ddq + C(q,dq) dq + g(q) (nq), rotor inertia included. Recursive Newton-Euler.
template <class S>
void inverse_dynamics(const Model& model, DataTpl<S>& data, InVector<S> q,
                      InVector<S> dq, InVector<S> ddq, VectorX<S>& tau);

// T = dq^T M(q) dq / 2, J (rotor inertia included).
template <class S>
S kinetic_energy(const Model& model, DataTpl<S>& data, InVector<S> q, InVector<S> dq);

// V = -sum_k m_k gravity . c_k, J (zero with every com at the root origin).
template <class S>
S potential_energy(const Model& model, DataTpl<S>& data, InVector<S> q);

// World-frame position of a point fixed in body `body` (0..nq-1), m. Runs forward_kinematics.
template <class S>
Eigen::Matrix<S, 3, 1> point_position(const Model& model, DataTpl<S>& data, InVector<S> q,
                                      int body, InVector3<S> point_in_body);

// Jacobian (3 x nq) of the world linear velocity of a point fixed in body `body` (0..nq-1):
// v = J dq; columns of joints after `body` are zero. Maps a contact force f on that point to
// joint torques J^T f. Throws std::invalid_argument when body is out of range.
template <class S>
void point_jacobian(const Model& model, DataTpl<S>& data, InVector<S> q, int body,
                    InVector3<S> point_in_body, Matrix3X<S>& J);

}  // namespace momentum::model

#include "momentum/model/dynamics_impl.hpp"

// The double versions are compiled once, in lib/src/model/dynamics.cpp, instead of in every file
// that includes this header (they cost seconds of compile time each); other scalars, such as
// ceres::Jet, are instantiated where they are used.
namespace momentum::model {
extern template void forward_kinematics<double>(const Model&, Data&, InVector<double>);
extern template void mass_matrix<double>(const Model&, Data&, InVector<double>, MatrixX<double>&);
extern template void gravity_torque<double>(const Model&, Data&, InVector<double>, VectorX<double>&);
extern template void coriolis_times_velocity<double>(const Model&, Data&, InVector<double>,
    InVector<double>, VectorX<double>&);
extern template void coriolis_transpose_times_velocity<double>(const Model&, Data&, InVector<double>,
    InVector<double>, VectorX<double>&);
extern template void momentum_and_beta<double>(const Model&, Data&, InVector<double>, InVector<double>,
    VectorX<double>&, VectorX<double>&);
extern template void inverse_dynamics<double>(const Model&, Data&, InVector<double>, InVector<double>,
    InVector<double>, VectorX<double>&);
extern template double kinetic_energy<double>(const Model&, Data&, InVector<double>, InVector<double>);
extern template double potential_energy<double>(const Model&, Data&, InVector<double>);
extern template Eigen::Matrix<double, 3, 1> point_position<double>(const Model&, Data&, InVector<double>,
    int, InVector3<double>);
extern template void point_jacobian<double>(const Model&, Data&, InVector<double>, int,
    InVector3<double>, Matrix3X<double>&);
}  // namespace momentum::model
