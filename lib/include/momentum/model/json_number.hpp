// A double as a JSON value, the one way every report writes numbers into JSON. It lives in
// model/, the lowest stage that exposes nlohmann::json (core/ does not depend on it).
#pragma once

#include <cmath>

#include <nlohmann/json.hpp>

namespace momentum::model {

// `value` as a JSON number when it is finite; null for NaN and +-inf, which JSON cannot
// write (a missing or undefined number: a delay of no detection, an unidentified parameter).
nlohmann::json json_number(double value);

}  // namespace momentum::model
