#include "alphainv/rt/alpha_estimator.hpp"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "alphainv/model/damping_model.hpp"
#include "support/counting_allocator.hpp"

namespace alphainv::rt {
namespace {

constexpr double kT = 1e-3;

/// Largest relative error of α̂ against `alpha_true` over `seconds` after warm-up.
double max_rel_error_sine(AlphaEstimator& est, double amp, double f, double phase, double seconds) {
  est.reset(amp * std::sin(phase));
  const double w = 2 * M_PI * f;
  const double truth = amp * amp * w * w;
  double worst = 0.0;
  const long n = static_cast<long>(seconds / kT);
  for (long k = 0; k < n; ++k) {
    const AlphaEstimate e = est.update(amp * std::sin(w * static_cast<double>(k) * kT + phase));
    if (k > 3 * est.warmup_ticks()) worst = std::max(worst, std::abs(e.alpha - truth) / truth);
  }
  return worst;
}

TEST(AlphaEstimator, SinesFrom1To10HzWithin1Percent) {
  AlphaEstimator est;
  for (double amp : {0.02, 0.3, 4.0}) {
    for (double f : {1.0, 1.5, 2.0, 3.0, 4.5, 6.0, 8.0, 10.0}) {
      EXPECT_LT(max_rel_error_sine(est, amp, f, 0.3, 3.0), 0.01) << "A=" << amp << " f=" << f;
    }
  }
}

TEST(AlphaEstimator, BiasFollowsStatedFilterGain) {
  // Above the pass band the under-read is the stated |H|² (plus the hold's sinc²).
  AlphaEstimator est;
  const double f = 20.0, amp = 1.0, w = 2 * M_PI * f;
  est.reset();
  double sum = 0.0;
  int n = 0;
  for (long k = 0; k < 4000; ++k) {
    const AlphaEstimate e = est.update(amp * std::sin(w * static_cast<double>(k) * kT));
    if (k > 2000) {
      sum += e.alpha;
      ++n;
    }
  }
  const double sinc = std::sin(w * kT / 2) / (w * kT / 2);
  const double expected = est.alpha_gain(f) * std::pow(sinc, 4) * amp * amp * w * w;
  EXPECT_NEAR(sum / n, expected, 0.01 * expected);
  EXPECT_LT(est.alpha_gain(f), 0.85);  // the bias is real at 20 Hz
}

TEST(AlphaEstimator, QuantisedClosedLoopCommandAt3HzWithin5Percent) {
  // Steady state of the linear plant θ̈ + Cθ̇ + βθ = βr (C = 6.242, β = 458, the 65°/90° pose),
  // with θ quantised to 1.5e-4 rad as an encoder would, feeding v = kp(r − θ_q).
  const double kp = 2.0, c = 6.242, beta = 458.0, ar = 0.07, f = 3.0, w = 2 * M_PI * f;
  // θ = A1 cos ωt + A2 sin ωt, from (18).
  const double den = (beta - w * w) * (beta - w * w) + c * c * w * w;
  const double a2 = beta * ar * (beta - w * w) / den;
  const double a1 = -beta * ar * c * w / den;
  const double truth = kp * kp * w * w * (a1 * a1 + (ar - a2) * (ar - a2));  // eq. (36)
  const double q = 1.5e-4;
  AlphaEstimator est;
  est.reset();
  double worst = 0.0;
  for (long k = 0; k < 5000; ++k) {
    const double t = static_cast<double>(k) * kT;
    const double theta = a1 * std::cos(w * t) + a2 * std::sin(w * t);
    const double theta_q = q * std::round(theta / q);
    const AlphaEstimate e = est.update(kp * (ar * std::sin(w * t) - theta_q));
    if (k > 3 * est.warmup_ticks()) worst = std::max(worst, std::abs(e.alpha - truth) / truth);
  }
  EXPECT_LT(worst, 0.05);
}

TEST(AlphaEstimator, NoiseGainMatchesContinuousApproximationAndSimulation) {
  AlphaEstimator est;
  const AlphaNoiseGain g = est.noise_gain();
  const double wc = 2 * M_PI * est.config().cutoff_hz;
  // White noise of variance σ² through the Butterworth: var(w'') ≈ σ² T ωc⁵ / 3, var(w') ≈ σ² T ωc³ / 6.
  EXPECT_NEAR(g.v_ddot, std::sqrt(kT * std::pow(wc, 5) / 3), 0.1 * g.v_ddot);
  EXPECT_NEAR(g.v_dot, std::sqrt(kT * std::pow(wc, 3) / 6), 0.1 * g.v_dot);
  // And against a seeded Monte Carlo run.
  std::mt19937_64 rng(42);
  std::normal_distribution<double> noise(0.0, 1.0);
  est.reset();
  double s2 = 0.0;
  const int n = 200000;
  for (int k = 0; k < n; ++k) {
    const double vdd = est.update(noise(rng)).v_ddot;
    if (k > 1000) s2 += vdd * vdd;
  }
  EXPECT_NEAR(std::sqrt(s2 / (n - 1001)), g.v_ddot, 0.03 * g.v_ddot);
}

TEST(AlphaEstimator, DelayIsStated) {
  AlphaEstimator est;
  EXPECT_NEAR(est.delay_s(), 2.0 / (2 * M_PI * 25.0), 1e-12);
  // A slow ramp v = s·t is followed with the stated lag: w ≈ s (t − delay).
  est.reset();
  const double s = 0.7;
  AlphaEstimate e;
  for (long k = 0; k < 2000; ++k) e = est.update(s * static_cast<double>(k) * kT);
  const double t_end = 1999 * kT;  // the estimate refers to the newest sample's instant
  EXPECT_NEAR(e.v, s * (t_end - est.delay_s()), 1e-6);
  EXPECT_NEAR(e.v_dot, s, 1e-9);
  EXPECT_NEAR(e.alpha, s * s, 1e-6);  // α of a ramp is its slope²
}

TEST(AlphaEstimator, RejectsBadSettings) {
  EXPECT_THROW(AlphaEstimator(AlphaEstimatorConfig{0.0, 25.0}), alphainv::Error);
  EXPECT_THROW(AlphaEstimator(AlphaEstimatorConfig{1e-3, 300.0}), alphainv::Error);
  EXPECT_THROW(AlphaEstimator(AlphaEstimatorConfig{1e-3, -1.0}), alphainv::Error);
  EXPECT_THROW(AlphaEstimator(AlphaEstimatorConfig{NAN, 25.0}), alphainv::Error);
}

TEST(AlphaEstimator, TickAllocatesNothing) {
  AlphaEstimator est;
  const AlphaModel model = paper_alpha_model();
  est.reset();
  double sink = 0.0;
  const long before = alphainv::test::allocation_count();
  for (int k = 0; k < 10000; ++k) {
    const AlphaEstimate e = est.update(std::sin(0.01 * k));
    sink += model.damping(e.alpha, 0.004366) + model.beta_tilde(e.alpha, 0.004366);
  }
  EXPECT_EQ(alphainv::test::allocation_count() - before, 0);
  EXPECT_TRUE(std::isfinite(sink));
}

}  // namespace
}  // namespace alphainv::rt
