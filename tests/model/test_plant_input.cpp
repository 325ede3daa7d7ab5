// Tests of include/alphainv/model/plant_input.hpp: u = e·S(Z(v(t − τ))) + n(θ, θ̇, t) + d against
// its terms written out, the motor enable, and that it allocates nothing.
#include "alphainv/model/plant_input.hpp"

#include <cmath>
#include <type_traits>

#include <gtest/gtest.h>

#include "support/counting_allocator.hpp"

namespace alphainv {
namespace {

Effects some_effects() {
  Effects e;
  e.coulomb_v = 0.01;
  e.coulomb_smoothing_rad_s = 0.02;
  e.offset_v = -0.003;
  e.gravity_v = 0.05;
  e.gravity_theta0_rad = 0.2;
  e.deadzone_v = 0.004;
  e.saturation_v = 0.3;
  return e;
}

TEST(PlantInput, WithoutEffectsOrKnownInputsItIsTheCommand) {
  const Effects none;
  EXPECT_EQ(plant_input(none, 1.5, 0.123, 0.4, -2.0), 0.123);
  EXPECT_EQ(applied_command(none, -0.7), -0.7);
  EXPECT_EQ(plant_torque(none, 1.5, 0.4, -2.0), 0.0);
}

TEST(PlantInput, IsTheAmplifiedCommandPlusTheTorquesPlusTheDisturbance) {
  const Effects e = some_effects();
  const double v = 0.25, theta = 0.1, theta_dot = 0.03, d = 0.017;
  // Written out: S(Z(v)) = clamp(sign(v)·(|v| − 0.004), ±0.3); n = −Fc tanh(θ̇/ε) + d0 − g sin(θ+θ0).
  const double amp = 0.25 - 0.004;
  const double n = -0.01 * std::tanh(0.03 / 0.02) - 0.003 - 0.05 * std::sin(0.1 + 0.2);
  const KnownInputs known{d, true};
  EXPECT_NEAR(applied_command(e, v, known), amp, 1e-15);
  EXPECT_NEAR(plant_torque(e, 2.0, theta, theta_dot, known), n + d, 1e-15);
  EXPECT_NEAR(plant_input(e, 2.0, v, theta, theta_dot, known), amp + n + d, 1e-15);
  // The saturation clips the command, never the disturbance (a torque on the joint).
  const KnownInputs big{1.0, true};
  EXPECT_NEAR(plant_input(e, 0.0, 5.0, theta, theta_dot, big), 0.3 + n + 1.0, 1e-15);
  // Without a disturbance the result is bit for bit that of the two effects.hpp terms.
  EXPECT_EQ(plant_input(e, 0.0, v, theta, theta_dot),
            amplifier(e, v) + effect_torque(e, theta, theta_dot));
}

TEST(PlantInput, TheMotorOffRemovesTheCommandButNotTheTorques) {
  const Effects e = some_effects();
  const KnownInputs off{0.02, false};
  EXPECT_EQ(applied_command(e, 0.25, off), 0.0);
  EXPECT_NEAR(plant_input(e, 0.0, 0.25, 0.1, 0.0, off), effect_torque(e, 0.1, 0.0) + 0.02, 1e-15);
  EXPECT_EQ(plant_input(Effects{}, 0.0, 0.25, 0.0, 0.0, KnownInputs{0.0, false}), 0.0);
}

TEST(PlantInput, IsRealTimeSafe) {
  static_assert(noexcept(plant_input(Effects{}, 0.0, 0.0, 0.0, 0.0, KnownInputs{})));
  static_assert(noexcept(applied_command(Effects{}, 0.0)));
  static_assert(noexcept(plant_torque(Effects{}, 0.0, 0.0, 0.0)));
  const Effects e = some_effects();
  const long before = test::allocation_count();
  double sink = 0.0;
  for (int k = 0; k < 1000; ++k) {
    const KnownInputs known{0.001 * k, k % 3 != 0};
    sink += plant_input(e, 1e-3 * k, std::sin(0.01 * k), 0.001 * k, 0.1, known);
  }
  EXPECT_EQ(test::allocation_count(), before);
  EXPECT_TRUE(std::isfinite(sink));
}

}  // namespace
}  // namespace alphainv
