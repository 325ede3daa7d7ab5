#include "alphainv/simulate/invented_effects.hpp"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "alphainv/error.hpp"
#include "alphainv/simulate/experiment_plan.hpp"

namespace alphainv {
namespace {

TEST(InventedEffects, LuGreSettlesToItsSteadyStateFrictionAndLagsAtReversal) {
  const InventedEffect e = parse_invented_effect("lugre:level_v=0.006,breakaway_v=0.012");
  EXPECT_EQ(e.kind, InventedKind::kLuGre);
  for (double v : {0.02, 0.1, 1.0, -0.3}) {
    auto n = invented_torque(e, 0);
    double out = 0.0;
    for (int k = 0; k < 4000; ++k) out = n(1e-3 * k, 0.0, v);  // 4 s at constant θ̇
    // ż = 0: σ0·z = g(θ̇)·sign θ̇, g = Fc + (Fs − Fc)·exp(−|θ̇/v_s|).
    const double g = 0.006 + 0.006 * std::exp(-std::abs(v / 0.1));
    EXPECT_NEAR(out, -std::copysign(g, v), 1e-9 * g) << v;
  }
  // After a reversal the bristles take time: the friction does not flip at once.
  auto n = invented_torque(e, 0);
  for (int k = 0; k < 1000; ++k) n(1e-3 * k, 0.0, 0.5);
  const double just_after = n(1.0, 0.0, -0.5);
  EXPECT_LT(just_after, 0.0);  // still opposing the old motion for one tick
  double later = 0.0;
  for (int k = 1; k < 200; ++k) later = n(1.0 + 1e-3 * k, 0.0, -0.5);
  EXPECT_GT(later, 0.0);
}

TEST(InventedEffects, DriftChangesTheLevelFromRunToRun) {
  const InventedEffect e = parse_invented_effect("drift:level_v=0.01,drift=0.5");
  for (std::size_t run : {0u, 1u, 4u}) {
    const double frac = std::fmod(0.618 * static_cast<double>(run + 1), 1.0);
    const double level = 0.01 * (1.0 + 0.5 * (2.0 * frac - 1.0));
    const double v = 0.3;
    EXPECT_NEAR(invented_torque(e, run)(0.0, 0.0, v), -level * v / std::sqrt(v * v + 0.01), 1e-15);
  }
}

TEST(InventedEffects, HysteresisLagsTheVelocity) {
  const InventedEffect e = parse_invented_effect("hysteresis:level_v=0.01,lag_s=0.02,velocity_rad_s=0.05");
  auto n = invented_torque(e, 0);
  n(0.0, 0.0, 0.0);  // the lag starts at the first velocity
  double out = 0.0;
  for (int k = 1; k <= 20; ++k) out = n(1e-3 * k, 0.0, 1.0);
  // v_lag after 20 ms of θ̇ = 1 with τ = 20 ms: 1 − e^{−1}.
  const double lag = 1.0 - std::exp(-1.0);
  EXPECT_NEAR(out, -0.01 * lag / std::sqrt(lag * lag + 0.0025), 1e-12);
}

TEST(InventedEffects, SpecsReadBackAndBadOnesNameTheOption) {
  const InventedEffect e = parse_invented_effect("lugre:level_v=0.005,stiffness_v_per_rad=20");
  EXPECT_EQ(e.text(), "lugre:level_v=0.005,breakaway_v=0.016,velocity_rad_s=0.1,stiffness_v_per_rad=20");
  const InventedEffect back = parse_invented_effect(e.text());
  EXPECT_EQ(back.stiffness_v_per_rad, 20.0);
  EXPECT_EQ(InventedEffect{}.text(), "none");
  auto field = [](const std::string& spec) {
    try {
      parse_invented_effect(spec, "--invented");
    } catch (const Error& err) {
      return err.field();
    }
    return std::string();
  };
  EXPECT_EQ(field("stribeck"), "--invented");
  EXPECT_EQ(field("drift:lag_s=1"), "--invented");  // not a parameter of drift
  EXPECT_EQ(field("lugre:level_v=abc"), "--invented");
  EXPECT_EQ(field("lugre:level_v=-1"), "--invented lugre:level_v");
  EXPECT_EQ(field("drift:drift=1.5"), "--invented drift:drift");
}

TEST(InventedEffects, APlanAppliesItWithoutRecordingIt) {
  ExperimentPlanOptions o = paper_plan_options(3);
  o.sine_freqs_hz = {2.0};
  o.sine_poses = {o.sine_poses.front()};
  o.square_poses = {};
  o.sine_settle_s = 1.0;
  o.sine_steady_s = 1.0;
  o.plant.measurement.noise_std_rad = 0.0;
  const ExperimentPlan plain = make_experiment_plan(o);
  o.invented = parse_invented_effect("hysteresis:level_v=0.02");
  const ExperimentPlan with = make_experiment_plan(o);
  const RunData a = simulate_planned_run(plain, 0), b = simulate_planned_run(with, 0);
  ASSERT_EQ(a.size(), b.size());
  double diff = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) diff = std::max(diff, std::abs(a.theta[k] - b.theta[k]));
  EXPECT_GT(diff, 1e-3);                       // the joint felt it
  EXPECT_TRUE(b.extra_columns.empty());        // no column says it
  const std::string truth = truth_json(with);
  EXPECT_NE(truth.find("\"invented_effect\""), std::string::npos) << truth;
  EXPECT_NE(truth.find("hysteresis:level_v=0.02"), std::string::npos) << truth;
}

}  // namespace
}  // namespace alphainv
