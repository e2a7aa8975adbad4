// The annotator interface's key function (annotator.hpp): its vtable and type information are
// emitted here once, not in every unit that includes the header.
#include "momentum/detect/annotator.hpp"

namespace momentum::detect {

EventAnnotator::~EventAnnotator() = default;

}  // namespace momentum::detect
