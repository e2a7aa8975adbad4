// The parameter checks of the Coulomb-viscous model (coulomb_viscous.hpp): out of line, as they run once per profile
// read or fit, not per sample.
#include "momentum/friction/coulomb_viscous.hpp"

#include <iterator>

namespace momentum::friction {

bool CoulombViscous::IsValid(const Parameters<double>& p, std::string* why) {
  return check::finite(p, std::begin(kParameters), std::end(kParameters), why) &&
         check::finite(p, std::begin(kAsymmetry), std::end(kAsymmetry), why) && check::not_negative(p, 2, why) &&
         check::not_negative(p, 3, why) && check::not_above(p, 6, 3, why);
}

}  // namespace momentum::friction
