// Random numbers for the simulator, bit-identical on every platform and standard library.
// std::normal_distribution and friends are implementation-defined, so a --seed would not give
// the same log on another machine; the engine (std::mt19937_64) is fully specified, and the
// distributions below are written out.
#pragma once

#include <cstdint>
#include <random>

namespace momentum::sim {

// Mixes a seed and a stream tag into an independent seed (SplitMix64 finaliser), so that every
// random process (trajectory, contacts, sensors) has its own stream and changing one option
// does not move the draws of another.
std::uint64_t derive_seed(std::uint64_t seed, std::uint64_t stream_tag);

class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  // Uniform on [0, 1) with 53 random bits.
  double uniform();
  // Uniform on [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  // Uniform integer in [lo, hi] (inclusive); requires lo <= hi.
  int integer(int lo, int hi);
  // Standard normal (Box-Muller, both values used).
  double normal();
  // Bernoulli with probability p (p <= 0: never, p >= 1: always).
  bool chance(double p) { return p > 0 && uniform() < p; }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0;
  bool has_spare_ = false;
};

}  // namespace momentum::sim
