// Template definitions for regressor.hpp. Include regressor.hpp, not this file.
#pragma once

#include "momentum/dynfit/regressor.hpp"

namespace momentum::dynfit {

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
  // Per joint: V_i x S_i (angular, linear parts), and the velocity of the point at the origin.
  for (int k = 0; k < n; ++k) {
    const Matrix3& R = data.rotation[k];
    const Vector3& o = data.position[k];
    const Vector3& w = data.omega[k];
    const Vector3& v = data.velocity[k];
    const Vector3 w_body = R.transpose() * w;
    std::array<Vector3, kBodyParameters> linear, angular;
    linear[0] = v;
    angular[0] = Vector3::Zero();
    for (int e = 0; e < 3; ++e) {
      const Vector3 axis = R.col(e);
      linear[1 + e] = w.cross(axis);
      angular[1 + e] = axis.cross(v);
    }
    // Ixx, Ixy, Ixz, Iyy, Iyz, Izz: E w_body, rotated back to the world.
    const int rows[6] = {0, 0, 0, 1, 1, 2};
    const int cols[6] = {0, 1, 2, 1, 2, 2};
    for (int e = 0; e < 6; ++e) {
      Vector3 ew = Vector3::Zero();
      ew[rows[e]] += w_body[cols[e]];
      if (rows[e] != cols[e]) ew[cols[e]] += w_body[rows[e]];
      linear[4 + e] = Vector3::Zero();
      angular[4 + e] = R * ew;
    }
    for (int i = 0; i <= k; ++i) {
      const Vector3& z = data.axis[i];
      const Vector3& oi = data.position[i];
      const Vector3& wi = data.omega[i];
      const bool revolute = data.revolute[i] != 0;
      // V_i x S_i = [w_i x a_S ; w_i x b_S + vO_i x a_S], S_i = [a_S; b_S].
      Vector3 cross_angular, cross_linear;
      if (revolute) {
        const Vector3 velocity_origin = data.velocity[i] + oi.cross(wi);
        cross_angular = wi.cross(z);
        cross_linear = wi.cross(Vector3(oi.cross(z))) + velocity_origin.cross(z);
      } else {
        cross_angular = Vector3::Zero();
        cross_linear = wi.cross(z);
      }
      const Vector3 arm = o - oi;
      for (int j = 0; j < kBodyParameters; ++j) {
        const Vector3& l = linear[j];
        const Vector3 about_origin = angular[j] + o.cross(l);
        S momentum_i, coriolis_i;
        if (revolute) {
          momentum_i = z.dot(Vector3(angular[j] + arm.cross(l)));
          coriolis_i = about_origin.dot(cross_angular) + l.dot(cross_linear);
        } else {
          momentum_i = z.dot(l);
          coriolis_i = l.dot(cross_linear);
        }
        S gravity_i = S(0.0);
        if (j == 0) {
          gravity_i = revolute ? S(-gravity.dot(Vector3(z.cross(arm)))) : S(-gravity.dot(z));
        } else if (j <= 3 && revolute) {
          gravity_i = -gravity.dot(Vector3(z.cross(Vector3(R.col(j - 1)))));
        }
        const int c = kBodyParameters * k + j;
        Yp(i, c) += momentum_i;
        Yb(i, c) += gravity_i - coriolis_i;
      }
    }
  }
}

}  // namespace momentum::dynfit
