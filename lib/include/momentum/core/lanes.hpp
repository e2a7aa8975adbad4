#pragma once
// Two doubles at a time in SSE2's registers (x86-64's baseline; GCC's and Clang's vector
// extension lower it to scalar code elsewhere), for per-joint loops of the hot path: the same
// operations as on one double, bit for bit, so that a loop may run its pairs as Pair and its
// odd last joint as double with one body (a template on the lane type).
//
// A comparison of Pairs gives a PairMask: all ones in a lane where it holds, zeros elsewhere,
// as a comparison of doubles gives a bool; `&` and `|` combine either kind.

#include <cstddef>
#include <cstdint>
#include <cstring>

// A hot function compiled twice, for x86-64's baseline and for AVX2 (VEX's three-operand
// instructions, and four lanes where -O3 vectorises), the CPU's choosing when the program loads
// (target_clones: an ifunc). The same operations in the same order, so the same bits: the avx2
// target does not include FMA, and the files that use it compile without contraction. GCC
// only: Clang 14 names the clones' dispatcher apart from the function, so that a caller in
// another file that does not see the attribute finds no definition.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__has_attribute)
#if __has_attribute(target_clones)
#define MOMENTUM_WITH_AVX2_CLONE __attribute__((target_clones("avx2", "default")))
#endif
#endif
#ifndef MOMENTUM_WITH_AVX2_CLONE
#define MOMENTUM_WITH_AVX2_CLONE
#endif

namespace momentum::core::lanes {

typedef double Pair __attribute__((vector_size(16)));
typedef std::int64_t PairMask __attribute__((vector_size(16)));

// The lane type's mask type: bool for double, PairMask for Pair.
template <class V>
using Mask = decltype(V{} < V{});

template <class V>
inline V load(const double* at) {
  V v;
  std::memcpy(&v, at, sizeof v);
  return v;
}

template <class V>
inline void store(double* at, V v) {
  std::memcpy(at, &v, sizeof v);
}

// |x|: the sign bit cleared, as std::fabs.
inline double abs(double x) { return __builtin_fabs(x); }
inline Pair abs(Pair x) {
  return reinterpret_cast<Pair>(reinterpret_cast<PairMask>(x) & (PairMask{} + INT64_MAX));
}

// `when ? a : b`, lane by lane.
inline double select(bool when, double a, double b) { return when ? a : b; }
inline Pair select(PairMask when, Pair a, Pair b) {
  return reinterpret_cast<Pair>((reinterpret_cast<PairMask>(a) & when) | (reinterpret_cast<PairMask>(b) & ~when));
}

// std::max(a, b): b where a < b, else a (a NaN a stays, a NaN b is not taken). One maxpd.
inline double max(double a, double b) { return a < b ? b : a; }
inline Pair max(Pair a, Pair b) { return a < b ? b : a; }

// Whether the mask holds in every lane, in some lane.
inline bool all(bool m) { return m; }
inline bool all(PairMask m) { return (m[0] & m[1]) != 0; }
inline bool any(bool m) { return m; }
inline bool any(PairMask m) { return (m[0] | m[1]) != 0; }

// The per-joint loop of the hot path: body.template operator()<V>(j) for joints 0 .. n-1, two at
// a time (V = Pair, joints j and j + 1) and an odd last one alone (V = double). `body` is a
// lambda templated on the lane type: [&]<class V>(std::size_t j) { ... }. Always inlined: called
// from an AVX2 clone (MOMENTUM_WITH_AVX2_CLONE), a helper GCC left out of line ran the body at
// the baseline target, behind a call (4,200 against 3,720 instructions a row of mo-observe).
template <class Body>
[[gnu::always_inline]] inline void for_joints(std::size_t n, Body&& body) {
  std::size_t j = 0;
  for (; j + 2 <= n; j += 2) body.template operator()<Pair>(j);
  if (j < n) body.template operator()<double>(j);
}

// As for_joints() for a body that returns whether its joints pass, stopping at the first that
// does not: whether every joint passed.
template <class Body>
[[gnu::always_inline]] inline bool all_joints(std::size_t n, Body&& body) {
  std::size_t j = 0;
  for (; j + 2 <= n; j += 2)
    if (!body.template operator()<Pair>(j)) return false;
  return j == n || body.template operator()<double>(j);
}

}  // namespace momentum::core::lanes
