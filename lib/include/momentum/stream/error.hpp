#pragma once
// Errors and warnings live in the core stage (momentum/core/error.hpp); this name stays for the
// stages and tools that include it.
#include "momentum/core/error.hpp"
