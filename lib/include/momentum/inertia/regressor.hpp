// The rigid-body dynamics written as linear functions of the inertial parameters, for
// identification. Every moving body k contributes ten standard parameters, in its own (joint)
// frame and about its own origin (a point on its joint axis):
//
//   theta_k = [m, m cx, m cy, m cz, Ixx, Ixy, Ixz, Iyy, Iyz, Izz]      (kg, kg m, kg m^2)
//
// with I the rotational inertia about the body ORIGIN (I = I_com + m ([c].[c] E - c c^T)), so
// that theta = [theta_1 .. theta_n] (10 n) enters the dynamics linearly:
//
//   p    = M(q) dq            = Y_p(q, dq) theta + B dq     (generalized momentum)
//   beta = g(q) - C(q,dq)^T dq = Y_b(q, dq) theta
//   tau  = M ddq + C dq + g   = d/dt(Y_p theta + B dq) + Y_b theta
//
// B = diag(rotor_inertia) is a known constant of the drive, not identified here.
//
// This is a second, independent implementation of the momentum pass of model/dynamics.hpp
// (world-frame Jacobians instead of aligned body frames), so the two check each other.
// Templated on the scalar (double or ceres::Jet): a Jet in time gives dY_p/dt exactly.
#pragma once

#include <array>
#include <string>

#include <Eigen/Core>

#include "momentum/model/dynamics.hpp"
#include "momentum/model/model.hpp"

namespace momentum::inertia {

// Parameters per body, and their names in the order above.
inline constexpr int kBodyParameters = 10;
const std::array<const char*, kBodyParameters>& parameter_names();

// Index of the first parameter of body k (0-based) in theta.
inline int body_offset(int k) { return kBodyParameters * k; }

// All bodies' standard parameters (model::standard_parameters), 10 nq, body k's at 10 k.
Eigen::VectorXd model_parameters(const model::Model& model);

// Y_p and Y_b (both nq x 10 nq) at (q, dq). Overwrites data's world-frame fields (as
// forward_kinematics does). Throws std::invalid_argument on size mismatches.
template <class S>
void momentum_regressor(const model::Model& model, model::DataTpl<S>& data,
                        model::InVector<S> q, model::InVector<S> dq, model::MatrixX<S>& Yp,
                        model::MatrixX<S>& Yb);

}  // namespace momentum::inertia

#include "momentum/inertia/regressor_impl.hpp"
