// Template definitions for dynamics.hpp. Include dynamics.hpp, not this file.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

// (dynamics.hpp includes this file at its end, after every declaration it needs.)

namespace momentum::model {

namespace detail {

inline Eigen::Matrix3d skew(const Eigen::Vector3d& a) {
  Eigen::Matrix3d k;
  k << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return k;
}

// A rotation whose third column is the unit vector `axis` (exact for the coordinate axes).
inline Eigen::Matrix3d frame_with_z_along(const Eigen::Vector3d& axis) {
  Eigen::Matrix3d a;
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(),
                        z = Eigen::Vector3d::UnitZ();
  if (axis == z) return Eigen::Matrix3d::Identity();
  if (axis == -z) a << x, -y, -z;
  else if (axis == x) a << y, z, x;
  else if (axis == -x) a << z, y, -x;
  else if (axis == y) a << z, x, y;
  else if (axis == -y) a << x, z, -y;
  else a = Eigen::Quaterniond::FromTwoVectors(z, axis).toRotationMatrix();
  return a;
}

// Small fixed-size products written out: Eigen's generic kernels for 3-vectors mix SIMD and
// scalar code and cost about twice the instructions in the momentum pass.
template <class S>
inline Eigen::Matrix<S, 3, 1> rotate(const Eigen::Matrix<S, 3, 3>& r, const Eigen::Matrix<S, 3, 1>& x) {
  return {r(0, 0) * x[0] + r(0, 1) * x[1] + r(0, 2) * x[2],
          r(1, 0) * x[0] + r(1, 1) * x[1] + r(1, 2) * x[2],
          r(2, 0) * x[0] + r(2, 1) * x[1] + r(2, 2) * x[2]};
}
template <class S>
inline Eigen::Matrix<S, 3, 1> rotate_back(const Eigen::Matrix<S, 3, 3>& r,
                                          const Eigen::Matrix<S, 3, 1>& x) {
  return {r(0, 0) * x[0] + r(1, 0) * x[1] + r(2, 0) * x[2],
          r(0, 1) * x[0] + r(1, 1) * x[1] + r(2, 1) * x[2],
          r(0, 2) * x[0] + r(1, 2) * x[1] + r(2, 2) * x[2]};
}
template <class S>
inline Eigen::Matrix<S, 3, 1> cross(const Eigen::Matrix<S, 3, 1>& a, const Eigen::Matrix<S, 3, 1>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// sin and cos of x together. For double: within 1 ulp of the true values, the same bits in the
// one-sample and the batched momentum pass (sin_cos.cpp, MomentumBatch); other scalars (Jet):
// their own sin and cos.
void sin_cos(double x, double* sin_x, double* cos_x);
// Beyond this |x| (2^19 rad), and for inf and NaN, sin_cos(double) returns libm's values: up to
// it fn (pi/2) rounds exactly in its reduction, and three 33-bit steps of pi/2 keep the
// remainder within an ulp even for the x nearest to a multiple of pi/2.
inline constexpr double kSinCosRange = 524288.0;
template <class S>
inline void sin_cos(const S& x, S* sin_x, S* cos_x) {
  using std::cos;
  using std::sin;
  *sin_x = sin(x);
  *cos_x = cos(x);
}

inline void check_size(const char* function, const char* what, Eigen::Index got,
                       Eigen::Index want) {
  if (got != want) {
    throw std::invalid_argument(std::string(function) + ": " + what + " has " +
                                std::to_string(got) + " entries, the model has " +
                                std::to_string(want) + " joints");
  }
}

template <class S>
void check_q(const char* function, const Model& model, const DataTpl<S>& data,
             InVector<S> q) {
  check_size(function, "q", q.size(), model.nq);
  if (data.rotation.size() != static_cast<std::size_t>(model.nq)) {
    throw std::invalid_argument(std::string(function) + ": data was made for another model");
  }
}

// Forward velocity pass (after forward_kinematics): data.omega, data.velocity.
template <class S>
void forward_velocity(const Model& model, DataTpl<S>& data, InVector<S> dq) {
  using Vector3 = typename DataTpl<S>::Vector3;
  Vector3 omega_parent = Vector3::Zero();
  Vector3 velocity_parent = Vector3::Zero();
  Vector3 position_parent = Vector3::Zero();
  for (int i = 0; i < model.nq; ++i) {
    const Vector3& z = data.axis[i];
    Vector3 v = velocity_parent + omega_parent.cross(data.position[i] - position_parent);
    if (data.revolute[i]) {
      data.omega[i] = omega_parent + z * dq[i];
    } else {
      data.omega[i] = omega_parent;
      v += z * dq[i];
    }
    data.velocity[i] = v;
    omega_parent = data.omega[i];
    velocity_parent = v;
    position_parent = data.position[i];
  }
}

// Rotational inertia of body i in world axes applied to a world vector: R I (R^T x).
template <class S>
typename DataTpl<S>::Vector3 world_inertia_times(const DataTpl<S>& data, int i,
                                                 const typename DataTpl<S>::Vector3& x) {
  return data.rotation[i] * (data.inertia[i] * (data.rotation[i].transpose() * x));
}

// Recursive Newton-Euler; ddq may be null (= 0). Rotor inertia is the caller's business.
template <class S>
void rnea(const Model& model, DataTpl<S>& data, InVector<S> dq, const Eigen::Ref<const VectorX<S>>* ddq,
          bool with_gravity, VectorX<S>& tau) {
  using Vector3 = typename DataTpl<S>::Vector3;
  const int n = model.nq;
  forward_velocity(model, data, dq);
  Vector3 omega_parent = Vector3::Zero();
  Vector3 domega_parent = Vector3::Zero();
  Vector3 accel_parent = with_gravity ? Vector3(-data.gravity) : Vector3(Vector3::Zero());
  Vector3 position_parent = Vector3::Zero();
  for (int i = 0; i < n; ++i) {
    const Vector3& z = data.axis[i];
    const Vector3 r = data.position[i] - position_parent;
    Vector3 a = accel_parent + domega_parent.cross(r) + omega_parent.cross(omega_parent.cross(r));
    Vector3 dw = domega_parent;
    if (data.revolute[i]) {
      dw += omega_parent.cross(z) * dq[i];
      if (ddq) dw += z * (*ddq)[i];
    } else {
      a += S(2.0) * omega_parent.cross(z) * dq[i];
      if (ddq) a += z * (*ddq)[i];
    }
    data.domega[i] = dw;
    data.accel[i] = a;
    const Vector3& w = data.omega[i];
    const Vector3& rc = data.com_offset[i];
    const Vector3 accel_com = a + dw.cross(rc) + w.cross(w.cross(rc));
    const Vector3 force = data.mass[i] * accel_com;
    const Vector3 moment_com =
        world_inertia_times(data, i, dw) + w.cross(world_inertia_times(data, i, w));
    data.linear[i] = force;
    data.angular[i] = moment_com + (data.position[i] + rc).cross(force);
    omega_parent = w;
    domega_parent = dw;
    accel_parent = a;
    position_parent = data.position[i];
  }
  tau.resize(n);
  Vector3 force = Vector3::Zero();
  Vector3 moment = Vector3::Zero();  // about the world origin
  for (int i = n - 1; i >= 0; --i) {
    force += data.linear[i];
    moment += data.angular[i];
    const Vector3& z = data.axis[i];
    if (data.revolute[i]) {
      tau[i] = z.dot(moment - data.position[i].cross(force));
    } else {
      tau[i] = z.dot(force);
    }
  }
}

}  // namespace detail

template <class S>
DataTpl<S>::DataTpl(const Model& model) {
  const auto n = static_cast<std::size_t>(model.nq);
  for (const Joint& joint : model.joints) {
    const Eigen::Matrix3d k = detail::skew(joint.axis);
    const Eigen::Matrix3d& r0 = joint.placement.rotation;
    joint_rotation.push_back(r0.cast<S>());
    joint_rotation_k.push_back((r0 * k).cast<S>());
    joint_rotation_k2.push_back((r0 * k * k).cast<S>());
    joint_translation.push_back(joint.placement.translation.cast<S>());
    joint_axis_parent.push_back((r0 * joint.axis).cast<S>());
    revolute.push_back(joint.type == JointType::revolute ? 1 : 0);
  }
  for (const Body& body : model.bodies) {
    mass.push_back(S(body.mass));
    com.push_back(body.com.cast<S>());
    inertia.push_back(body.inertia.cast<S>());
  }
  Eigen::Matrix3d previous = Eigen::Matrix3d::Identity();  // A_{i-1}; the root frame is A_0 = I
  for (std::size_t i = 0; i < n; ++i) {
    const Joint& joint = model.joints[i];
    const Body& body = model.bodies[i];
    const Eigen::Matrix3d a = detail::frame_with_z_along(joint.axis);
    aligned_joint_rotation.push_back(
        (previous.transpose() * joint.placement.rotation * a).cast<S>());
    aligned_translation.push_back((previous.transpose() * joint.placement.translation).cast<S>());
    aligned_slide.push_back((previous.transpose() * joint.placement.rotation * joint.axis).cast<S>());
    aligned_com.push_back((a.transpose() * body.com).cast<S>());
    aligned_inertia.push_back((a.transpose() * body.inertia * a).cast<S>());
    previous = a;
  }
  aligned_rotation.assign(n, Matrix3::Identity());
  aligned_omega.assign(n, Vector3::Zero());
  aligned_velocity.assign(n, Vector3::Zero());
  aligned_gravity.assign(n, Vector3::Zero());
  aligned_linear.assign(n, Vector3::Zero());
  aligned_angular.assign(n, Vector3::Zero());
  rotor_inertia = model.rotor_inertia.cast<S>();
  gravity = model.gravity.cast<S>();
  tip_rotation = model.tip_placement.rotation.cast<S>();
  tip_translation = model.tip_placement.translation.cast<S>();
  rotation.assign(n, Matrix3::Identity());
  position.assign(n, Vector3::Zero());
  axis.assign(n, Vector3::Zero());
  com_offset.assign(n, Vector3::Zero());
  omega.assign(n, Vector3::Zero());
  velocity.assign(n, Vector3::Zero());
  domega.assign(n, Vector3::Zero());
  accel.assign(n, Vector3::Zero());
  linear.assign(n, Vector3::Zero());
  angular.assign(n, Vector3::Zero());
  tip_rotation_world = Matrix3::Identity();
  tip_position_world = Vector3::Zero();
}

template <class S>
void forward_kinematics(const Model& model, DataTpl<S>& data, InVector<S> q) {
  using std::cos;
  using std::sin;
  using Vector3 = typename DataTpl<S>::Vector3;
  using Matrix3 = typename DataTpl<S>::Matrix3;
  detail::check_q("forward_kinematics", model, data, q);
  Matrix3 rotation_parent = Matrix3::Identity();
  Vector3 position_parent = Vector3::Zero();
  for (int i = 0; i < model.nq; ++i) {
    Vector3 translation = data.joint_translation[i];
    Matrix3 local;
    if (data.revolute[i]) {
      const S s = sin(q[i]);
      const S c = cos(q[i]);
      // Rodrigues: R0 Rot(a, q) = R0 + sin q R0[a]x + (1 - cos q) R0[a]x^2.
      local = data.joint_rotation[i] + s * data.joint_rotation_k[i] +
              (S(1.0) - c) * data.joint_rotation_k2[i];
    } else {
      local = data.joint_rotation[i];
      translation += data.joint_axis_parent[i] * q[i];
    }
    data.axis[i] = rotation_parent * data.joint_axis_parent[i];
    data.position[i] = position_parent + rotation_parent * translation;
    data.rotation[i] = rotation_parent * local;
    data.com_offset[i] = data.rotation[i] * data.com[i];
    rotation_parent = data.rotation[i];
    position_parent = data.position[i];
  }
  data.tip_rotation_world = rotation_parent * data.tip_rotation;
  data.tip_position_world = position_parent + rotation_parent * data.tip_translation;
}

template <class S>
void mass_matrix(const Model& model, DataTpl<S>& data, InVector<S> q, MatrixX<S>& M) {
  using Vector3 = typename DataTpl<S>::Vector3;
  using Matrix3 = typename DataTpl<S>::Matrix3;
  forward_kinematics(model, data, q);
  const int n = model.nq;
  M.resize(n, n);
  // Composite rigid body of the subtree of joint i, about the world origin: mass, first moment
  // h = sum m c, rotational inertia J = sum (R I R^T + m [c]x^T [c]x).
  S m = S(0.0);
  Vector3 h = Vector3::Zero();
  Matrix3 J = Matrix3::Zero();
  for (int i = n - 1; i >= 0; --i) {
    const Vector3 c = data.position[i] + data.com_offset[i];
    const S mi = data.mass[i];
    m += mi;
    h += mi * c;
    J += data.rotation[i] * data.inertia[i] * data.rotation[i].transpose();
    J += mi * (c.squaredNorm() * Matrix3::Identity() - c * c.transpose());
    // Spatial force F = I^c S_i (about the world origin): linear l, angular k.
    const Vector3& z = data.axis[i];
    Vector3 l;
    Vector3 k;
    if (data.revolute[i]) {
      const Vector3 u = data.position[i].cross(z);  // S_i = [z; p x z]
      l = m * u + z.cross(h);
      k = J * z + h.cross(u);
    } else {  // S_i = [0; z]
      l = m * z;
      k = h.cross(z);
    }
    for (int j = 0; j <= i; ++j) {
      const Vector3& zj = data.axis[j];
      const S mji = data.revolute[j] ? zj.dot(k - data.position[j].cross(l)) : zj.dot(l);
      M(j, i) = mji;
      M(i, j) = mji;
    }
    M(i, i) += data.rotor_inertia[i];
  }
}

template <class S>
void gravity_torque(const Model& model, DataTpl<S>& data, InVector<S> q, VectorX<S>& g) {
  using Vector3 = typename DataTpl<S>::Vector3;
  forward_kinematics(model, data, q);
  const int n = model.nq;
  g.resize(n);
  S m = S(0.0);
  Vector3 h = Vector3::Zero();
  for (int i = n - 1; i >= 0; --i) {
    m += data.mass[i];
    h += data.mass[i] * (data.position[i] + data.com_offset[i]);
    const Vector3& z = data.axis[i];
    if (data.revolute[i]) {
      g[i] = -z.dot((h - m * data.position[i]).cross(data.gravity));
    } else {
      g[i] = -m * z.dot(data.gravity);
    }
  }
}

template <class S>
void coriolis_times_velocity(const Model& model, DataTpl<S>& data, InVector<S> q,
                             InVector<S> dq, VectorX<S>& c) {
  detail::check_size("coriolis_times_velocity", "dq", dq.size(), model.nq);
  forward_kinematics(model, data, q);
  detail::rnea<S>(model, data, dq, nullptr, false, c);
}

namespace detail {

// Shared backward pass of momentum_and_beta and coriolis_transpose_times_velocity. Writes p
// (if non-null), C^T dq into ct (if non-null) and g - C^T dq into beta (if non-null).
template <class S>
void momentum_pass(const Model& model, DataTpl<S>& data, InVector<S> q, InVector<S> dq,
                   VectorX<S>* p, VectorX<S>* ct, VectorX<S>* beta) {
  using Vector3 = typename DataTpl<S>::Vector3;
  using Matrix3 = typename DataTpl<S>::Matrix3;
  check_q("momentum_and_beta", model, data, q);
  check_size("momentum_and_beta", "dq", dq.size(), model.nq);
  const int n = model.nq;
  if (p) p->resize(n);
  if (ct) ct->resize(n);
  if (beta) beta->resize(n);
  // Forward, in aligned frames (joint axis = z): the joint rotation E_i = E0_i Rz(q_i), the
  // body's angular velocity w, the velocity v of its origin, gravity, and its momentum: linear
  // l = m (v + w x c), angular about the origin k = I w + c x l.
  Vector3 omega_parent = Vector3::Zero();
  Vector3 velocity_parent = Vector3::Zero();
  Vector3 gravity_parent = data.gravity;
  for (int i = 0; i < n; ++i) {
    const Matrix3& e0 = data.aligned_joint_rotation[i];
    Matrix3& e = data.aligned_rotation[i];
    Vector3 r = data.aligned_translation[i];
    const bool revolute = data.revolute[i] != 0;
    if (revolute) {
      S s, c;
      sin_cos(S(q[i]), &s, &c);
      e.col(0) = c * e0.col(0) + s * e0.col(1);
      e.col(1) = c * e0.col(1) - s * e0.col(0);
      e.col(2) = e0.col(2);
    } else {
      e = e0;
      r += data.aligned_slide[i] * q[i];
    }
    Vector3 omega = rotate_back(e, omega_parent);
    Vector3 velocity = rotate_back(e, Vector3(velocity_parent + cross(omega_parent, r)));
    if (revolute) {
      omega.z() += dq[i];
    } else {
      velocity.z() += dq[i];
    }
    const Vector3 gravity = rotate_back(e, gravity_parent);
    const Vector3& com = data.aligned_com[i];
    const Vector3 l = data.mass[i] * (velocity + cross(omega, com));
    data.aligned_omega[i] = omega;
    data.aligned_velocity[i] = velocity;
    data.aligned_gravity[i] = gravity;
    data.aligned_linear[i] = l;
    data.aligned_angular[i] = rotate(data.aligned_inertia[i], omega) + cross(com, l);
    omega_parent = omega;
    velocity_parent = velocity;
    gravity_parent = gravity;
  }
  // Backward: composite momentum (about the frame origin, on the joint axis), mass and first
  // moment of the subtree, carried from frame i+1 into frame i, then projected on z.
  S m = S(0.0);
  Vector3 first_moment = Vector3::Zero();
  Vector3 linear = Vector3::Zero();
  Vector3 angular = Vector3::Zero();
  for (int i = n - 1; i >= 0; --i) {
    if (i + 1 < n) {
      const Matrix3& e = data.aligned_rotation[i + 1];
      Vector3 r = data.aligned_translation[i + 1];
      if (!data.revolute[i + 1]) r += data.aligned_slide[i + 1] * q[i + 1];
      linear = rotate(e, linear);
      angular = rotate(e, angular) + cross(r, linear);
      first_moment = rotate(e, first_moment) + m * r;
    }
    m += data.mass[i];
    first_moment += data.mass[i] * data.aligned_com[i];
    linear += data.aligned_linear[i];
    angular += data.aligned_angular[i];
    const Vector3& w = data.aligned_omega[i];
    const Vector3& g = data.aligned_gravity[i];
    S pi;
    S cti;
    S gi;
    // With S_i = [z; 0] at the origin: (C^T dq)_i = h.(v_i x S_i) = K.(w x z) + L.(v x z), and
    // w x z = (w_y, -w_x, 0).
    if (data.revolute[i]) {
      const Vector3& v = data.aligned_velocity[i];
      pi = angular.z();
      cti = angular.x() * w.y() - angular.y() * w.x() + linear.x() * v.y() - linear.y() * v.x();
      gi = g.x() * first_moment.y() - g.y() * first_moment.x();  // -z.(F x g)
    } else {
      pi = linear.z();
      cti = linear.x() * w.y() - linear.y() * w.x();
      gi = -m * g.z();
    }
    if (p) (*p)[i] = pi + data.rotor_inertia[i] * dq[i];
    if (ct) (*ct)[i] = cti;
    if (beta) (*beta)[i] = gi - cti;
  }
}

}  // namespace detail

template <class S>
void coriolis_transpose_times_velocity(const Model& model, DataTpl<S>& data,
                                       InVector<S> q, InVector<S> dq,
                                       VectorX<S>& ct) {
  detail::momentum_pass<S>(model, data, q, dq, nullptr, &ct, nullptr);
}

template <class S>
void momentum_and_beta(const Model& model, DataTpl<S>& data, InVector<S> q,
                       InVector<S> dq, VectorX<S>& p, VectorX<S>& beta) {
  detail::momentum_pass<S>(model, data, q, dq, &p, nullptr, &beta);
}

template <class S>
void inverse_dynamics(const Model& model, DataTpl<S>& data, InVector<S> q,
                      InVector<S> dq, InVector<S> ddq, VectorX<S>& tau) {
  detail::check_size("inverse_dynamics", "dq", dq.size(), model.nq);
  detail::check_size("inverse_dynamics", "ddq", ddq.size(), model.nq);
  forward_kinematics(model, data, q);
  detail::rnea<S>(model, data, dq, &ddq, true, tau);
  for (int i = 0; i < model.nq; ++i) tau[i] += data.rotor_inertia[i] * ddq[i];
}

template <class S>
S kinetic_energy(const Model& model, DataTpl<S>& data, InVector<S> q, InVector<S> dq) {
  using Vector3 = typename DataTpl<S>::Vector3;
  detail::check_size("kinetic_energy", "dq", dq.size(), model.nq);
  forward_kinematics(model, data, q);
  detail::forward_velocity(model, data, dq);
  S twice = S(0.0);
  for (int i = 0; i < model.nq; ++i) {
    const Vector3& w = data.omega[i];
    const Vector3 vc = data.velocity[i] + w.cross(data.com_offset[i]);
    twice += data.mass[i] * vc.squaredNorm() + w.dot(detail::world_inertia_times(data, i, w)) +
             data.rotor_inertia[i] * dq[i] * dq[i];
  }
  return S(0.5) * twice;
}

template <class S>
S potential_energy(const Model& model, DataTpl<S>& data, InVector<S> q) {
  forward_kinematics(model, data, q);
  S v = S(0.0);
  for (int i = 0; i < model.nq; ++i) {
    v -= data.mass[i] * data.gravity.dot(data.position[i] + data.com_offset[i]);
  }
  return v;
}

template <class S>
Eigen::Matrix<S, 3, 1> point_position(const Model& model, DataTpl<S>& data, InVector<S> q,
                                      int body, InVector3<S> point_in_body) {
  if (body < 0 || body >= model.nq) {
    throw std::invalid_argument("point_position: body " + std::to_string(body) +
                                " out of range 0.." + std::to_string(model.nq - 1));
  }
  forward_kinematics(model, data, q);
  return data.position[body] + data.rotation[body] * point_in_body;
}

template <class S>
void point_jacobian(const Model& model, DataTpl<S>& data, InVector<S> q, int body,
                    InVector3<S> point_in_body, Matrix3X<S>& J) {
  using Vector3 = typename DataTpl<S>::Vector3;
  const Vector3 x = point_position(model, data, q, body, point_in_body);
  J.resize(3, model.nq);
  J.setZero();
  for (int j = 0; j <= body; ++j) {
    const Vector3& z = data.axis[j];
    J.col(j) = data.revolute[j] ? Vector3(z.cross(x - data.position[j])) : z;
  }
}

}  // namespace momentum::model
