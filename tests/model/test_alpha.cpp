#include "alphainv/model/alpha.hpp"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

namespace alphainv {
namespace {

TEST(Alpha, InstantaneousOfSineIsAmplitudeSquaredOmegaSquared) {
  for (double amp : {0.01, 0.3, 2.0}) {
    for (double f : {1.0, 3.0, 7.5}) {
      const double w = 2 * M_PI * f;
      for (double t : {0.0, 0.013, 0.21, 1.7}) {
        const double phase = 0.4;
        const double v = amp * std::sin(w * t + phase);
        const double vd = amp * w * std::cos(w * t + phase);
        const double vdd = -amp * w * w * std::sin(w * t + phase);
        EXPECT_NEAR(alpha_instantaneous(v, vd, vdd), amp * amp * w * w, 1e-9 * amp * amp * w * w);
      }
    }
  }
}

TEST(Alpha, ZeroForConstantAndRampGivesSlopeSquared) {
  EXPECT_DOUBLE_EQ(alpha_instantaneous(3.0, 0.0, 0.0), 0.0);
  EXPECT_DOUBLE_EQ(alpha_instantaneous(3.0, 2.0, 0.0), 4.0);
}

TEST(Alpha, CycleAverageOfSineEqualsInstantaneousAndOfTwoToneIsSumOfTones) {
  const double dt = 1e-4, f = 2.0, w = 2 * M_PI * f;
  const std::size_t n = static_cast<std::size_t>(1.0 / f / dt) + 1;
  std::vector<double> v(n), vd(n), vdd(n);
  // v = a sin wt + b sin 3wt: average of v̇² − v v̈ over a period is a²w² + b²(3w)² (cross terms vanish).
  const double a = 0.5, b = 0.2;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * dt;
    v[k] = a * std::sin(w * t) + b * std::sin(3 * w * t);
    vd[k] = a * w * std::cos(w * t) + 3 * w * b * std::cos(3 * w * t);
    vdd[k] = -a * w * w * std::sin(w * t) - 9 * w * w * b * std::sin(3 * w * t);
  }
  const double expected = a * a * w * w + b * b * 9 * w * w;
  EXPECT_NEAR(alpha_cycle_average(v.data(), vd.data(), vdd.data(), n, dt), expected, 1e-6 * expected);
  EXPECT_EQ(alpha_cycle_average(v.data(), vd.data(), vdd.data(), 1, dt), 0.0);
}

TEST(Alpha, SineSteadyStateMatchesInstantaneousOfCommand) {
  // eq. (35)-(36): v = kp(−A1 cos ωt + (Ar − A2) sin ωt).
  const double kp = 2.0, w = 2 * M_PI * 3.0, a1 = -0.03, a2 = 0.05, ar = 0.07;
  const double t = 0.123;
  const double v = kp * (-a1 * std::cos(w * t) + (ar - a2) * std::sin(w * t));
  const double vd = kp * w * (a1 * std::sin(w * t) + (ar - a2) * std::cos(w * t));
  const double vdd = -w * w * v;
  EXPECT_NEAR(alpha_sine_steady_state(kp, w, a1, a2, ar), alpha_instantaneous(v, vd, vdd), 1e-9);
}

}  // namespace
}  // namespace alphainv
