// The parameter checks of the Dahl model (dahl.hpp): out of line, as they run once per profile
// read or fit, not per sample.
#include "momentum/friction/dahl.hpp"

#include <iterator>

namespace momentum::friction {

bool Dahl::IsValid(const Parameters<double>& p, std::string* why) {
  return check::finite(p, std::begin(kParameters), std::end(kParameters), why) &&
         check::finite(p, std::begin(kAsymmetry), std::end(kAsymmetry), why) && check::not_negative(p, 2, why) &&
         check::positive(p, 3, why) && check::below(p, 6, 3, why) && check::positive(p, 0, why);
}

}  // namespace momentum::friction
