#include "momentum/observer/filter.hpp"

#include <algorithm>
#include <cmath>

#include "momentum/core/number.hpp"

namespace momentum::observer {
namespace {

// phi_0..phi_3 of z = -kappa (kappa >= 0): phi_0 = e^z, phi_k+1 = (phi_k - 1/k!) / z, i.e.
// phi_k(z) = sum_j z^j / (j+k)!. The exact first-order-hold coefficients are combinations of
// them; the series keeps them accurate for small kappa, where the recurrence cancels.
struct Phi {
  double a, p1, p2, p3;
};

Phi phi(double kappa) {
  Phi f{};
  if (kappa == 0.0) return {1.0, 1.0, 0.5, 1.0 / 6};
  if (kappa < 0.5) {
    static constexpr double inv_factorial[] = {
        1.0, 1.0, 1.0 / 2, 1.0 / 6, 1.0 / 24, 1.0 / 120, 1.0 / 720, 1.0 / 5040, 1.0 / 40320,
        1.0 / 362880, 1.0 / 3628800, 1.0 / 39916800, 1.0 / 479001600, 1.0 / 6227020800.0,
        1.0 / 87178291200.0, 1.0 / 1307674368000.0, 1.0 / 20922789888000.0,
        1.0 / 355687428096000.0, 1.0 / 6402373705728000.0, 1.0 / 121645100408832000.0,
        1.0 / 2432902008176640000.0, 1.0 / 51090942171709440000.0};
    // The first omitted term, kappa^(n+1) / (n+1)!, is below 3e-19 of the sum (>= 1/6).
    const int n = kappa < 0.1 ? 10 : 18;
    const double z = -kappa;
    double f0 = 0, f1 = 0, f2 = 0, f3 = 0;
    for (int j = n; j >= 0; --j) {
      f0 = f0 * z + inv_factorial[j];
      f1 = f1 * z + inv_factorial[j + 1];
      f2 = f2 * z + inv_factorial[j + 2];
      f3 = f3 * z + inv_factorial[j + 3];
    }
    f = {f0, f1, f2, f3};
  } else {
    f.a = std::exp(-kappa);
    f.p1 = (1.0 - f.a) / kappa;
    f.p2 = (1.0 - f.p1) / kappa;
    f.p3 = (0.5 - f.p2) / kappa;
  }
  return f;
}

// Unit-gain low-pass K/(s+K), input linear over the interval: y' = a y + b0 x0 + b1 x1.
struct LowPass {
  double a, b0, b1;
};

LowPass low_pass(const Phi& f, double kappa) {
  if (kappa < 1.0) return {f.a, kappa * (f.p1 - f.p2), kappa * f.p2};
  return {f.a, f.p1 - f.a, 1.0 - f.p1};
}

bool fail(std::string* why, const char* name, double value, const char* condition) {
  if (why) *why = std::string(name) + " = " + core::significant(value, 17) + " is not " + condition;
  return false;
}

}  // namespace

bool Gains::IsValid(std::string* why) const {
  if (!std::isfinite(k1) || !(k1 > 0)) return fail(why, "k1", k1, "a finite value > 0");
  if (!std::isfinite(k2) || k2 < 0) return fail(why, "k2", k2, "a finite value >= 0");
  if (!std::isfinite(k3) || k3 < 0) return fail(why, "k3", k3, "a finite value >= 0");
  return true;
}

FilterCoefficients discretize(const Gains& gains, double dt) {
  FilterCoefficients c;
  const double k1 = gains.k1, k2 = gains.k2;
  if (std::abs(k1 - k2) <= 1e-6 * std::max(k1, k2)) {
    // Repeated pole K: s1 = LP x, s2 = LP^2 x. With kappa = K dt, a = e^-kappa, the second
    // state's response over one interval is a s2 + kappa a s1 + c0 x_start + c1 x_end with
    // c0 + c1 = 1 - a (1 + kappa) (step) and c1 = 1 - 2 (1 - a)/kappa + a (unit ramp).
    const double k = 0.5 * (k1 + k2);
    const double kappa = k * dt;
    const Phi f = phi(kappa);
    const LowPass lp = low_pass(f, kappa);
    c.a1 = lp.a;
    c.b10 = lp.b0;
    c.b11 = lp.b1;
    c.a2 = f.a;
    c.c21 = kappa * f.a;
    if (kappa < 1.0) {
      c.b21 = kappa * kappa * (f.p2 - 2 * f.p3);
      c.b20 = kappa * kappa * (f.p1 - 2 * f.p2 + 2 * f.p3);
    } else {
      c.b21 = 1.0 - 2.0 * f.p1 + f.a;
      c.b20 = (1.0 - f.a - kappa * f.a) - c.b21;
    }
    c.gain = (k1 + gains.k3) / k;
    return c;
  }
  const double kappa1 = k1 * dt, kappa2 = k2 * dt;
  const LowPass lp1 = low_pass(phi(kappa1), kappa1);
  const LowPass lp2 = k2 == 0 ? LowPass{1.0, 0.0, 0.0} : low_pass(phi(kappa2), kappa2);
  c.a1 = lp1.a;
  c.b10 = lp1.b0;
  c.b11 = lp1.b1;
  c.a2 = lp2.a;
  c.c21 = 0;
  c.b20 = lp2.b0;
  c.b21 = lp2.b1;
  c.gain = (k1 + gains.k3) / (k1 - k2);
  return c;
}

}  // namespace momentum::observer
