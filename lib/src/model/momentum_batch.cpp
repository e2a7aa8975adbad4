// The helpers here and in sin_cos_kernel.hpp take and return 32-byte vectors; GCC warns that
// their calling convention differs with AVX. They are internal to this file and inlined: no
// call crosses a boundary.
#pragma GCC diagnostic ignored "-Wpsabi"

#include "momentum/model/momentum_batch.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include "sin_cos_kernel.hpp"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define MOMENTUM_LANES_AVX2 1
#else
#define MOMENTUM_LANES_AVX2 0
#endif

namespace momentum::model {

namespace {

constexpr int kLanes = MomentumBatch::kLanes;
// One value per sample. GCC's and Clang's vector extension: arithmetic on it is element-wise,
// so each lane rounds exactly as a scalar computation would.
typedef double Lanes __attribute__((vector_size(8 * kLanes)));

// Every helper is inlined into the pass it serves, so that it is compiled for that pass's
// instruction set (a call would pass the vectors through memory).
#define MOMENTUM_LANES_INLINE [[gnu::always_inline]] inline
#define MOMENTUM_LANES_LAMBDA __attribute__((always_inline))

// Written out element by element: `Lanes{} + x` costs an add, and GCC then spilled the pass's
// vectors (585 against 293 ns a row without AVX).
MOMENTUM_LANES_INLINE Lanes broadcast(double x) { return Lanes{x, x, x, x}; }
MOMENTUM_LANES_INLINE Lanes load(const double* x) {
  Lanes v;
  std::memcpy(&v, x, sizeof v);
  return v;
}
MOMENTUM_LANES_INLINE void store(double* x, Lanes v) { std::memcpy(x, &v, sizeof v); }
// Element i of each lane's array, built in registers: filled one element at a time through
// memory, a vector costs a failed store forwarding when it is read back whole.
static_assert(kLanes == 4, "broadcast and lane_values list the lanes");
MOMENTUM_LANES_INLINE Lanes lane_values(const double* const x[], int i) {
  return Lanes{x[0][i], x[1][i], x[2][i], x[3][i]};
}

typedef std::uint64_t LaneBits __attribute__((vector_size(8 * kLanes)));

// As detail::sin_cos, lane by lane: the same kernel, and libm beyond its range.
MOMENTUM_LANES_INLINE void sin_cos(Lanes x, Lanes* sin_x, Lanes* cos_x) {
  detail::sin_cos_reduced<Lanes, LaneBits>(
      x, sin_x, cos_x, [](Lanes v) MOMENTUM_LANES_LAMBDA { return reinterpret_cast<LaneBits>(v); },
      [](LaneBits mask, Lanes a, Lanes b) MOMENTUM_LANES_LAMBDA { return mask != 0 ? a : b; });
  for (int k = 0; k < kLanes; ++k) {
    if (std::fabs(x[k]) < detail::kSinCosRange) continue;
    double s, c;  // (a vector's element has no address in Clang)
    detail::sin_cos(x[k], &s, &c);
    (*sin_x)[k] = s;
    (*cos_x)[k] = c;
  }
}

struct Vector3 {
  Lanes x, y, z;
};
MOMENTUM_LANES_INLINE Vector3 broadcast3(const double* a) {
  return {broadcast(a[0]), broadcast(a[1]), broadcast(a[2])};
}
MOMENTUM_LANES_INLINE Vector3 load3(const double* a) { return {load(a), load(a + kLanes), load(a + 2 * kLanes)}; }
MOMENTUM_LANES_INLINE void store3(double* a, const Vector3& v) {
  store(a, v.x);
  store(a + kLanes, v.y);
  store(a + 2 * kLanes, v.z);
}
MOMENTUM_LANES_INLINE Vector3 operator+(const Vector3& a, const Vector3& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
MOMENTUM_LANES_INLINE Vector3 operator*(Lanes s, const Vector3& a) { return {s * a.x, s * a.y, s * a.z}; }
// As dynamics_impl.hpp's rotate, rotate_back and cross, term for term. `m` holds a 3x3 matrix
// row major, one Lanes per entry.
MOMENTUM_LANES_INLINE Vector3 rotate(const Lanes* m, const Vector3& a) {
  return {m[0] * a.x + m[1] * a.y + m[2] * a.z, m[3] * a.x + m[4] * a.y + m[5] * a.z,
          m[6] * a.x + m[7] * a.y + m[8] * a.z};
}
MOMENTUM_LANES_INLINE Vector3 rotate_back(const Lanes* m, const Vector3& a) {
  return {m[0] * a.x + m[3] * a.y + m[6] * a.z, m[1] * a.x + m[4] * a.y + m[7] * a.z,
          m[2] * a.x + m[5] * a.y + m[8] * a.z};
}
MOMENTUM_LANES_INLINE Vector3 cross(const Vector3& a, const Vector3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

}  // namespace

MomentumBatch::MomentumBatch(const Model& model, const Data& data, bool use_cpu_extensions) : n_(model.nq) {
  if (data.aligned_joint_rotation.size() != static_cast<std::size_t>(n_))
    throw std::invalid_argument("MomentumBatch: data was made for another model");
  for (int i = 0; i < n_; ++i) {
    for (int row = 0; row < 3; ++row) {
      for (int col = 0; col < 3; ++col) {
        joint_rotation_.push_back(data.aligned_joint_rotation[i](row, col));
        inertia_.push_back(data.aligned_inertia[i](row, col));
      }
    }
    for (int a = 0; a < 3; ++a) {
      translation_.push_back(data.aligned_translation[i][a]);
      slide_.push_back(data.aligned_slide[i][a]);
      com_.push_back(data.aligned_com[i][a]);
    }
    mass_.push_back(data.mass[i]);
    rotor_.push_back(data.rotor_inertia[i]);
    revolute_.push_back(data.revolute[i]);
  }
  for (int a = 0; a < 3; ++a) gravity_[a] = data.gravity[a];
  const auto values = static_cast<std::size_t>(n_) * kLanes;
  rotation_.assign(9 * values, 0.0);
  for (auto* v : {&omega_, &velocity_, &gravity_frame_, &linear_, &angular_}) v->assign(3 * values, 0.0);
  dq_.assign(values, 0.0);
#if MOMENTUM_LANES_AVX2
  accelerated_ = use_cpu_extensions && __builtin_cpu_supports("avx2");
#else
  (void)use_cpu_extensions;
#endif
}

// The pass, written once and compiled twice: for x86-64's baseline and for AVX2, chosen at
// construction by what the CPU has (MomentumBatch::accelerated()).
struct MomentumBatchPass {
  MOMENTUM_LANES_INLINE static void pass(MomentumBatch& b, const double* const lane_q[], const double* const lane_dq[],
                                         int count, double* const p[], double* const beta[]) {
    const int n = b.n_;
    // Forward, as momentum_pass: joint rotation, angular velocity, origin velocity, gravity and
    // the body's momentum in its aligned frame.
    Vector3 omega_parent{}, velocity_parent{};
    Vector3 gravity_parent = broadcast3(b.gravity_);
    for (int i = 0; i < n; ++i) {
      const double* e0 = &b.joint_rotation_[9 * i];
      Lanes e[9];
      Vector3 r = broadcast3(&b.translation_[3 * i]);
      const Lanes qi = lane_values(lane_q, i);
      const Lanes dqi = lane_values(lane_dq, i);
      if (b.revolute_[i]) {
        Lanes s, c;
        sin_cos(qi, &s, &c);
        for (int row = 0; row < 3; ++row) {
          e[3 * row] = c * e0[3 * row] + s * e0[3 * row + 1];
          e[3 * row + 1] = c * e0[3 * row + 1] - s * e0[3 * row];
          e[3 * row + 2] = broadcast(e0[3 * row + 2]);
        }
      } else {
        for (int k = 0; k < 9; ++k) e[k] = broadcast(e0[k]);
        r = r + qi * broadcast3(&b.slide_[3 * i]);
      }
      Vector3 omega = rotate_back(e, omega_parent);
      Vector3 velocity = rotate_back(e, velocity_parent + cross(omega_parent, r));
      if (b.revolute_[i]) {
        omega.z += dqi;
      } else {
        velocity.z += dqi;
      }
      const Vector3 gravity = rotate_back(e, gravity_parent);
      const Vector3 com = broadcast3(&b.com_[3 * i]);
      const Vector3 l = broadcast(b.mass_[i]) * (velocity + cross(omega, com));
      Lanes inertia[9];
      for (int k = 0; k < 9; ++k) inertia[k] = broadcast(b.inertia_[9 * i + k]);
      const auto at = static_cast<std::size_t>(i) * kLanes;
      for (int k = 0; k < 9; ++k) store(&b.rotation_[9 * at + k * kLanes], e[k]);
      store3(&b.omega_[3 * at], omega);
      store3(&b.velocity_[3 * at], velocity);
      store3(&b.gravity_frame_[3 * at], gravity);
      store3(&b.linear_[3 * at], l);
      store3(&b.angular_[3 * at], rotate(inertia, omega) + cross(com, l));
      store(&b.dq_[at], dqi);
      omega_parent = omega;
      velocity_parent = velocity;
      gravity_parent = gravity;
    }
    // Backward: the subtree's mass, first moment and momentum carried into frame i, projected on
    // its axis.
    Lanes m = broadcast(0.0);
    Vector3 first_moment{}, linear{}, angular{};
    for (int i = n - 1; i >= 0; --i) {
      if (i + 1 < n) {
        const auto next = static_cast<std::size_t>(i + 1) * kLanes;
        Lanes e[9];
        for (int k = 0; k < 9; ++k) e[k] = load(&b.rotation_[9 * next + k * kLanes]);
        Vector3 r = broadcast3(&b.translation_[3 * (i + 1)]);
        if (!b.revolute_[i + 1]) r = r + lane_values(lane_q, i + 1) * broadcast3(&b.slide_[3 * (i + 1)]);
        linear = rotate(e, linear);
        angular = rotate(e, angular) + cross(r, linear);
        first_moment = rotate(e, first_moment) + m * r;
      }
      m += b.mass_[i];
      first_moment = first_moment + broadcast(b.mass_[i]) * broadcast3(&b.com_[3 * i]);
      const auto at = static_cast<std::size_t>(i) * kLanes;
      linear = linear + load3(&b.linear_[3 * at]);
      angular = angular + load3(&b.angular_[3 * at]);
      const Vector3 w = load3(&b.omega_[3 * at]);
      const Vector3 g = load3(&b.gravity_frame_[3 * at]);
      Lanes pi, cti, gi;
      if (b.revolute_[i]) {
        const Vector3 v = load3(&b.velocity_[3 * at]);
        pi = angular.z;
        cti = angular.x * w.y - angular.y * w.x + linear.x * v.y - linear.y * v.x;
        gi = g.x * first_moment.y - g.y * first_moment.x;
      } else {
        pi = linear.z;
        cti = linear.x * w.y - linear.y * w.x;
        gi = -m * g.z;
      }
      const Lanes momentum = pi + b.rotor_[i] * load(&b.dq_[at]);
      const Lanes beta_lanes = gi - cti;
      for (int k = 0; k < count; ++k) {
        p[k][i] = momentum[k];
        beta[k][i] = beta_lanes[k];
      }
    }
  }
  static void baseline(MomentumBatch& b, const double* const lane_q[], const double* const lane_dq[], int count,
                       double* const p[], double* const beta[]) {
    pass(b, lane_q, lane_dq, count, p, beta);
  }
#if MOMENTUM_LANES_AVX2
  // Without FMA: a fused multiply-add rounds once where the one-sample pass rounds twice.
  __attribute__((target("avx2"))) static void avx2(MomentumBatch& b, const double* const lane_q[],
                                                   const double* const lane_dq[], int count, double* const p[],
                                                   double* const beta[]) {
    pass(b, lane_q, lane_dq, count, p, beta);
  }
#endif
};

void MomentumBatch::run(int count, const double* const q[], const double* const dq[], double* const p[],
                        double* const beta[]) {
  if (count < 1 || count > kLanes)
    throw std::invalid_argument("MomentumBatch::run: " + std::to_string(count) + " samples, not 1.." +
                                std::to_string(kLanes));
  const double* lane_q[kLanes];
  const double* lane_dq[kLanes];
  for (int k = 0; k < kLanes; ++k) {
    lane_q[k] = q[k < count ? k : 0];
    lane_dq[k] = dq[k < count ? k : 0];
  }
#if MOMENTUM_LANES_AVX2
  if (accelerated_) {
    MomentumBatchPass::avx2(*this, lane_q, lane_dq, count, p, beta);
    return;
  }
#endif
  MomentumBatchPass::baseline(*this, lane_q, lane_dq, count, p, beta);
}

}  // namespace momentum::model
