#include "alphainv/identify.hpp"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace alphainv {
namespace {

/// Steady state of θ̈ + Cθ̇ + βθ = βr for r = Ar sin ωt: θ = A1 cos ωt + A2 sin ωt.
void linear_response(double c, double beta, double ar, double w, double& a1, double& a2) {
  const double den = (beta - w * w) * (beta - w * w) + c * c * w * w;
  a2 = beta * ar * (beta - w * w) / den;
  a1 = -beta * ar * c * w / den;
}

TEST(Identify, SineFitRecoversCoefficientsAndOffset) {
  std::vector<double> t, y;
  const double w = 2 * M_PI * 2.5;
  for (int k = 0; k < 2000; ++k) {
    t.push_back(k * 1e-3);
    y.push_back(0.03 * std::cos(w * t.back()) - 0.05 * std::sin(w * t.back()) + 0.002);
  }
  const SineFit fit = fit_sine(t, y, w);
  ASSERT_TRUE(fit.valid);
  EXPECT_NEAR(fit.a1, 0.03, 1e-12);
  EXPECT_NEAR(fit.a2, -0.05, 1e-12);
  EXPECT_NEAR(fit.offset, 0.002, 1e-12);
  EXPECT_NEAR(fit.amplitude(), std::hypot(0.03, 0.05), 1e-12);
  EXPECT_NEAR(fit.rms_residual, 0.0, 1e-12);
  const SineFit no_offset = fit_sine(t, y, w, false);
  EXPECT_GT(no_offset.rms_residual, 1e-3);
  EXPECT_FALSE(fit_sine(t.data(), y.data(), 3, w).valid);
}

TEST(Identify, Eq19And20RecoverLinearPlantAtEveryFrequency) {
  // paper-notes: exact for C = 6.242, β = 458.
  const double c = 6.242, beta = 458.0, ar = 0.07, kp = 2.0;
  for (double f : {1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0}) {
    double a1, a2;
    linear_response(c, beta, ar, 2 * M_PI * f, a1, a2);
    const LocalLinearPoint p = local_linear_point(f, a1, a2, ar, kp);
    EXPECT_TRUE(p.physical);
    EXPECT_NEAR(p.c_data, c, 1e-10 * c) << f;
    EXPECT_NEAR(p.beta_data, beta, 1e-10 * beta) << f;
    const double w = 2 * M_PI * f;
    EXPECT_NEAR(p.alpha_data, kp * kp * w * w * (a1 * a1 + (ar - a2) * (ar - a2)), 1e-12);
  }
}

TEST(Identify, NonPhysicalPointsAreFlagged) {
  // "Excessive" phase lag at small amplitude: A_r A2 > A1² + A2² gives negative C and β.
  const LocalLinearPoint p = local_linear_point(1.5, -0.002, 0.02, 0.07, 2.0);
  EXPECT_FALSE(p.physical);
  EXPECT_LT(p.beta_data, 0.0);
}

TEST(Identify, GlobalRegressionEq22RecoversLinearPlant) {
  const double c = 6.242, beta = 458.0, ar = 0.07, kp = 2.0;
  std::vector<LocalLinearPoint> pts;
  for (double f : {1.5, 2.0, 3.0, 4.0, 5.0, 7.0}) {
    double a1, a2;
    linear_response(c, beta, ar, 2 * M_PI * f, a1, a2);
    pts.push_back(local_linear_point(f, a1, a2, ar, kp));
  }
  const GlobalLinearFit g = global_linear_fit(pts, kp);
  ASSERT_TRUE(g.valid) << g.message;
  EXPECT_NEAR(g.c_linear, c, 1e-9);
  EXPECT_NEAR(g.beta_linear, beta, 1e-7);
  EXPECT_NEAR(g.beta_tilde_linear, beta / kp, 1e-7);
  EXPECT_LT(g.rms_residual, 1e-9);
  EXPECT_FALSE(global_linear_fit({}, kp).valid);
}

TEST(Identify, GlobalRegressionWithNoiseIsUnbiasedWithinTolerance) {
  const double c = 5.0, beta = 400.0, ar = 0.07, kp = 2.0;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 2e-5);
  std::vector<LocalLinearPoint> pts;
  for (double f : {1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0}) {
    double a1, a2;
    linear_response(c, beta, ar, 2 * M_PI * f, a1, a2);
    pts.push_back(local_linear_point(f, a1 + noise(rng), a2 + noise(rng), ar, kp));
  }
  const GlobalLinearFit g = global_linear_fit(pts, kp);
  EXPECT_NEAR(g.c_linear, c, 0.02 * c);
  EXPECT_NEAR(g.beta_linear, beta, 0.01 * beta);
}

TEST(Identify, SteadyStateWindowIsWholePeriodsAtTheEnd) {
  std::vector<double> t;
  for (int k = 0; k <= 5000; ++k) t.push_back(k * 1e-3);
  const IndexRange r = steady_state_window(t, 3.0, 2.0);
  // 3 s after settling → 9 whole periods of 1/3 s: starts at 5 − 3 = 2 s.
  EXPECT_EQ(r.end, t.size());
  EXPECT_NEAR(t[r.begin], 2.0, 1e-3);
  EXPECT_EQ(steady_state_window(t, 0.1, 2.0).size(), 0u);  // shorter than one period
}

}  // namespace
}  // namespace alphainv
