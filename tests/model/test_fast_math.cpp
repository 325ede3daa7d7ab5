// Tests of include/alphainv/model/detail/fast_math.hpp: fast_sin_cos(), fast_sin() and fast_tanh()
// against std:: over wide ranges (a few ulp), their edge cases (quadrant boundaries, ±0, the
// library fallback beyond kFastTrigMax, NaN, ±∞).
#include "alphainv/model/detail/fast_math.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace alphainv::detail {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();  // 2^-52 = 2.2e-16

/// The arguments tried: uniform on [−b, b] for b from 1e-8 to kFastTrigMax, the multiples of π/4
/// (quadrant boundaries and the kernels' edge), and the tick's own (a cogging period of 0.016 rad
/// over ±1 rad, 2π·7 Hz over 1000 s).
std::vector<double> trig_arguments() {
  std::mt19937_64 rng(20261203);
  std::vector<double> x;
  for (double b : {1e-8, 1e-3, 0.7, 3.2, 10.0, 400.0, 2e4, 3e5, kFastTrigMax}) {
    std::uniform_real_distribution<double> u(-b, b);
    for (int k = 0; k < 20000; ++k) x.push_back(u(rng));
  }
  for (int k = -4000; k <= 4000; ++k) {
    const double m = k * 0.78539816339744830962;
    x.insert(x.end(), {m, std::nextafter(m, 1e9), std::nextafter(m, -1e9)});
  }
  x.push_back(kFastTrigMax);
  x.push_back(-kFastTrigMax);
  return x;
}

TEST(FastMath, SinCosEqualTheLibrarysToAFewUlp) {
  double worst_sin = 0.0, worst_cos = 0.0;  // in ulp of max(|value|, 2^-30)
  for (double x : trig_arguments()) {
    double s = 0.0, c = 0.0;
    fast_sin_cos(x, s, c);
    const double ulp_s = kEps * std::max(std::abs(std::sin(x)), 0x1p-30);
    const double ulp_c = kEps * std::max(std::abs(std::cos(x)), 0x1p-30);
    worst_sin = std::max(worst_sin, std::abs(s - std::sin(x)) / ulp_s);
    worst_cos = std::max(worst_cos, std::abs(c - std::cos(x)) / ulp_c);
    ASSERT_LE(std::abs(s - std::sin(x)), 2.0 * ulp_s) << "sin at x = " << x;
    ASSERT_LE(std::abs(c - std::cos(x)), 2.0 * ulp_c) << "cos at x = " << x;
    ASSERT_EQ(fast_sin(x), s) << x;
  }
  RecordProperty("worst_sin_ulp", std::to_string(worst_sin));
  RecordProperty("worst_cos_ulp", std::to_string(worst_cos));
  // Measured: 1.04 ulp for both (a reduction off by a quadrant would be off by ~1, 4.5e15 ulp).
  EXPECT_LT(worst_sin, 2.0);
  EXPECT_LT(worst_cos, 2.0);
}

TEST(FastMath, SinCosSmallArgumentsAndSignedZeroAreExact) {
  double s = 1.0, c = 0.0;
  fast_sin_cos(0.0, s, c);
  EXPECT_EQ(s, 0.0);
  EXPECT_EQ(c, 1.0);
  fast_sin_cos(-0.0, s, c);
  EXPECT_EQ(s, 0.0);
  EXPECT_TRUE(std::signbit(s));
  for (double x : {1e-300, -3e-20, 1e-9, -2.5e-9}) {
    fast_sin_cos(x, s, c);
    EXPECT_EQ(s, x);  // sin x = x to rounding for |x| ≤ 2.5e-9
    EXPECT_EQ(c, 1.0);
  }
}

TEST(FastMath, SinCosBeyondTheFastRangeAndNonFiniteAreTheLibrarys) {
  for (double x : {kFastTrigMax * 1.0000001, -1e7, 3.1e12, 1e300}) {
    double s = 0.0, c = 0.0;
    fast_sin_cos(x, s, c);
    EXPECT_EQ(s, std::sin(x)) << x;
    EXPECT_EQ(c, std::cos(x)) << x;
  }
  for (double x : {std::numeric_limits<double>::quiet_NaN(),
                   std::numeric_limits<double>::infinity(),
                   -std::numeric_limits<double>::infinity()}) {
    double s = 0.0, c = 0.0;
    fast_sin_cos(x, s, c);
    EXPECT_TRUE(std::isnan(s)) << x;
    EXPECT_TRUE(std::isnan(c)) << x;
  }
}

TEST(FastMath, TanhEqualsTheLibrarysToAFewUlp) {
  std::mt19937_64 rng(7);
  std::vector<double> x;
  for (double b : {1e-12, 1e-4, 0.3, 0.5, 0.51, 2.0, 8.0, 25.0, 1e3, 1e6}) {
    std::uniform_real_distribution<double> u(-b, b);
    for (int k = 0; k < 20000; ++k) x.push_back(u(rng));
  }
  for (double edge : {0.5, 22.0, 19.0, 1e-300}) {
    x.insert(x.end(), {edge, -edge, std::nextafter(edge, 0.0), std::nextafter(edge, 100.0)});
  }
  double worst = 0.0;
  for (double v : x) {
    const double ulp = kEps * std::abs(std::tanh(v));
    const double err = std::abs(fast_tanh(v) - std::tanh(v));
    ASSERT_LE(err, 3.0 * ulp) << "tanh at " << v << ": " << fast_tanh(v) << " vs " << std::tanh(v);
    if (ulp > 0.0) worst = std::max(worst, err / ulp);
  }
  RecordProperty("worst_tanh_ulp", std::to_string(worst));  // measured: 1.99 ulp
  EXPECT_EQ(fast_tanh(0.0), 0.0);
  EXPECT_TRUE(std::signbit(fast_tanh(-0.0)));
  EXPECT_EQ(fast_tanh(22.0), 1.0);
  EXPECT_EQ(fast_tanh(-std::numeric_limits<double>::infinity()), -1.0);
  EXPECT_TRUE(std::isnan(fast_tanh(std::numeric_limits<double>::quiet_NaN())));
}

}  // namespace
}  // namespace alphainv::detail
