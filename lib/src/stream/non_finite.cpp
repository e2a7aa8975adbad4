#include "momentum/stream/non_finite.hpp"

#include "momentum/core/number.hpp"

namespace momentum::stream {

void NonFiniteRows::note(const Reader& in, double t) {
  if (count_++ == 0) {
    first_ = in.where();
    first_t_ = t;
  }
  last_ = in.where();
  last_t_ = t;
}

std::string NonFiniteRows::summary() const {
  if (count_ == 0) return {};
  std::string out = std::to_string(count_) + (count_ == 1 ? " row" : " rows") +
                    " left out: a value they need is not a finite number (at " + first_ + ", t=" +
                    core::significant(first_t_, 9);
  if (count_ > 1) out += "; last at " + last_ + ", t=" + core::significant(last_t_, 9);
  return out + ")";
}

}  // namespace momentum::stream
