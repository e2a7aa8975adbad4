#pragma once
// Rows a consumer leaves out because a value it needs is not a finite number (NaN, inf): a
// span of them is reported once, with its place, instead of passing in silence (a log whose
// second half is NaN fits or calibrates on its first half, and says so).

#include <cstdint>
#include <string>

#include "momentum/stream/reader.hpp"

namespace momentum::stream {

class NonFiniteRows {
 public:
  // Notes the row `in` last returned (at time t, s) as left out.
  void note(const Reader& in, double t);
  std::uint64_t count() const { return count_; }
  // "N rows left out: a value they need is not a finite number (first at WHERE, t=..., last
  // at WHERE, t=...)", or empty when none was noted.
  std::string summary() const;

 private:
  std::uint64_t count_ = 0;
  std::string first_, last_;
  double first_t_ = 0, last_t_ = 0;
};

}  // namespace momentum::stream
