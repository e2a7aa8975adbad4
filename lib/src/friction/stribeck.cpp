// The parameter checks of the Stribeck model (stribeck.hpp): out of line, as they run once per profile
// read or fit, not per sample.
#include "momentum/friction/stribeck.hpp"

#include <iterator>

namespace momentum::friction {

bool Stribeck::IsValid(const Parameters<double>& p, std::string* why) {
  return check::finite(p, std::begin(kParameters), std::end(kParameters), why) &&
         check::finite(p, std::begin(kAsymmetry), std::end(kAsymmetry), why) && levels_valid(p, why);
}

}  // namespace momentum::friction
