// The parameter checks of LuGre (lugre.hpp): out of line, as they run once per profile
// read or fit, not per sample.
#include "momentum/friction/lugre.hpp"

#include <iterator>

namespace momentum::friction {

bool Lugre::IsValid(const Parameters<double>& p, std::string* why) {
  return check::finite(p, std::begin(kParameters), std::end(kParameters), why) &&
         check::finite(p, std::begin(kAsymmetry), std::end(kAsymmetry), why) && Stribeck::levels_valid(p, why) &&
         check::positive(p, 0, why) && check::not_negative(p, 1, why);
}

}  // namespace momentum::friction
