#include <cmath>
#include <cstdint>

#include "momentum/model/dynamics.hpp"
#include "sin_cos_kernel.hpp"

namespace momentum::model::detail {

void sin_cos(double x, double* sin_x, double* cos_x) {
  if (!(std::fabs(x) < kSinCosRange)) {
    *sin_x = std::sin(x);
    *cos_x = std::cos(x);
    return;
  }
  sin_cos_reduced<double, std::uint64_t>(
      x, sin_x, cos_x, [](double v) { return std::bit_cast<std::uint64_t>(v); },
      [](std::uint64_t mask, double a, double b) { return mask ? a : b; });
}

}  // namespace momentum::model::detail
