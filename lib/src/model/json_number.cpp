#include "momentum/model/json_number.hpp"

#include <cmath>

namespace momentum::model {

nlohmann::json json_number(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

}  // namespace momentum::model
