#include "alphainv/model/damping_model.hpp"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace alphainv {
namespace {

constexpr double kI6590 = 0.004366;  // Table 10

TEST(DampingModel, PaperModelReproducesTable10) {
  // paper-notes erratum 3: C = 16.955, 10.619, 6.486, 3.710 at α = 0, 2.2, 25, 250; β̃ 267.6, 170.9.
  const AlphaModel m = paper_alpha_model();
  ASSERT_TRUE(m.valid());
  const double alphas[] = {0.0, 2.2, 25.0, 250.0};
  const double c[] = {16.955, 10.619, 6.486, 3.710};
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(m.damping(alphas[k], kI6590), c[k], 0.001 * c[k]);
  EXPECT_NEAR(m.beta_tilde(0.0, kI6590), 267.6, 0.001 * 267.6);
  EXPECT_NEAR(m.beta_tilde(250.0, kI6590), 170.9, 0.001 * 170.9);
}

TEST(DampingModel, TriLinearBetweenBreakpointsEq38) {
  const AlphaModel m = paper_alpha_model();
  const double c1 = m.damping(2.2, kI6590), c2 = m.damping(25.0, kI6590);
  const double a = 10.0;
  EXPECT_NEAR(m.damping(a, kI6590), c1 + (c2 - c1) / (25.0 - 2.2) * (a - 2.2), 1e-12);
  const double b0 = m.beta_tilde(0.0, kI6590), b1 = m.beta_tilde(250.0, kI6590);
  EXPECT_NEAR(m.beta_tilde(100.0, kI6590), b0 + (b1 - b0) * 100.0 / 250.0, 1e-12);  // eq. (41)
}

TEST(DampingModel, ContinuousAtBreakpoints) {
  const AlphaModel m = paper_alpha_model();
  for (std::size_t n = 0; n < m.n_breakpoints; ++n) {
    const double a = m.alpha[n], eps = 1e-9 * std::max(1.0, a);
    EXPECT_NEAR(m.damping(a - eps, kI6590), m.damping(a + eps, kI6590), 1e-6);
  }
  EXPECT_NEAR(m.beta_tilde(250.0 - 1e-9, kI6590), m.beta_tilde(250.0 + 1e-9, kI6590), 1e-6);
}

TEST(DampingModel, HeldAtEndValuesOutsideBreakpoints) {
  const AlphaModel m = paper_alpha_model();
  EXPECT_DOUBLE_EQ(m.damping(-5.0, kI6590), m.damping(0.0, kI6590));
  EXPECT_DOUBLE_EQ(m.damping(1e6, kI6590), m.damping(250.0, kI6590));
  EXPECT_DOUBLE_EQ(m.beta_tilde(-1.0, kI6590), m.beta_tilde(0.0, kI6590));
  EXPECT_DOUBLE_EQ(m.beta_tilde(1e9, kI6590), m.beta_tilde(250.0, kI6590));
}

TEST(DampingModel, InertiaScalingEq40) {
  // C_n(I) = 1/(C_n1 I): doubling I halves C and β̃ at every α.
  const AlphaModel m = paper_alpha_model();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> alpha(-10.0, 400.0);
  for (int k = 0; k < 100; ++k) {
    const double a = alpha(rng);
    EXPECT_NEAR(m.damping(a, 2 * kI6590), 0.5 * m.damping(a, kI6590), 1e-12);
    EXPECT_NEAR(m.beta_tilde(a, 2 * kI6590), 0.5 * m.beta_tilde(a, kI6590), 1e-10);
  }
}

TEST(DampingModel, TwoAndEightBreakpoints) {
  AlphaModel m;
  m.n_breakpoints = 2;
  m.alpha[0] = 1.0;
  m.alpha[1] = 3.0;
  m.c_n1[0] = 1.0;
  m.c_n1[1] = 0.5;
  ASSERT_TRUE(m.valid());
  EXPECT_DOUBLE_EQ(m.damping(2.0, 1.0), 1.5);
  m.n_breakpoints = kMaxBreakpoints;
  for (std::size_t n = 0; n < kMaxBreakpoints; ++n) {
    m.alpha[n] = static_cast<double>(n);
    m.c_n1[n] = 1.0 / (1.0 + static_cast<double>(n));
  }
  ASSERT_TRUE(m.valid());
  EXPECT_NEAR(m.damping(6.5, 1.0), 7.5, 1e-12);
}

TEST(DampingModel, ValidityChecks) {
  AlphaModel m = paper_alpha_model();
  m.alpha[2] = m.alpha[1];
  EXPECT_FALSE(m.valid());
  m = paper_alpha_model();
  m.c_n1[0] = -1.0;
  EXPECT_FALSE(m.valid());
  m = paper_alpha_model();
  m.n_breakpoints = 1;
  EXPECT_FALSE(m.valid());
  m = paper_alpha_model();
  m.beta_alpha = {1.0, 1.0};
  EXPECT_FALSE(m.valid());
}

}  // namespace
}  // namespace alphainv
