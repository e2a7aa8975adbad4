// The simulator's random numbers are the suite's one seeded source (momentum/core/random.hpp):
// these names keep the simulator's code as it was. mo-sim's output for a --seed depends on
// core::derive_seed and core::Random drawing exactly as they do.
#pragma once

#include "momentum/core/random.hpp"

namespace momentum::sim {

using core::derive_seed;
using Random = core::Random;

}  // namespace momentum::sim
