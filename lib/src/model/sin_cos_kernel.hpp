// sin and cos of one angle together, written once for a double and for a vector of doubles
// (GCC's vector extension), so that the momentum pass gives the same bits one sample at a time
// (detail::sin_cos, sin_cos.cpp) and four at once (MomentumBatch). libm's sincos cannot be
// called on a vector, and calling it lane by lane cost as much as the rest of the batched pass.
//
// The method is fdlibm's (Sun Microsystems, 1993, as musl carries it): x reduced by pi/2 in
// three Cody-Waite steps to y0 + y1 with |y0| <= pi/4 and a quadrant n, then the minimax
// kernels __kernel_sin and __kernel_cos on (y0, y1). Within 1 ulp of libm's correctly rounded
// values for |x| < kSinCosRange (dynamics_impl.hpp; tests/model/sin_cos_test.cpp measures it);
// beyond that, and for inf and NaN, the caller uses libm.
//
// Private to lib/src/model: both users must be compiled without floating-point contraction.
#pragma once

#include <bit>
#include <cstdint>

#include "momentum/model/dynamics.hpp"

namespace momentum::model::detail {

// sin and cos of x (|x| < kSinCosRange, finite). T is double or a vector of doubles, U the
// matching unsigned 64-bit integer type; bits(v) reinterprets v as U, select(mask, a, b) picks
// a where mask (0 or 1) is 1.
template <class T, class U, class Bits, class Select>
[[gnu::always_inline]] inline void sin_cos_reduced(T x, T* sin_x, T* cos_x, Bits bits, Select select) {
  constexpr double kToInt = 6755399441055744.0;  // 1.5 * 2^52: adding it rounds to an integer
  constexpr double kInvPio2 = 6.36619772367581382433e-01;
  constexpr double kPio2_1 = 1.57079632673412561417e+00;   // first 33 bits of pi/2
  constexpr double kPio2_2 = 6.07710050630396597660e-11;   // second 33 bits
  constexpr double kPio2_2t = 2.02226624879595063154e-21;  // pi/2 - (kPio2_1 + kPio2_2)
  constexpr double kPio2_3 = 2.02226624871116645580e-21;   // third 33 bits
  constexpr double kPio2_3t = 8.47842766036889956997e-32;  // pi/2 - (kPio2_1 + kPio2_2 + kPio2_3)
  const T shifted = x * kInvPio2 + kToInt;
  const T fn = shifted - kToInt;
  const U quadrant = bits(shifted);  // the integer's low bits: n mod 4 in bits 0 and 1
  // Reduction: x - fn pi/2 = y0 + y1 (fdlibm's __rem_pio2, its second and third rounds always).
  T r = x - fn * kPio2_1;  // exact: fn * kPio2_1 is, and lies within a factor 2 of x
  T t = r;
  T w = fn * kPio2_2;
  r = t - w;
  w = fn * kPio2_2t - ((t - r) - w);
  t = r;
  w = fn * kPio2_3;
  r = t - w;
  w = fn * kPio2_3t - ((t - r) - w);
  const T y0 = r - w;
  const T y1 = (r - y0) - w;
  // fdlibm's __kernel_sin(y0, y1, 1) and __kernel_cos(y0, y1).
  constexpr double kS1 = -1.66666666666666324348e-01, kS2 = 8.33333333332248946124e-03,
                   kS3 = -1.98412698298579493134e-04, kS4 = 2.75573137070700676789e-06,
                   kS5 = -2.50507602534068634195e-08, kS6 = 1.58969099521155010221e-10;
  constexpr double kC1 = 4.16666666666666019037e-02, kC2 = -1.38888888888741095749e-03,
                   kC3 = 2.48015872894767294178e-05, kC4 = -2.75573143513906633035e-07,
                   kC5 = 2.08757232129817482790e-09, kC6 = -1.13596475577881948265e-11;
  const T z = y0 * y0;
  const T z2 = z * z;
  const T sr = kS2 + z * (kS3 + z * kS4) + z * z2 * (kS5 + z * kS6);
  const T v = z * y0;
  const T s = y0 - ((z * (0.5 * y1 - v * sr) - y1) - v * kS1);
  const T cr = z * (kC1 + z * (kC2 + z * kC3)) + z2 * z2 * (kC4 + z * (kC5 + z * kC6));
  const T hz = 0.5 * z;
  const T one_minus_hz = 1.0 - hz;
  const T c = one_minus_hz + (((1.0 - one_minus_hz) - hz) + (z * cr - y0 * y1));
  // Quadrant n: (sin, cos) = (s, c), (c, -s), (-s, -c), (-c, s).
  const U odd = quadrant & 1u;
  const U negative_sin = (quadrant >> 1) & 1u;
  const U negative_cos = ((quadrant + 1u) >> 1) & 1u;
  const T sin_magnitude = select(odd, c, s);
  const T cos_magnitude = select(odd, s, c);
  *sin_x = select(negative_sin, -sin_magnitude, sin_magnitude);
  *cos_x = select(negative_cos, -cos_magnitude, cos_magnitude);
}

}  // namespace momentum::model::detail
