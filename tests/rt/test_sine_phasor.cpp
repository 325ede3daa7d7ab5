// rt::SinePhasor: sin and cos of an advancing phase by rotation, against std::sin and std::cos
// over long runs (the rounding a rotation adds is bounded by the periodic direct evaluation), with
// the tick's time as the runner makes it (integer nanoseconds), skipped ticks and NaN.
#include "alphainv/rt/sine_phasor.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>

using alphainv::rt::SinePhasor;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Largest |sin − std::sin|, |cos − std::cos| over `ticks` calls at φ = ω·t, t = k·T from integer
/// nanoseconds as LoopRunner makes it, with every `skip_every`-th tick skipped (0: none).
double worst_error(double freq_hz, std::int64_t ticks, std::int64_t skip_every) {
  const double period_s = 1e-3;
  const double omega = 2.0 * kPi * freq_hz;
  SinePhasor p;
  p.set_step(omega * period_s);
  double worst = 0.0;
  for (std::int64_t k = 0; k < ticks; ++k) {
    if (skip_every > 0 && k % skip_every == skip_every - 1) continue;  // a late tick: t jumps 2T
    const double t = static_cast<double>(k * 1'000'000) * 1e-9;
    const double phase = omega * t;
    double s = 0.0, c = 0.0;
    p.sin_cos(phase, s, c);
    worst = std::max(worst, std::max(std::abs(s - std::sin(phase)), std::abs(c - std::cos(phase))));
  }
  return worst;
}

}  // namespace

TEST(SinePhasor, EqualsTheLibrarysSinAndCosOverLongRuns) {
  // 0.5-7 Hz, 2·10^5 ticks (200 s): within 1e-14 throughout (the rotations' rounding over at
  // most 63 calls between two direct evaluations).
  for (double f : {0.5, 1.5, 3.0, 7.0}) {
    const double worst = worst_error(f, 200'000, 0);
    RecordProperty("worst_" + std::to_string(f), std::to_string(worst));
    EXPECT_LT(worst, 1e-14) << f << " Hz";
  }
}

TEST(SinePhasor, SkippedTicksAndLargeTimes) {
  // A skipped tick (Δ = 2δ, not near δ) evaluates directly: no error from the jump.
  EXPECT_LT(worst_error(3.0, 50'000, 97), 1e-14);
  // Late in a long run (t ≈ 10^4 s: the phase's own rounding is 1e-11 rad), the rotation
  // corrects by Δ − δ, so sin and cos are those of the phase passed, to its rounding.
  SinePhasor p;
  const double omega = 2.0 * kPi * 3.0;
  p.set_step(omega * 1e-3);
  double worst = 0.0;
  for (std::int64_t k = 10'000'000; k < 10'010'000; ++k) {
    const double phase = omega * (static_cast<double>(k * 1'000'000) * 1e-9);
    double s = 0.0, c = 0.0;
    p.sin_cos(phase, s, c);
    worst = std::max(worst, std::max(std::abs(s - std::sin(phase)), std::abs(c - std::cos(phase))));
  }
  EXPECT_LT(worst, 1e-14);
}

TEST(SinePhasor, ResetAndNewStepEvaluateDirectly) {
  SinePhasor p;
  p.set_step(0.01);
  double s = 0.0, c = 0.0;
  for (int k = 0; k < 10; ++k) p.sin_cos(0.01 * k, s, c);
  // A phase that does not follow (a new waveform started): evaluated directly.
  p.sin_cos(2.0, s, c);
  EXPECT_NEAR(s, std::sin(2.0), 1e-15);
  EXPECT_NEAR(c, std::cos(2.0), 1e-15);
  // After reset() the next call is direct even when it follows by δ.
  p.reset();
  p.sin_cos(2.01, s, c);
  EXPECT_NEAR(s, std::sin(2.01), 1e-15);
  // A new step: the rotation uses it.
  p.set_step(0.05);
  for (int k = 0; k < 300; ++k) {
    const double phase = 1.0 + 0.05 * k;
    p.sin_cos(phase, s, c);
    ASSERT_NEAR(s, std::sin(phase), 1e-14) << k;
    ASSERT_NEAR(c, std::cos(phase), 1e-14) << k;
  }
}

TEST(SinePhasor, NanPhaseGivesNanAndRecovers) {
  SinePhasor p;
  p.set_step(0.01);
  double s = 0.0, c = 0.0;
  p.sin_cos(0.0, s, c);
  p.sin_cos(std::numeric_limits<double>::quiet_NaN(), s, c);
  EXPECT_TRUE(std::isnan(s));
  EXPECT_TRUE(std::isnan(c));
  p.sin_cos(0.5, s, c);  // not a rotation of NaN: a direct evaluation
  EXPECT_NEAR(s, std::sin(0.5), 1e-15);
  EXPECT_NEAR(c, std::cos(0.5), 1e-15);
}
