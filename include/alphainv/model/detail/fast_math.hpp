#pragma once
/// \file model/detail/fast_math.hpp
/// sin, cos and tanh for the 1 kHz tick (and the torque effects it evaluates): inline, with no
/// library call on the common path, and equal to the C library's to a few ulp (not bit for bit):
///
/// - fast_sin_cos(x): x reduced by π/2 in three parts (Cody–Waite: x − n·P1 − n·P2 − n·P3 with P1, P2
///   of 33 bits, so n·P1 and n·P2 are exact for |n| < 2^20), then fdlibm's kernels on
///   |r| ≤ π/4 (__kernel_sin, __kernel_cos: < 1 ulp). For |x| > kFastTrigMax (and NaN, ±∞)
///   std::sin/std::cos. Error against std:: over |x| ≤ kFastTrigMax: test
///   FastMath.SinCosEqualTheLibrarysToAFewUlp: within 2 ulp of max(|sin x|, 2^-30) (so at most
///   4.5e-16 absolute; 1.04 ulp measured on 200 000 arguments), sin x = x for |x| < 2^-27.
/// - fast_tanh(x) = sign(x)·(1 − t)/(1 + t), t = e^(−2|x|), for 0.5 < |x| < 22 (no cancellation: 1 − t ≥
///   0.63), −u/(2 + u), u = expm1(−2|x|), below (relative accuracy near 0), ±1 from 22 on (as
///   glibc, where tanh(x) rounds to ±1). One exp instead of glibc's expm1 and division. Test
///   FastMath.TanhEqualsTheLibrarysToAFewUlp: within 3 ulp (1.99 measured).
///
/// Plain double arithmetic (SSE2, no FMA needed; with FMA contraction the reduction is only more
/// exact). Real-time safe: no allocation, no locks, no I/O, no errno on the fast paths.

#include <cmath>
#include <cstdint>
#include <cstring>

/// Inlined where called: GCC kept fast_sin_cos() out of line in effect_torque_terms(), whose sum
/// then waited on the call and its spills (perf).
#if defined(__GNUC__)
#define ALPHAINV_FAST_MATH_INLINE inline __attribute__((always_inline))
#else
#define ALPHAINV_FAST_MATH_INLINE inline
#endif

namespace alphainv::detail {

/// Largest |x| [rad] fast_sin_cos() reduces itself (2^19·π/2); beyond it, std::sin and std::cos.
inline constexpr double kFastTrigMax = 823549.6654455938;

/// sin r and cos r for |r| ≤ π/4 (fdlibm's __kernel_sin and __kernel_cos with no tail).
ALPHAINV_FAST_MATH_INLINE void sin_cos_kernel(double r, double& s, double& c) noexcept {
  constexpr double S1 = -1.66666666666666324348e-01, S2 = 8.33333333332248946124e-03,
                   S3 = -1.98412698298579493134e-04, S4 = 2.75573137070700676789e-06,
                   S5 = -2.50507602534068634195e-08, S6 = 1.58969099521155010221e-10;
  constexpr double C1 = 4.16666666666666019037e-02, C2 = -1.38888888888741095749e-03,
                   C3 = 2.48015872894767294178e-05, C4 = -2.75573143513906633035e-07,
                   C5 = 2.08757232129817482790e-09, C6 = -1.13596475577881948265e-11;
  const double z = r * r;
  const double z2 = z * z, z4 = z2 * z2;
  s = r + r * z * ((S1 + z * S2) + z2 * (S3 + z * S4) + z4 * (S5 + z * S6));
  const double pc = z2 * ((C1 + z * C2) + z2 * (C3 + z * C4) + z4 * (C5 + z * C6));
  const double hz = 0.5 * z;
  const double w = 1.0 - hz;
  c = w + (((1.0 - w) - hz) + pc);
}

/// x reduced to r ∈ [−π/4, π/4] (about) and the quadrant n mod 4, for |x| ≤ kFastTrigMax.
ALPHAINV_FAST_MATH_INLINE double reduce_half_pi(double x, unsigned& quadrant) noexcept {
  constexpr double kInvHalfPi = 6.36619772367581382433e-01;
  constexpr double kP1 = 1.57079632673412561417e+00;  // first 33 bits of π/2
  constexpr double kP2 = 6.07710050630396597660e-11;  // next 33 bits
  constexpr double kP3 = 2.02226624871116645580e-21;  // the rest, to 53 bits
  constexpr double kRound = 6755399441055744.0;       // 1.5·2^52: adding it rounds to an integer
  const double shifted = x * kInvHalfPi + kRound;
  std::uint64_t bits = 0;
  std::memcpy(&bits, &shifted, sizeof bits);
  quadrant = static_cast<unsigned>(bits & 3u);  // n mod 4 (two's complement for n < 0)
  const double n = shifted - kRound;
  return ((x - n * kP1) - n * kP2) - n * kP3;
}

/// sin x and cos x (file comment). Real-time safe.
ALPHAINV_FAST_MATH_INLINE void fast_sin_cos(double x, double& s, double& c) noexcept {
  if (!(std::abs(x) <= kFastTrigMax)) {
    s = std::sin(x);
    c = std::cos(x);
    return;
  }
  if (std::abs(x) < 0x1p-27) {  // as fdlibm: sin x = x (±0 kept), cos x = 1 to rounding
    s = x;
    c = 1.0;
    return;
  }
  unsigned q = 0;
  double ks = 0.0, kc = 1.0;
  sin_cos_kernel(reduce_half_pi(x, q), ks, kc);
  // The quadrant's swap and signs by bit operations, not branches (the cogging term's quadrant
  // follows θ, and a branch on it mispredicted on a quarter of the ticks: callgrind --branch-sim).
  std::uint64_t ks_bits = 0, kc_bits = 0;
  std::memcpy(&ks_bits, &ks, sizeof ks_bits);
  std::memcpy(&kc_bits, &kc, sizeof kc_bits);
  const std::uint64_t swap = 0 - static_cast<std::uint64_t>(q & 1u);  // all ones when q is odd
  const std::uint64_t sin_bits = ((kc_bits & swap) | (ks_bits & ~swap)) ^
                                 (static_cast<std::uint64_t>((q >> 1) & 1u) << 63);
  const std::uint64_t cos_bits = ((ks_bits & swap) | (kc_bits & ~swap)) ^
                                 (static_cast<std::uint64_t>(((q + 1u) >> 1) & 1u) << 63);
  std::memcpy(&s, &sin_bits, sizeof s);
  std::memcpy(&c, &cos_bits, sizeof c);
}

/// sin x (file comment; fast_sin_cos() without the cosine's sign). Real-time safe.
ALPHAINV_FAST_MATH_INLINE double fast_sin(double x) noexcept {
  double s = 0.0, c = 1.0;
  fast_sin_cos(x, s, c);
  return s;
}

/// tanh x (file comment). Real-time safe.
ALPHAINV_FAST_MATH_INLINE double fast_tanh(double x) noexcept {
  const double ax = std::abs(x);
  double t_abs;
  if (ax >= 22.0) {
    t_abs = 1.0;
  } else if (ax > 0.5) {
    const double t = std::exp(-2.0 * ax);
    t_abs = (1.0 - t) / (1.0 + t);
  } else {
    const double u = std::expm1(-2.0 * ax);  // NaN stays NaN
    t_abs = -u / (2.0 + u);
  }
  return std::copysign(t_abs, x);
}

}  // namespace alphainv::detail
