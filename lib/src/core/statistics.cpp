#include "momentum/core/statistics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace momentum::core {

double grouped_median(std::vector<double>& values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t n = values.size();
  auto mid = values.begin() + static_cast<std::ptrdiff_t>(n / 2);
  std::nth_element(values.begin(), mid, values.end());
  const double v = *mid;
  // Sums of quantised values (a second difference) differ from the multiple of the step by
  // rounding: values that close are ties.
  double largest = 0;
  for (double x : values) largest = std::max(largest, std::fabs(x));
  const double tie = 1e-9 * largest;
  std::size_t below = 0, equal = 0;
  double previous = -std::numeric_limits<double>::infinity(), next = std::numeric_limits<double>::infinity();
  for (double x : values) {
    if (x < v - tie) {
      ++below;
      previous = std::max(previous, x);
    } else if (x <= v + tie) {
      ++equal;
    } else {
      next = std::min(next, x);
    }
  }
  if (equal < 2) return v;
  const bool has_previous = std::isfinite(previous), has_next = std::isfinite(next);
  if (!has_previous && !has_next) return v;  // all equal
  const double step = std::min(has_previous ? v - previous : INFINITY, has_next ? next - v : INFINITY);
  const double from = has_previous ? v - step / 2 : v;
  const double width = v + step / 2 - from;
  return from + width * (static_cast<double>(n) / 2 - static_cast<double>(below)) / static_cast<double>(equal);
}

double white_noise_from_second_differences(std::vector<double>& magnitudes) {
  if (magnitudes.empty()) return 0;
  return grouped_median(magnitudes) / 0.6744897501960817 / std::sqrt(6.0);
}

}  // namespace momentum::core
