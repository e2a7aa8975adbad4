#pragma once
// Robust statistics shared by the fitters.

#include <vector>

namespace momentum::core {

// The median of `values` (reordered in place; NaN not allowed), interpolated within its bin
// when the values are quantised: drives report velocity as an integer count (a UR10e in steps
// of 1e-4 rad/s, the simulator by default 1e-3), so the plain median of a noise statistic is a
// multiple of the step and an estimate from it is off by up to half a step. When the median
// value is tied, the bin around it reaches halfway to the neighbouring values on each side
// (from the value itself when it is the smallest) and the median is placed in it by the share
// of ties below the middle (the grouped-data median). Values within 1e-9 of the largest
// magnitude of each other are ties. Empty: NaN.
double grouped_median(std::vector<double>& values);

// Standard deviation of white noise on a signal from |second differences| of consecutive samples
// (reordered in place): white noise of deviation s has second differences of deviation
// s sqrt(6), and their median magnitude is robust to the signal's own curvature and to the odd
// outlier. Empty: 0.
double white_noise_from_second_differences(std::vector<double>& magnitudes);

}  // namespace momentum::core
