// Tests of include/alphainv/model/torque_effects.hpp: TorqueEffects::torque() against
// effect_torque() for every torque effect of the catalogue (equal to rounding: it multiplies by
// reciprocals where effect_torque() divides), the switched-off terms and plant_torque's overload.
#include "alphainv/model/torque_effects.hpp"

#include <cmath>
#include <algorithm>
#include <cstddef>
#include <limits>

#include <gtest/gtest.h>

#include "alphainv/model/plant_input.hpp"

namespace alphainv {
namespace {

/// `kind` switched on alone, at magnitudes of the diagnose sweep, with smoothing and scales away
/// from their defaults (so a reciprocal that is not 1 is used).
Effects one_effect(EffectKind kind) {
  Effects e;
  switch (kind) {
    case EffectKind::kCoulombFriction:
      e.coulomb_v = 0.02;
      e.coulomb_smoothing_rad_s = 0.013;
      break;
    case EffectKind::kOffsetTorque:
      e.offset_v = -0.0117;
      break;
    case EffectKind::kGravity:
      e.gravity_v = 0.031;
      e.gravity_theta0_rad = 0.37;
      break;
    case EffectKind::kCogging:
      e.cogging_v = 0.0093;
      e.cogging_period_rad = 0.0217;
      e.cogging_phase_rad = 0.61;
      break;
    case EffectKind::kStribeckFriction:
      e.stribeck_coulomb_v = 0.017;
      e.stribeck_breakaway_v = 0.041;
      e.stribeck_velocity_rad_s = 0.073;
      e.stribeck_smoothing_rad_s = 0.0031;
      break;
    case EffectKind::kAsymmetricFriction:
      e.asymmetric_coulomb_pos_v = 0.027;
      e.asymmetric_coulomb_neg_v = 0.011;
      e.asymmetric_viscous_diff_v_s = 0.0043;
      e.asymmetric_smoothing_rad_s = 0.0071;
      break;
    case EffectKind::kPositionDependentFriction:
      e.position_coulomb_v = 0.019;
      e.position_slope_v_per_rad = 0.13;
      e.position_smoothing_rad_s = 0.0029;
      break;
    case EffectKind::kDiscovered:
      e.discovered_sign_v = -0.004;
      e.discovered_stribeck_mid_v = -0.003;
      e.discovered_sin2_v = 0.002;
      e.discovered_vel_abs_vel_v = 0.001;
      e.discovered_pos_v = 0.0007;
      e.discovered_smoothing_rad_s = 0.02;
      e.discovered_velocity_scale_rad_s = 1.5;
      e.discovered_position_center_rad = 0.01;
      e.discovered_position_scale_rad = 0.07;
      break;
    default:
      ADD_FAILURE() << "no values for the torque effect " << effect_name(kind);
  }
  return e;
}

/// |a − b| within a few ulps of the larger, or 1e-14 relative to the effect's scale `scale_v` (a
/// sum of terms that nearly cancel has no relative accuracy of its own), or a few ulps of the
/// cogging's sine argument 2π·θ/p times its amplitude (that argument grows with θ/p: 240 at
/// θ = 0.83, p = 0.0217, where its ulp is 3e-14).
void expect_equal_to_rounding(double a, double b, double scale_v, const Effects& e, const char* what,
                              double theta, double theta_dot) {
  constexpr double kEps = std::numeric_limits<double>::epsilon();
  const double ulps = 4.0 * kEps * std::max(std::abs(a), std::abs(b));
  const double cogging_argument = 2.0 * 3.14159265358979323846 * std::abs(theta) / e.cogging_period_rad;
  const double argument = 4.0 * kEps * cogging_argument * std::abs(e.cogging_v);
  EXPECT_LE(std::abs(a - b), std::max({ulps, 1e-14 * scale_v, argument}))
      << what << " at theta = " << theta << ", theta' = " << theta_dot << ": " << a << " vs " << b;
}

TEST(TorqueEffects, EqualsEffectTorqueToRoundingForEveryTorqueEffect) {
  const double thetas[] = {-0.41, -0.0233, 0.0, 0.0071, 0.19, 0.83};
  const double velocities[] = {-2.3, -0.21, -0.004, 0.0, 1e-4, 0.0061, 0.09, 3.7};
  std::size_t kinds = 0;
  Effects all;
  for (const EffectSpec& spec : kEffectCatalogue) {
    if (spec.role != EffectRole::kTorque) continue;
    ++kinds;
    const Effects e = one_effect(spec.kind);
    ASSERT_TRUE(effect_active(e, spec.kind)) << spec.name;
    for (const EffectParameter& p : spec) all.*(p.member) = e.*(p.member);
    const TorqueEffects t(e);
    EXPECT_TRUE(t.any()) << spec.name;
    double largest = 0.0;  // the effect's scale: the largest |n| over the states
    for (double th : thetas) {
      for (double v : velocities) largest = std::max(largest, std::abs(effect_torque(e, th, v)));
    }
    ASSERT_GT(largest, 1e-3) << spec.name;
    for (double th : thetas) {
      for (double v : velocities) {
        expect_equal_to_rounding(t.torque(th, v), effect_torque(e, th, v), largest, e, spec.name,
                                 th, v);
      }
    }
  }
  // Every torque effect of the catalogue has values here (coulomb … position, discovered).
  EXPECT_EQ(kinds, 8u);
  // All of them at once.
  const TorqueEffects t(all);
  for (double th : thetas) {
    for (double v : velocities) {
      expect_equal_to_rounding(t.torque(th, v), effect_torque(all, th, v), 0.1, all, "all", th, v);
    }
  }
}

TEST(TorqueEffects, WithoutEffectsTheTorqueIsZeroAndNothingIsOn) {
  const TorqueEffects none;
  EXPECT_FALSE(none.any());
  EXPECT_EQ(none.torque(0.3, -2.0), 0.0);
  Effects off_terms;  // input maps and the delay are not torque terms
  off_terms.deadzone_v = 0.01;
  off_terms.saturation_v = 0.5;
  off_terms.delay_s = 0.002;
  EXPECT_FALSE(TorqueEffects(off_terms).any());
  EXPECT_EQ(TorqueEffects(off_terms).torque(0.1, 0.5), 0.0);
  Effects offset;
  offset.offset_v = 0.004;
  EXPECT_TRUE(TorqueEffects(offset).any());
  EXPECT_EQ(TorqueEffects(offset).torque(0.1, 0.5), 0.004);
}

TEST(TorqueEffects, FrictionAloneIsZeroAtRestExactly) {
  // The friction forms carry tanh(θ̇/ε): at θ̇ = 0 their torque is +0 at every θ, as
  // zero_at_rest() says; offset, gravity, cogging and the discovered term do not.
  Effects friction;
  for (EffectKind k : {EffectKind::kCoulombFriction, EffectKind::kStribeckFriction,
                       EffectKind::kAsymmetricFriction, EffectKind::kPositionDependentFriction}) {
    const Effects one = one_effect(k);
    EXPECT_TRUE(TorqueEffects(one).zero_at_rest()) << effect_name(k);
    for (const EffectParameter& p : effect_spec(k)) friction.*(p.member) = one.*(p.member);
  }
  const TorqueEffects t(friction);
  EXPECT_TRUE(t.zero_at_rest());
  for (double th : {-0.7, -0.01, 0.0, 0.2, 1.3}) {
    EXPECT_EQ(t.torque(th, 0.0), 0.0) << th;
    EXPECT_FALSE(std::signbit(t.torque(th, 0.0))) << th;
  }
  for (EffectKind k : {EffectKind::kOffsetTorque, EffectKind::kGravity, EffectKind::kCogging,
                       EffectKind::kDiscovered}) {
    EXPECT_FALSE(TorqueEffects(one_effect(k)).zero_at_rest()) << effect_name(k);
  }
}

TEST(TorqueEffects, SumTermsTellsEachTermAndItsPlainSumIsTheTorqueBitForBit) {
  Effects e;
  e.offset_v = -0.01;
  e.coulomb_v = 0.02;
  e.cogging_v = 0.01;
  e.cogging_period_rad = 0.016;
  e.gravity_v = 0.05;
  e.gravity_theta0_rad = 0.2;
  const TorqueEffects t(e);
  using detail::TorqueTerm;
  using detail::torque_term_bit;
  EXPECT_EQ(t.terms_on(), torque_term_bit(TorqueTerm::kCoulomb) | torque_term_bit(TorqueTerm::kGravity) |
                              torque_term_bit(TorqueTerm::kCogging));
  EXPECT_EQ(TorqueEffects().terms_on(), 0u);
  // A sum that keeps the Coulomb term apart: offset, gravity and cogging in one part, the
  // friction in the other; together the plain sum, bit for bit (same addends, same order).
  struct Split {
    double still = 0.0, coulomb = 0.0;
    int calls = 0;
    void start(double offset) { still = offset; }
    void add(TorqueTerm term, double addend) {
      ++calls;
      (term == TorqueTerm::kCoulomb ? coulomb : still) += addend;
    }
  };
  for (double theta : {-0.05, 0.0, 0.031}) {
    for (double w : {-0.4, 0.0, 2e-4, 0.7}) {
      Split split;
      t.sum_terms(theta, w, split);
      EXPECT_EQ(split.calls, 3);
      // Coulomb's addend alone: −Fc·tanh(θ̇/ε), with the other terms as written.
      EXPECT_NEAR(split.coulomb, -0.02 * std::tanh(w / e.coulomb_smoothing_rad_s), 1e-15);
      const double still = -0.01 - 0.05 * std::sin(theta + 0.2) +
                           0.01 * std::sin(6.283185307179586 * theta / 0.016);
      EXPECT_NEAR(split.still, still, 1e-15);
      detail::PlainTorqueSum plain;
      t.sum_terms(theta, w, plain);
      EXPECT_EQ(plain.n, t.torque(theta, w));
    }
  }
}

TEST(TorqueEffects, PlantTorqueOverloadAddsTheKnownDisturbance) {
  Effects e = one_effect(EffectKind::kCoulombFriction);
  e.offset_v = 0.003;
  const TorqueEffects t(e);
  KnownInputs known;
  known.disturbance_v = -0.0021;
  for (double v : {-0.5, 0.0, 0.007, 1.2}) {
    const double want = plant_torque(e, 0.4, 0.05, v, known);
    EXPECT_NEAR(plant_torque(t, 0.4, 0.05, v, known), want, 1e-15) << v;
    EXPECT_NEAR(plant_torque(t, 0.4, 0.05, v), effect_torque(e, 0.05, v), 1e-15) << v;
  }
}

}  // namespace
}  // namespace alphainv
