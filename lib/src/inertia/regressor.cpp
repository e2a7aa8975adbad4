#include "momentum/inertia/regressor.hpp"

#include "momentum/model/inertial_corrections.hpp"

namespace momentum::inertia {

const std::array<const char*, kBodyParameters>& parameter_names() {
  static const std::array<const char*, kBodyParameters> names = {
      "m", "mx", "my", "mz", "ixx", "ixy", "ixz", "iyy", "iyz", "izz"};
  return names;
}

Eigen::VectorXd model_parameters(const model::Model& model) {
  Eigen::VectorXd theta(kBodyParameters * model.nq);
  for (int k = 0; k < model.nq; ++k) {
    theta.segment<kBodyParameters>(body_offset(k)) =
        model::standard_parameters(model.bodies[static_cast<std::size_t>(k)]);
  }
  return theta;
}

template void momentum_regressor<double>(const model::Model&, model::DataTpl<double>&,
                                         model::InVector<double>, model::InVector<double>,
                                         model::MatrixX<double>&, model::MatrixX<double>&);

}  // namespace momentum::inertia
