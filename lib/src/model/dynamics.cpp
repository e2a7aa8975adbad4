// Explicit instantiations for S = double; see the extern declarations at the end of dynamics.hpp.
#include "momentum/model/dynamics.hpp"

namespace momentum::model {
template void forward_kinematics<double>(const Model&, Data&, InVector<double>);
template void mass_matrix<double>(const Model&, Data&, InVector<double>, MatrixX<double>&);
template void gravity_torque<double>(const Model&, Data&, InVector<double>, VectorX<double>&);
template void coriolis_times_velocity<double>(const Model&, Data&, InVector<double>, InVector<double>,
    VectorX<double>&);
template void coriolis_transpose_times_velocity<double>(const Model&, Data&, InVector<double>,
    InVector<double>, VectorX<double>&);
template void momentum_and_beta<double>(const Model&, Data&, InVector<double>, InVector<double>,
    VectorX<double>&, VectorX<double>&);
template void inverse_dynamics<double>(const Model&, Data&, InVector<double>, InVector<double>,
    InVector<double>, VectorX<double>&);
template double kinetic_energy<double>(const Model&, Data&, InVector<double>, InVector<double>);
template double potential_energy<double>(const Model&, Data&, InVector<double>);
template Eigen::Matrix<double, 3, 1> point_position<double>(const Model&, Data&, InVector<double>, int,
    InVector3<double>);
template void point_jacobian<double>(const Model&, Data&, InVector<double>, int, InVector3<double>,
    Matrix3X<double>&);
}  // namespace momentum::model
