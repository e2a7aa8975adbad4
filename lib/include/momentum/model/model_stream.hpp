// What mo-model does to a sample stream: per row, from q<j> (and dq<j>, ddq<j> when present)
// append the gravity torque g<j>, beta<j> = g - C^T dq and the momentum p<j> = M dq, the mass
// matrix entries m<i>_<k> on request, and the inverse dynamics tau_id<j> = M ddq + C dq + g.
// Constant memory; columns are looked up once, at header time.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "momentum/model/dynamics.hpp"
#include "momentum/stream/reader.hpp"
#include "momentum/stream/writer.hpp"

namespace momentum::model {

struct ModelStreamOptions {
  // Append m<i>_<k> for i, k = 1..n (row-major, n^2 columns).
  bool mass_matrix = false;
};

class ModelStream {
 public:
  // Reads the header of `in` and decides the output columns. Throws momentum::Error naming
  // the input when: q1..qn is not exactly the chain's joint count; dq or ddq columns are only
  // partly there (e.g. dq1..dq5 for 6 joints); ddq is there without dq; an output column
  // (g1, beta1, ...) is already in the input.
  ModelStream(stream::Reader& in, const Model& model, ModelStreamOptions options = {});

  // Input columns followed by the appended ones.
  const std::vector<std::string>& columns() const { return columns_; }
  bool has_velocity() const { return !dq_.empty(); }
  bool has_acceleration() const { return !ddq_.empty(); }

  // Writes the header and every row to `out` (comments after the header are passed through),
  // until the input ends. Returns the number of rows written. Does not close `out`.
  std::uint64_t run(stream::Writer& out);

 private:
  stream::Reader& in_;
  const Model& model_;
  ModelStreamOptions options_;
  std::vector<std::size_t> q_, dq_, ddq_;  // input column indices
  std::vector<std::string> columns_;
};

}  // namespace momentum::model
