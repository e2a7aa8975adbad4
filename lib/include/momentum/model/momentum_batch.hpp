// The momentum observer's dynamics, p = M(q) dq and beta = g(q) - C(q,dq)^T dq, for several
// samples at once: one sample per lane of a SIMD vector, so a stream read from a file costs
// less than half the time per row of momentum_and_beta (tests/data/ur5.json with AVX2: 94
// against 222 ns a row, bench/model_bench.cpp; eight lanes with AVX-512 gave 86 ns, too little
// to show in mo-observe's time).
//
// The arithmetic is momentum_and_beta's (dynamics_impl.hpp, momentum_pass), operation for
// operation and in the same order, so every lane's result is bit for bit the one
// momentum_and_beta gives for that sample (tests/model/momentum_batch_test.cpp pins it; both
// files are compiled without floating-point contraction, so that an FMA build keeps it too).
#pragma once

#include <vector>

#include "momentum/model/dynamics.hpp"
#include "momentum/model/model.hpp"

namespace momentum::model {

class MomentumBatch {
 public:
  // Samples computed together: one AVX2 register per value (two SSE2 registers on x86-64's
  // baseline). Two lanes gained a third less.
  static constexpr int kLanes = 4;

  // Takes the model's constants from `data` (a Data made from `model`); keeps no reference to
  // either. Throws std::invalid_argument when data was made for another model. With
  // `use_cpu_extensions` false, runs on the baseline instruction set even where the CPU has
  // more (tests compare the two).
  MomentumBatch(const Model& model, const Data& data, bool use_cpu_extensions = true);

  // p and beta (nq values each, Nms and Nm) of `count` samples (1..kLanes): q[k] and dq[k]
  // point at sample k's nq positions (rad, m) and velocities; the results go to p[k] and
  // beta[k]. Lanes beyond `count` compute sample 0 again and are discarded. Throws
  // std::invalid_argument when count is outside 1..kLanes. Allocates nothing.
  void run(int count, const double* const q[], const double* const dq[], double* const p[],
           double* const beta[]);

  int joints() const { return n_; }
  // Whether run() costs less per sample than momentum_and_beta on this CPU: with AVX2 (x86-64),
  // about half; on the baseline instruction set, where a vector of four is two SSE2 registers,
  // about a quarter more (tests/data/ur5.json: 290 against 225 ns), so callers should then
  // compute one sample at a time.
  bool accelerated() const { return accelerated_; }

 private:
  friend struct MomentumBatchPass;
  int n_;
  bool accelerated_ = false;
  // Per joint, as momentum_pass reads them from Data: the aligned joint rotation (row major),
  // translation, prismatic direction, centre of mass, inertia (row major), mass, rotor inertia.
  std::vector<double> joint_rotation_, translation_, slide_, com_, inertia_, mass_, rotor_;
  std::vector<unsigned char> revolute_;
  double gravity_[3];
  // Scratch, kLanes values per entry: the per-joint results of the forward pass.
  std::vector<double> rotation_, omega_, velocity_, gravity_frame_, linear_, angular_, dq_;
};

}  // namespace momentum::model
