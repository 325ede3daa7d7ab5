// separability.hpp: the share of a column the others span, and which candidates the named
// effects' sensitivities span over the states visited.
#include "alphainv/diagnose/separability.hpp"

#include <cmath>

#include <gtest/gtest.h>

namespace alphainv {
namespace {

constexpr double kTwoPi = 6.283185307179586;

TEST(Separability, SpannedShareIsTheUncentredRSquared) {
  // y = 2·x1 − x2 exactly: all of it; y ⟂ the columns: none of it; y = x1 + e with e = (0, 0, 3, 0)
  // ⟂ x1: |x1|² / (|x1|² + |e|²).
  const std::vector<double> x1 = {1, 0, 0, 0}, x2 = {0, 1, 0, 0};
  EXPECT_NEAR(spanned_share({2, -1, 0, 0}, {x1, x2}), 1.0, 1e-15);
  EXPECT_NEAR(spanned_share({0, 0, 1, 1}, {x1, x2}), 0.0, 1e-15);
  EXPECT_NEAR(spanned_share({1, 0, 3, 0}, {x1}), 1.0 / 10.0, 1e-15);
  EXPECT_TRUE(std::isnan(spanned_share({0, 0, 0, 0}, {x1})));
  EXPECT_TRUE(std::isnan(spanned_share({1, 2}, {})));
  EXPECT_TRUE(std::isnan(spanned_share({1, 2}, {{1, 2, 3}})));
}

/// States of a sine motion θ = A·sin(2π·t) over 2 s at 1 kHz.
void sine_states(double amplitude_rad, std::vector<double>& theta, std::vector<double>& theta_dot) {
  theta.clear(), theta_dot.clear();
  for (int k = 0; k < 2000; ++k) {
    const double t = 0.001 * k;
    theta.push_back(amplitude_rad * std::sin(kTwoPi * t));
    theta_dot.push_back(amplitude_rad * kTwoPi * std::cos(kTwoPi * t));
  }
}

TEST(Separability, AnOffsetIsNotSeparableFromGravityOverASmallStrokeOnlyAndNotFromCoulomb) {
  Effects model;
  model.gravity_v = 0.22, model.gravity_theta0_rad = -0.088;
  Effects offset;
  offset.offset_v = 0.01;
  Effects coulomb;
  coulomb.coulomb_v = 0.02, coulomb.coulomb_smoothing_rad_s = 0.014;
  const std::vector<std::pair<EffectKind, Effects>> tried = {
      {EffectKind::kOffsetTorque, offset}, {EffectKind::kCoulombFriction, coulomb},
      {EffectKind::kGravity, model},  // named: skipped
      {EffectKind::kTimeDelay, Effects{}}};  // not a torque of the state: skipped
  std::vector<double> th, thd;
  // ±0.07 rad: cos(θ + θ0) is a constant to 1 − sin(θ0)²·A²/2/cos(θ0)² ≈ 1 − 2e-5 of its energy.
  sine_states(0.07, th, thd);
  const std::vector<NotSeparable> small = not_separable(model, {EffectKind::kGravity}, tried, th, thd);
  ASSERT_EQ(small.size(), 1u);
  EXPECT_EQ(small[0].effect, EffectKind::kOffsetTorque);
  ASSERT_EQ(small[0].from.size(), 1u);
  EXPECT_EQ(small[0].from[0], EffectKind::kGravity);
  EXPECT_GT(small[0].share, 0.99999);
  EXPECT_NE(small[0].message.find("offset_torque is not separable from gravity"), std::string::npos)
      << small[0].message;
  // ±1.5 rad: the curvature separates them (an offset is then far from gravity's tangent space).
  sine_states(1.5, th, thd);
  EXPECT_TRUE(not_separable(model, {EffectKind::kGravity}, tried, th, thd).empty());
  // An offset fitted to nothing (gravity's θ0 took it up) is judged by its form: the same.
  Effects none_left;
  sine_states(0.07, th, thd);
  const auto collapsed = not_separable(model, {EffectKind::kGravity}, {{EffectKind::kOffsetTorque, none_left}}, th, thd);
  ASSERT_EQ(collapsed.size(), 1u);
  EXPECT_GT(collapsed[0].share, 0.99999);
  sine_states(1.5, th, thd);
  // Nothing named, or no states: nothing to say.
  EXPECT_TRUE(not_separable(model, {}, tried, th, thd).empty());
  EXPECT_TRUE(not_separable(model, {EffectKind::kGravity}, tried, {}, {}).empty());
}

TEST(Separability, ALongCoggingIsGravitysAndNestedFormsAreNotChecked) {
  // Named: an offset and gravity. A cogging whose period (2 rad) is much longer than the stroke
  // (±0.07 rad) is a constant and a spring there: gravity's sensitivities span it (the offset's
  // constant alone does not); of period 0.02 rad it is its own.
  Effects model;
  model.offset_v = 0.005;
  model.gravity_v = 0.2, model.gravity_theta0_rad = 0.1;
  Effects cogging;
  cogging.cogging_v = 0.01, cogging.cogging_period_rad = 2.0, cogging.cogging_phase_rad = 0.7;
  std::vector<double> th, thd;
  sine_states(0.07, th, thd);
  const std::vector<EffectKind> named = {EffectKind::kOffsetTorque, EffectKind::kGravity};
  const std::vector<NotSeparable> ns = not_separable(model, named, {{EffectKind::kCogging, cogging}}, th, thd);
  ASSERT_EQ(ns.size(), 1u);
  EXPECT_EQ(ns[0].effect, EffectKind::kCogging);
  EXPECT_EQ(ns[0].from, std::vector<EffectKind>{EffectKind::kGravity});
  EXPECT_NE(ns[0].message.find("cogging is not separable from gravity"), std::string::npos) << ns[0].message;
  cogging.cogging_period_rad = 0.02;
  EXPECT_TRUE(not_separable(model, named, {{EffectKind::kCogging, cogging}}, th, thd).empty());
  // Nested forms: an asymmetric friction fitted symmetric, or a position-dependent friction with
  // no slope, is the Coulomb friction named (spanned by it), and an asymmetric friction is also
  // an offset's generalisation: none is said to be a confusion.
  Effects friction;
  friction.coulomb_v = 0.02, friction.coulomb_smoothing_rad_s = 0.014;
  Effects asym;
  asym.asymmetric_coulomb_pos_v = asym.asymmetric_coulomb_neg_v = 0.02;
  asym.asymmetric_smoothing_rad_s = 0.014;
  Effects pos;
  pos.position_coulomb_v = 0.02, pos.position_smoothing_rad_s = 0.014;
  const std::vector<std::pair<EffectKind, Effects>> nested = {{EffectKind::kAsymmetricFriction, asym},
                                                              {EffectKind::kPositionDependentFriction, pos}};
  EXPECT_TRUE(not_separable(friction, {EffectKind::kCoulombFriction}, nested, th, thd).empty());
  EXPECT_TRUE(not_separable(model, {EffectKind::kOffsetTorque}, {{EffectKind::kAsymmetricFriction, asym}}, th, thd)
                  .empty());
  // … while the same position-dependent friction against an offset (not nested) is its own.
  EXPECT_TRUE(not_separable(model, {EffectKind::kOffsetTorque}, {{EffectKind::kPositionDependentFriction, pos}},
                            th, thd)
                  .empty());
}

TEST(Separability, AGeneralisationTheNamedMakeUpTogetherIsSaid) {
  // Named: Coulomb friction and gravity. An asymmetric friction Fc⁺ = 0.02, Fc⁻ = 0.01 V (no
  // viscous difference, the same ε) is −σ·(0.015 + 0.005·σ) = −0.015·σ − 0.005·σ²: Coulomb's
  // σ and, where |θ̇| ≫ ε (σ² = 1), a constant, which gravity's θ0 makes over ±0.07 rad. So it
  // is not separable from the two together, though nested with Coulomb friction.
  Effects model;
  model.coulomb_v = 0.015, model.coulomb_smoothing_rad_s = 1e-3;
  model.gravity_v = 0.27, model.gravity_theta0_rad = 0.02;
  Effects asym;
  asym.asymmetric_coulomb_pos_v = 0.02, asym.asymmetric_coulomb_neg_v = 0.01;
  asym.asymmetric_smoothing_rad_s = 1e-3;
  std::vector<double> th, thd;
  sine_states(0.07, th, thd);  // |θ̇| ≤ 0.44 rad/s; below ε = 1 mrad/s at about 0.2 % of the samples
  const std::vector<EffectKind> named = {EffectKind::kCoulombFriction, EffectKind::kGravity};
  const std::vector<NotSeparable> ns = not_separable(model, named, {{EffectKind::kAsymmetricFriction, asym}}, th, thd);
  ASSERT_EQ(ns.size(), 1u);
  EXPECT_EQ(ns[0].effect, EffectKind::kAsymmetricFriction);
  EXPECT_EQ(ns[0].from, named);
  EXPECT_GT(ns[0].share, 0.999);
  EXPECT_NE(ns[0].message.find("beyond coulomb_friction's form is taken up"), std::string::npos) << ns[0].message;
  // Coulomb friction alone spans its symmetric part only (0.015² against 0.005²: 90 %).
  EXPECT_TRUE(not_separable(model, {EffectKind::kCoulombFriction}, {{EffectKind::kAsymmetricFriction, asym}}, th, thd)
                  .empty());
  // Over ±1.5 rad gravity's sensitivities are no constant: its own again.
  sine_states(1.5, th, thd);
  EXPECT_TRUE(not_separable(model, named, {{EffectKind::kAsymmetricFriction, asym}}, th, thd).empty());
  // A viscous difference of the same size as its levels (Δb/2·|θ̇|, no term the named make)
  // separates it over the small stroke too.
  sine_states(0.07, th, thd);
  asym.asymmetric_viscous_diff_v_s = 0.1;
  EXPECT_TRUE(not_separable(model, named, {{EffectKind::kAsymmetricFriction, asym}}, th, thd).empty());
}

TEST(Separability, SpannedOnlyByTwoNamedTogetherNamesBoth) {
  // Three distinct states, θ = 0, 1, 2 rad with θ̇ = +1, −1, +1 rad/s (|θ̇| ≫ ε: the Coulomb term
  // is −Fc·(1, −1, 1)). Named: Coulomb friction and gravity (θ0 = 0: its sensitivities −sin θ and
  // −g·cos θ). An offset's constant (1, 1, 1) is neither ±(1, −1, 1) nor a·sin θ + b·cos θ (b = 1
  // at θ = 0 and a = (1 − cos 1)/sin 1 = 0.546 at θ = 1 give 0.081 at θ = 2), but the three
  // columns span R³: it is not separable from the two together, and both are named.
  Effects model;
  model.coulomb_v = 0.02, model.coulomb_smoothing_rad_s = 1e-3;
  model.gravity_v = 0.1, model.gravity_theta0_rad = 0.0;
  Effects offset;
  offset.offset_v = 0.01;
  std::vector<double> th, thd;
  for (int k = 0; k < 300; ++k) th.push_back(k % 3), thd.push_back(k % 3 == 1 ? -1.0 : 1.0);
  const std::vector<EffectKind> named = {EffectKind::kCoulombFriction, EffectKind::kGravity};
  const std::vector<NotSeparable> ns = not_separable(model, named, {{EffectKind::kOffsetTorque, offset}}, th, thd);
  ASSERT_EQ(ns.size(), 1u);
  EXPECT_EQ(ns[0].effect, EffectKind::kOffsetTorque);
  EXPECT_EQ(ns[0].from, named);
  EXPECT_GT(ns[0].share, 0.999999);
  EXPECT_NE(ns[0].message.find("not separable from coulomb_friction + gravity"), std::string::npos)
      << ns[0].message;
  // Either one alone leaves most of it: with gravity only, the share is that of (1, 1, 1) on
  // span{sin θ, cos θ} at the three states, below the threshold; so nothing is said.
  EXPECT_TRUE(not_separable(model, {EffectKind::kGravity}, {{EffectKind::kOffsetTorque, offset}}, th, thd).empty());
  EXPECT_TRUE(
      not_separable(model, {EffectKind::kCoulombFriction}, {{EffectKind::kOffsetTorque, offset}}, th, thd).empty());
  // Moving one way only (θ̇ = +1 at all three), the Coulomb term is the constant itself: spanned by
  // Coulomb friction alone, which alone is named.
  for (double& v : thd) v = 1.0;
  const std::vector<NotSeparable> one = not_separable(model, named, {{EffectKind::kOffsetTorque, offset}}, th, thd);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].from, std::vector<EffectKind>{EffectKind::kCoulombFriction});
}

}  // namespace
}  // namespace alphainv
