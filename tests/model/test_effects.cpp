#include "alphainv/model/effects.hpp"

#include <cmath>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "alphainv/error.hpp"

namespace alphainv {
namespace {

TEST(Effects, NamesRoundTripAndUnknownNameNamesTheField) {
  for (EffectKind k : kAllEffectKinds) EXPECT_EQ(effect_kind_from_name(effect_name(k)), k);
  EXPECT_STREQ(effect_name(EffectKind::kCoulombFriction), "coulomb_friction");
  EXPECT_STREQ(effect_name(EffectKind::kTimeDelay), "time_delay");
  try {
    effect_kind_from_name("friction", "effects[0].effect");
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "effects[0].effect");
    EXPECT_NE(std::string(e.what()).find("coulomb_friction"), std::string::npos) << e.what();
  }
}

TEST(Effects, DefaultsAreAllOffAndTheTermsVanish) {
  const Effects e;
  EXPECT_TRUE(active_effects(e).empty());
  EXPECT_EQ(effect_torque(e, 0.3, -2.0), 0.0);
  EXPECT_EQ(amplifier(e, -7.5), -7.5);
  EXPECT_NO_THROW(validate_effects(e));
}

TEST(Effects, TorqueTermsMatchTheirFormulas) {
  Effects e;
  e.coulomb_v = 0.2;
  e.coulomb_smoothing_rad_s = 0.01;
  e.offset_v = -0.05;
  e.gravity_v = 0.3;
  e.gravity_theta0_rad = 0.4;
  e.cogging_v = 0.07;
  e.cogging_period_rad = 0.05;
  e.cogging_phase_rad = 1.1;
  const double th = 0.123, thd = 0.004;
  const double expected = -0.2 * std::tanh(0.4) - 0.05 - 0.3 * std::sin(0.523) +
                          0.07 * std::sin(2 * M_PI * th / 0.05 + 1.1);
  EXPECT_NEAR(effect_torque(e, th, thd), expected, 1e-15);
  // Far above ε the Coulomb term is −Fc·sign(θ̇).
  Effects c;
  c.coulomb_v = 0.2;
  EXPECT_NEAR(effect_torque(c, 0.0, 1.0), -0.2, 1e-12);
  EXPECT_NEAR(effect_torque(c, 0.0, -1.0), 0.2, 1e-12);
  const auto kinds = active_effects(e);
  ASSERT_EQ(kinds.size(), 4u);
  EXPECT_EQ(kinds[0], EffectKind::kCoulombFriction);
  EXPECT_EQ(kinds[3], EffectKind::kCogging);
}

TEST(Effects, AmplifierAppliesDeadzoneThenSaturation) {
  Effects e;
  e.deadzone_v = 0.1;
  e.saturation_v = 0.5;
  EXPECT_EQ(amplifier(e, 0.05), 0.0);
  EXPECT_EQ(amplifier(e, -0.1), 0.0);
  EXPECT_NEAR(amplifier(e, 0.3), 0.2, 1e-15);
  EXPECT_NEAR(amplifier(e, -0.35), -0.25, 1e-15);
  EXPECT_EQ(amplifier(e, 2.0), 0.5);
  EXPECT_EQ(amplifier(e, -2.0), -0.5);
}

TEST(Effects, ParametersPointAtTheirMembers) {
  Effects e;
  for (EffectKind k : kAllEffectKinds) {
    for (const EffectParameter& p : effect_parameters(k)) e.*(p.member) = 0.25;
  }
  EXPECT_EQ(e.coulomb_v, 0.25);
  EXPECT_EQ(e.cogging_period_rad, 0.25);
  EXPECT_EQ(e.delay_s, 0.25);
  EXPECT_EQ(e.saturation_v, 0.25);
  EXPECT_EQ(active_effects(e).size(), 7u);
  EXPECT_TRUE(effect_parameters(EffectKind::kNone).empty());
  EXPECT_EQ(effect_parameters(EffectKind::kCogging).size(), 3u);
}

TEST(Effects, ModellingChoicesAreListedOnlyWhenAsked) {
  // The Coulomb smoothing ε: not a fitted parameter, but what a model file stores.
  const auto with = effect_parameters(EffectKind::kCoulombFriction, true);
  ASSERT_EQ(with.size(), 2u);
  EXPECT_EQ(std::string(with[0].name), "coulomb_v");
  EXPECT_EQ(with[1].member, &Effects::coulomb_smoothing_rad_s);
  EXPECT_EQ(effect_parameters(EffectKind::kCoulombFriction).size(), 1u);
  for (EffectKind k : kAllEffectKinds) {
    if (k == EffectKind::kCoulombFriction) continue;
    EXPECT_EQ(effect_parameters(k, true).size(), effect_parameters(k).size()) << effect_name(k);
  }
}

TEST(Effects, TextNamesTheActiveEffectsWithTheirParameters) {
  Effects e;
  EXPECT_EQ(effects_text(e), "none");
  e.coulomb_v = 0.004;
  e.delay_s = 0.002;
  EXPECT_EQ(effects_text(e),
            "coulomb_friction (coulomb_v = 0.004, coulomb_smoothing_rad_s = 0.001); "
            "time_delay (delay_s = 0.002)");
}

TEST(Effects, ValidationNamesTheBadField) {
  auto field_of = [](const Effects& e) {
    try {
      validate_effects(e, "model.effects.");
    } catch (const Error& err) {
      return err.field();
    }
    return std::string("(none)");
  };
  Effects e;
  e.coulomb_v = -1;
  EXPECT_EQ(field_of(e), "model.effects.coulomb_v");
  e = {};
  e.delay_s = 2.0;
  EXPECT_EQ(field_of(e), "model.effects.delay_s");
  e = {};
  e.saturation_v = 0.0;
  EXPECT_EQ(field_of(e), "model.effects.saturation_v");
  e = {};
  e.offset_v = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(field_of(e), "model.effects.offset_v");
  e = {};
  e.cogging_v = 0.1;
  e.cogging_period_rad = 0.0;
  EXPECT_EQ(field_of(e), "model.effects.cogging_period_rad");
}

}  // namespace
}  // namespace alphainv
