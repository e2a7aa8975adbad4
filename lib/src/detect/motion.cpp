// The rest statistic's share of a contact (motion.hpp); the per-row trackers stay inline in
// the header, since the detector steps them on every row of every joint.
#include "momentum/detect/motion.hpp"

#include <cmath>

namespace momentum::detect {

double drift_gain(double drift_time, double rise) {
  if (!(drift_time > 0 && std::isfinite(drift_time))) return 1;
  if (!(rise > 0)) return 1;
  return -drift_time / rise * std::expm1(-rise / drift_time);
}

}  // namespace momentum::detect
