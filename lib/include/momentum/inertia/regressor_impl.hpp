// Template definitions for regressor.hpp. Include regressor.hpp, not this file.
#pragma once

#include <array>
#include <vector>

// (regressor.hpp includes this file at its end, after every declaration it needs.)

namespace momentum::inertia {


// World frame throughout. For body k: rotation R, origin o, angular velocity w, origin velocity
// v. A unit of each parameter gives the body a momentum (linear l, angular a about o):
//   m:        l = v,        a = 0
//   m c_e:    l = w x e,    a = e x v          (e = R e_axis)
//   I_O:      l = 0,        a = R E R^T w      (E the symmetric unit matrix of the entry)
// and a potential energy V = -g.(m o + R mc). With S_i the motion subspace of joint i (Plucker,
// about the world origin) and V_i its spatial velocity, for every joint i <= k:
//   p_i += S_i^T h,   (C^T dq)_i += h^T (V_i x S_i),   g_i += dV/dq_i.
template <class S>
void momentum_regressor(const model::Model& model, model::DataTpl<S>& data,
                        model::InVector<S> q, model::InVector<S> dq, model::MatrixX<S>& Yp,
                        model::MatrixX<S>& Yb) {
  using Vector3 = typename model::DataTpl<S>::Vector3;
  using Matrix3 = typename model::DataTpl<S>::Matrix3;
  model::detail::check_size("momentum_regressor", "dq", dq.size(), model.nq);
  model::forward_kinematics(model, data, q);
  model::detail::forward_velocity(model, data, dq);
  const int n = model.nq;
  Yp.setZero(n, kBodyParameters * n);
  Yb.setZero(n, kBodyParameters * n);
  const Vector3& gravity = data.gravity;
  // Per joint i, what does not depend on the body: its axis z, V_i x S_i (angular, linear
  // parts), and o_i x z for the momentum about the joint, z.(a + (o - o_i) x l) =
  // z.(a + o x l) + l.(o_i x z).
  struct JointTerms {
    Vector3 z, cross_angular, cross_linear, origin_cross_z;
    bool revolute = false;
  };
  std::vector<JointTerms> joints(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    JointTerms& J = joints[static_cast<std::size_t>(i)];
    const Vector3& z = data.axis[i];
    const Vector3& oi = data.position[i];
    const Vector3& wi = data.omega[i];
    J.z = z;
    J.revolute = data.revolute[i] != 0;
    // V_i x S_i = [w_i x a_S ; w_i x b_S + vO_i x a_S], S_i = [a_S; b_S].
    if (J.revolute) {
      const Vector3 velocity_origin = data.velocity[i] + oi.cross(wi);
      J.cross_angular = wi.cross(z);
      J.cross_linear = wi.cross(Vector3(oi.cross(z))) + velocity_origin.cross(z);
      J.origin_cross_z = oi.cross(z);
    } else {
      J.cross_angular = Vector3::Zero();
      J.cross_linear = wi.cross(z);
      J.origin_cross_z = Vector3::Zero();
    }
  }
  for (int k = 0; k < n; ++k) {
    const Matrix3& R = data.rotation[k];
    const Vector3& o = data.position[k];
    const Vector3& w = data.omega[k];
    const Vector3& v = data.velocity[k];
    const Vector3 w_body = R.transpose() * w;
    // A unit of each parameter: linear momentum l and angular momentum about the world origin.
    std::array<Vector3, kBodyParameters> linear, about_origin;
    linear[0] = v;
    about_origin[0] = o.cross(v);
    for (int e = 0; e < 3; ++e) {
      const Vector3 axis = R.col(e);
      linear[1 + e] = w.cross(axis);
      about_origin[1 + e] = Vector3(axis.cross(v)) + o.cross(linear[1 + e]);
    }
    // Ixx, Ixy, Ixz, Iyy, Iyz, Izz: E w_body, rotated back to the world.
    const int rows[6] = {0, 0, 0, 1, 1, 2};
    const int cols[6] = {0, 1, 2, 1, 2, 2};
    for (int e = 0; e < 6; ++e) {
      Vector3 ew = Vector3::Zero();
      ew[rows[e]] += w_body[cols[e]];
      if (rows[e] != cols[e]) ew[cols[e]] += w_body[rows[e]];
      linear[4 + e] = Vector3::Zero();
      about_origin[4 + e] = R * ew;
    }
    // The potential energy's gradient: -g.(z x (o - o_i)) for m, -g.(z x R e) for m c_e.
    const Vector3 g_cross_o = gravity.cross(o);
    std::array<Vector3, 3> g_cross_axis;
    for (int e = 0; e < 3; ++e) g_cross_axis[static_cast<std::size_t>(e)] = gravity.cross(Vector3(R.col(e)));
    for (int i = 0; i <= k; ++i) {
      const JointTerms& J = joints[static_cast<std::size_t>(i)];
      const int c = kBodyParameters * k;
      if (J.revolute) {
        // -g.(z x arm) = -z.(arm x g) = z.(g x arm), arm = o - o_i.
        const Vector3 g_cross_arm = g_cross_o - gravity.cross(data.position[i]);
        for (int j = 0; j < kBodyParameters; ++j) {
          const Vector3& l = linear[static_cast<std::size_t>(j)];
          const Vector3& a = about_origin[static_cast<std::size_t>(j)];
          const S momentum_i = J.z.dot(a) + l.dot(J.origin_cross_z);
          const S coriolis_i = a.dot(J.cross_angular) + l.dot(J.cross_linear);
          S gravity_i = S(0.0);
          if (j == 0) {
            gravity_i = J.z.dot(g_cross_arm);
          } else if (j <= 3) {
            gravity_i = J.z.dot(g_cross_axis[static_cast<std::size_t>(j - 1)]);
          }
          Yp(i, c + j) += momentum_i;
          Yb(i, c + j) += gravity_i - coriolis_i;
        }
      } else {
        for (int j = 0; j < kBodyParameters; ++j) {
          const Vector3& l = linear[static_cast<std::size_t>(j)];
          const S momentum_i = J.z.dot(l);
          const S coriolis_i = l.dot(J.cross_linear);
          const S gravity_i = j == 0 ? S(-gravity.dot(J.z)) : S(0.0);
          Yp(i, c + j) += momentum_i;
          Yb(i, c + j) += gravity_i - coriolis_i;
        }
      }
    }
  }
}

}  // namespace momentum::inertia
