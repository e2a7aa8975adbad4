#pragma once
// The one seeded random source of the suite: every random process (the simulator's trajectory,
// contacts and sensors, the fitter's genetic algorithm and noise draws, mo-dynfit's noisy
// copies) derives its numbers from a tool's --seed through the functions here, so that a seed
// gives the same numbers on every platform and standard library. The engine is
// std::mt19937_64, whose output the C++ standard fixes; the distributions are written out here
// because std::uniform_real_distribution and std::normal_distribution are
// implementation-defined.
//
// Seeds: derive_seed(seed, tag) gives each random process its own independent stream, so that
// changing one option does not move the draws of another. mo-sim's published numbers depend on
// the exact values below: they must not change.

#include <cstddef>
#include <cstdint>
#include <random>

namespace momentum::core {

// SplitMix64 (Steele, Lea and Flood 2014): adds the golden-ratio increment to `x` and mixes the
// result with its finaliser. A bijection on 64-bit words that turns nearby inputs into
// unrelated outputs.
std::uint64_t splitmix64(std::uint64_t x);

// An independent seed for the random process `tag` of a run seeded with `seed`:
// splitmix64(seed + tag * 0x9E3779B97F4A7C15), i.e. the (tag + 1)-th output of a SplitMix64
// generator started at `seed`.
std::uint64_t derive_seed(std::uint64_t seed, std::uint64_t tag);

// 53 random bits of `bits` as a double uniform on [0, 1).
inline double unit_interval(std::uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1.0p-53; }

// A standard normal value that depends only on `key` (Box-Muller on two uniforms mixed from the
// key): a counter-based draw, for noise that must come out the same whichever order the draws
// are made in (mo-dynfit adds the same noise to a sample when it streams and when it replays).
double normal_at(std::uint64_t key);

// A seeded stream of random numbers. Random(derive_seed(seed, tag)) for each random process.
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  // 64 random bits.
  std::uint64_t next() { return engine_(); }
  // Uniform on [0, 1) with 53 random bits.
  double uniform() { return unit_interval(engine_()); }
  // Uniform on [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  // Uniform integer in [0, n), n > 0; exactly uniform (rejection sampling).
  std::uint64_t below(std::uint64_t n);
  // Uniform integer in [lo, hi] (inclusive); requires lo <= hi.
  int integer(int lo, int hi);
  // Standard normal (Box-Muller; both values of a pair are used, the second on the next call).
  double normal();
  // Standard normal, one value per call (Box-Muller on 1 - uniform() and uniform(), the sine
  // half dropped): the fitter's noise draws, whose uncertainty tests depend on them.
  double normal_unpaired();
  // Bernoulli with probability p (p <= 0: never, p >= 1: always).
  bool chance(double p) { return p > 0 && uniform() < p; }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0;
  bool has_spare_ = false;
};

}  // namespace momentum::core
