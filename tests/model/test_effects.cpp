#include "alphainv/model/effects.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "alphainv/error.hpp"
#include "alphainv/model/plant_input.hpp"

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
  EXPECT_EQ(active_effects(e).size(), kEffectKindCount - 1);
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
  // Each friction term has its own smoothing ε, the external disturbance its window; no other
  // effect has a modelling choice.
  const std::set<EffectKind> with_smoothing = {
      EffectKind::kCoulombFriction, EffectKind::kStribeckFriction, EffectKind::kAsymmetricFriction,
      EffectKind::kPositionDependentFriction, EffectKind::kExternalDisturbance};
  // The discovered term: its four scales (ε, v_r, θ_c, θ_r) and its memory terms' three (T_f,
  // δ, ε_f).
  for (EffectKind k : kAllEffectKinds) {
    const std::size_t choices = with_smoothing.count(k) ? 1u : k == EffectKind::kDiscovered ? 7u : 0u;
    EXPECT_EQ(effect_parameters(k, true).size(), effect_parameters(k).size() + choices)
        << effect_name(k);
  }
}

TEST(Effects, TheKindsAreCountedByTheEnumSentinel) {
  EXPECT_EQ(kEffectKindCount, 13u);
  EXPECT_EQ(kAllEffectKinds.size(), kEffectCatalogue.size());
  for (std::size_t k = 0; k < kEffectKindCount; ++k) {
    EXPECT_EQ(kAllEffectKinds[k], static_cast<EffectKind>(k));
    EXPECT_EQ(kEffectCatalogue[k].kind, kAllEffectKinds[k]) << k;  // the table in enum order
  }
}

TEST(Effects, FrictionGeneralisationsMatchTheirFormulas) {
  const double eps = 0.01, th = 0.05;
  // Stribeck: Fc + (Fs − Fc)·exp(−(θ̇/v_s)²) times −tanh(θ̇/ε).
  Effects s;
  s.stribeck_coulomb_v = 0.02;
  s.stribeck_breakaway_v = 0.05;
  s.stribeck_velocity_rad_s = 0.1;
  s.stribeck_smoothing_rad_s = eps;
  for (double v : {-1.0, -0.1, 0.003, 0.05, 0.2, 2.0}) {
    const double expected = -std::tanh(v / eps) * (0.02 + 0.03 * std::exp(-(v / 0.1) * (v / 0.1)));
    EXPECT_NEAR(effect_torque(s, th, v), expected, 1e-15) << v;
  }
  EXPECT_NEAR(effect_torque(s, th, 0.05), -std::tanh(5.0) * (0.02 + 0.03 * std::exp(-0.25)), 1e-15);
  // Breakaway level just above ε, the sliding level far above v_s.
  EXPECT_NEAR(effect_torque(s, th, 0.05), -0.0434, 1e-3);
  EXPECT_NEAR(effect_torque(s, th, -3.0), 0.02, 1e-12);
  // Stribeck with Fs = Fc is Coulomb friction.
  Effects sc = s, c;
  sc.stribeck_breakaway_v = 0.02;
  c.coulomb_v = 0.02;
  c.coulomb_smoothing_rad_s = eps;
  for (double v : {-0.5, -0.02, 0.001, 0.3}) EXPECT_NEAR(effect_torque(sc, th, v), effect_torque(c, th, v), 1e-15);

  // Asymmetric: Fc⁺ forward, Fc⁻ backward, and half the viscous difference as Δb/2·|θ̇|.
  Effects a;
  a.asymmetric_coulomb_pos_v = 0.03;
  a.asymmetric_coulomb_neg_v = 0.01;
  a.asymmetric_viscous_diff_v_s = 0.004;
  a.asymmetric_smoothing_rad_s = eps;
  EXPECT_NEAR(effect_torque(a, th, 2.0), -0.03 - 0.5 * 0.004 * 2.0, 1e-12);
  EXPECT_NEAR(effect_torque(a, th, -2.0), 0.01 - 0.5 * 0.004 * 2.0, 1e-12);
  const double sg = std::tanh(0.004 / eps);
  EXPECT_NEAR(effect_torque(a, th, 0.004),
              -sg * (0.03 * 0.5 * (1 + sg) + 0.01 * 0.5 * (1 - sg)) - 0.5 * 0.004 * 0.004 * sg, 1e-15);

  // Position-dependent: the level Fc0 + s·θ, not below 0.
  Effects p;
  p.position_coulomb_v = 0.02;
  p.position_slope_v_per_rad = 0.14;
  p.position_smoothing_rad_s = eps;
  EXPECT_NEAR(effect_torque(p, 0.07, 1.0), -(0.02 + 0.14 * 0.07), 1e-12);
  EXPECT_NEAR(effect_torque(p, -0.07, -1.0), 0.02 - 0.14 * 0.07, 1e-12);
  EXPECT_EQ(effect_torque(p, -0.5, 1.0), 0.0);  // the level clamped at 0
  EXPECT_EQ(effect_spec(EffectKind::kStribeckFriction).refines, EffectKind::kCoulombFriction);
  EXPECT_EQ(effect_spec(EffectKind::kAsymmetricFriction).refines, EffectKind::kCoulombFriction);
  EXPECT_EQ(effect_spec(EffectKind::kPositionDependentFriction).refines, EffectKind::kCoulombFriction);
  EXPECT_EQ(effect_spec(EffectKind::kCoulombFriction).refines, EffectKind::kNone);
  // Each by its table name (what omni_gen --effect and model.json read).
  Effects from_spec;
  apply_effect_spec("stribeck_friction:stribeck_coulomb_v=0.02,stribeck_breakaway_v=0.05,"
                    "stribeck_velocity_rad_s=0.1",
                    from_spec);
  EXPECT_EQ(active_effects(from_spec), std::vector<EffectKind>{EffectKind::kStribeckFriction});
  EXPECT_EQ(from_spec.stribeck_breakaway_v, 0.05);
  apply_effect_spec("position_dependent_friction=0.02", from_spec);
  EXPECT_EQ(from_spec.position_coulomb_v, 0.02);
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

// --- the effect table ----------------------------------------------------------------------------

TEST(EffectTable, EntriesAreInKindOrderWithUniqueNamesAndMembers) {
  std::set<std::string> names, params;
  std::vector<double Effects::*> members;
  for (std::size_t i = 0; i < kEffectCatalogue.size(); ++i) {
    const EffectSpec& s = kEffectCatalogue[i];
    EXPECT_EQ(static_cast<std::size_t>(s.kind), i) << s.name;
    EXPECT_EQ(kAllEffectKinds[i], s.kind);
    EXPECT_TRUE(names.insert(s.name).second) << s.name;
    EXPECT_LE(s.parameter_count, kMaxEffectParameters);
    EXPECT_FALSE(s.active(Effects{})) << s.name << " is on by default";
    for (const EffectParameter& p : s) {
      EXPECT_TRUE(params.insert(p.name).second) << p.name;
      EXPECT_EQ(std::count(members.begin(), members.end(), p.member), 0) << p.name;
      members.push_back(p.member);
      EXPECT_NE(p.search_bounds, nullptr) << p.name;
      EXPECT_NE(p.search_step, nullptr) << p.name;
    }
    if (s.kind == EffectKind::kNone) {
      EXPECT_EQ(s.role, EffectRole::kNone);
      continue;
    }
    EXPECT_NE(s.role, EffectRole::kNone) << s.name;
    EXPECT_NE(s.search_grid, nullptr) << s.name;
    EXPECT_GT(s.sweep_magnitudes[0], 0.0) << s.name;
    EXPECT_FALSE(s.parameters[0].modelling_choice) << s.name << ": the first parameter is fitted";
    // Torque effects are started by regression; the command-path ones by a scan of the grid.
    EXPECT_EQ(s.equation_error_start != nullptr, s.role == EffectRole::kTorque) << s.name;
    // Setting the first parameter to its sweep magnitude switches the effect on.
    Effects e;
    e.*(s.parameters[0].member) = s.sweep_magnitudes[0];
    EXPECT_TRUE(s.active(e)) << s.name;
    EXPECT_EQ(active_effects(e), std::vector<EffectKind>{s.kind});
  }
  // 50 members of Effects (22 of the named effects, 2 of the external disturbance, 17 + 4 + 2 + 3
  // of the discovered term), each in exactly one entry.
  EXPECT_EQ(members.size(), 50u);
  EXPECT_EQ(sizeof(Effects), 50 * sizeof(double));
}

TEST(EffectTable, SearchBoundsGridsAndStepsFollowTheDataScales) {
  const EffectScales sc{0.5, 2.0, -0.07, 0.07};
  for (const EffectSpec& s : kEffectCatalogue) {
    if (s.kind == EffectKind::kNone) continue;
    std::vector<double> start;
    for (const EffectParameter& p : effect_parameters(s.kind)) {
      double lo = 0, hi = 0;
      p.search_bounds(sc, p.name == std::string("cogging_period_rad") ? 0.02 : 0.01, lo, hi);
      EXPECT_LT(lo, hi) << p.name;
      start.push_back(std::clamp(0.01, lo, hi));
    }
    const auto grid = s.search_grid(sc, start);
    ASSERT_FALSE(grid.empty()) << s.name;
    for (const auto& point : grid) EXPECT_EQ(point.size(), start.size()) << s.name;
  }
  // The numbers diagnose searches with.
  double lo = 0, hi = 0;
  effect_spec(EffectKind::kCoulombFriction).parameters[0].search_bounds(sc, 0.0, lo, hi);
  EXPECT_EQ(lo, 0.0);
  EXPECT_EQ(hi, 1.0);  // 2 v_max
  effect_spec(EffectKind::kCogging).parameters[1].search_bounds(sc, 0.1, lo, hi);
  EXPECT_DOUBLE_EQ(lo, 0.1 / 1.3);
  EXPECT_DOUBLE_EQ(hi, 0.1 / 1.3 * 1.01);  // a third of the motion range is below x/1.3: a sliver
  const auto sat = effect_spec(EffectKind::kSaturation).search_grid(sc, {});
  ASSERT_EQ(sat.size(), 5u);
  EXPECT_DOUBLE_EQ(sat[0][0], 0.95 * 0.5);
  const auto delay = effect_spec(EffectKind::kTimeDelay).search_grid(sc, {0.1});
  ASSERT_EQ(delay.size(), 7u);  // the start is replaced by the absolute grid
  EXPECT_EQ(delay.front()[0], 0.0005);
  EXPECT_EQ(delay.back()[0], 0.032);
  // Gravity's grid: the start, then springs of either sign times kp, with and without the offset.
  const auto grav = effect_spec(EffectKind::kGravity).search_grid(sc, {0.1, 0.05});
  ASSERT_EQ(grav.size(), 23u);
  EXPECT_DOUBLE_EQ(grav[1][0], -0.3 * 2.0);
  EXPECT_EQ(grav[1][1], 0.0);
  EXPECT_EQ(grav[2][1], 0.05);
  EXPECT_DOUBLE_EQ(effect_spec(EffectKind::kGravity).parameters[0].search_step(sc, 9.0, {0.1, 0.05}),
                   0.2);  // a tenth of kp
}

TEST(EffectTable, GravityIsSearchedAsASpringAndAnOffset) {
  const EffectSpec& g = effect_spec(EffectKind::kGravity);
  ASSERT_NE(g.to_search, nullptr);
  ASSERT_NE(g.from_search, nullptr);
  const EffectScales sc{0.5, 2.0, -0.07, 0.07};
  std::vector<double> x{0.3, 0.2}, lower, upper;  // g, θ0
  g.to_search(sc, x, lower, upper);
  EXPECT_DOUBLE_EQ(x[0], 0.3 * std::cos(0.2));  // k
  EXPECT_DOUBLE_EQ(x[1], 0.3 * std::sin(0.2));  // o
  EXPECT_EQ(lower, (std::vector<double>{-1.0, -0.5}));
  EXPECT_EQ(upper, (std::vector<double>{1.0, 0.5}));
  Effects e;
  g.from_search(x.data(), e);
  EXPECT_NEAR(e.gravity_v, 0.3, 1e-15);
  EXPECT_NEAR(e.gravity_theta0_rad, 0.2, 1e-15);
  // −k·sin θ − o·cos θ is the gravity term −g·sin(θ + θ0).
  for (double th : {-0.07, 0.0, 0.05}) {
    EXPECT_NEAR(effect_torque(e, th, 0.0), -x[0] * std::sin(th) - x[1] * std::cos(th), 1e-15);
  }
}

/// A TorqueRegression over synthetic samples, solved by the normal equations (a test double of
/// diagnose's QR).
class SyntheticTorque final : public TorqueRegression {
 public:
  SyntheticTorque(const Effects& truth, double offset_v) {
    for (int k = 0; k < 2000; ++k) {
      const double t = 0.001 * k;
      theta_.push_back(0.07 * std::sin(2 * 3.14159265358979 * 1.3 * t) + 0.01 * std::sin(17.0 * t));
      theta_dot_.push_back(0.07 * 2 * 3.14159265358979 * 1.3 * std::cos(2 * 3.14159265358979 * 1.3 * t) +
                           0.17 * std::cos(17.0 * t));
      n_hat_.push_back(effect_torque(truth, theta_.back(), theta_dot_.back()) + offset_v);
    }
  }
  std::size_t size() const override { return n_hat_.size(); }
  const std::vector<double>& theta() const override { return theta_; }
  const std::vector<double>& theta_dot() const override { return theta_dot_; }
  std::vector<double> fit(const std::vector<std::vector<double>>& x, double* r2) const override {
    const std::size_t p = x.size();
    std::vector<double> a(p * p, 0.0), b(p, 0.0);
    for (std::size_t i = 0; i < p; ++i) {
      for (std::size_t k = 0; k < size(); ++k) b[i] += x[i][k] * n_hat_[k];
      for (std::size_t j = 0; j < p; ++j)
        for (std::size_t k = 0; k < size(); ++k) a[i * p + j] += x[i][k] * x[j][k];
    }
    for (std::size_t c = 0; c < p; ++c) {  // Gauss-Jordan (tiny, well-conditioned systems)
      for (std::size_t r = 0; r < p; ++r) {
        if (r == c) continue;
        const double f = a[r * p + c] / a[c * p + c];
        for (std::size_t j = 0; j < p; ++j) a[r * p + j] -= f * a[c * p + j];
        b[r] -= f * b[c];
      }
    }
    for (std::size_t c = 0; c < p; ++c) b[c] /= a[c * p + c];
    if (r2 != nullptr) {
      double mean = 0, tot = 0, res = 0;
      for (double y : n_hat_) mean += y / static_cast<double>(size());
      for (std::size_t k = 0; k < size(); ++k) {
        double yhat = 0;
        for (std::size_t j = 0; j < p; ++j) yhat += b[j] * x[j][k];
        tot += (n_hat_[k] - mean) * (n_hat_[k] - mean);
        res += (n_hat_[k] - yhat) * (n_hat_[k] - yhat);
      }
      *r2 = tot > 0 ? 1.0 - res / tot : std::numeric_limits<double>::quiet_NaN();
    }
    return b;
  }

 private:
  std::vector<double> theta_, theta_dot_, n_hat_;
};

TEST(EffectTable, EquationErrorStartsRecoverTheTorqueTerms) {
  const EffectScales sc{0.5, 2.0, -0.08, 0.08};
  {
    Effects truth;
    truth.coulomb_v = 0.012;
    truth.coulomb_smoothing_rad_s = 0.01;
    Effects e;
    e.coulomb_smoothing_rad_s = 0.01;
    effect_spec(EffectKind::kCoulombFriction).equation_error_start(SyntheticTorque(truth, 0.003), sc, e);
    EXPECT_NEAR(e.coulomb_v, 0.012, 1e-12);  // the constant column takes the 0.003 offset
  }
  {
    Effects truth;
    truth.gravity_v = 0.25;
    truth.gravity_theta0_rad = -0.4;
    Effects e;
    effect_spec(EffectKind::kGravity).equation_error_start(SyntheticTorque(truth, 0.0), sc, e);
    EXPECT_NEAR(e.gravity_v, 0.25, 1e-10);
    EXPECT_NEAR(e.gravity_theta0_rad, -0.4, 1e-10);
  }
  {
    Effects truth;
    truth.offset_v = -0.03;
    Effects e;
    effect_spec(EffectKind::kOffsetTorque).equation_error_start(SyntheticTorque(truth, 0.0), sc, e);
    EXPECT_NEAR(e.offset_v, -0.03, 1e-14);
  }
  {
    // Cogging on the start's log grid of periods: the nearest grid period, an amplitude near a.
    Effects truth;
    truth.cogging_v = 0.02;
    truth.cogging_period_rad = 0.016;
    truth.cogging_phase_rad = 0.7;
    Effects e;
    effect_spec(EffectKind::kCogging).equation_error_start(SyntheticTorque(truth, 0.0), sc, e);
    EXPECT_NEAR(e.cogging_period_rad, 0.016, 0.016 * 0.04);  // grid ratio (400/3)^(1/79) ≈ 1.064
    EXPECT_GT(e.cogging_v, 0.005);
  }
}

TEST(EffectTable, SpecsReadAndWriteEveryEffect) {
  Effects e;
  apply_effect_spec("cogging:cogging_v=0.02,cogging_period_rad=0.015", e);
  EXPECT_EQ(e.cogging_v, 0.02);
  EXPECT_EQ(e.cogging_period_rad, 0.015);
  EXPECT_EQ(e.cogging_phase_rad, 0.0);  // a parameter not given takes its default
  apply_effect_spec("deadzone=0.01", e);  // the short form sets the first parameter
  EXPECT_EQ(e.deadzone_v, 0.01);
  apply_effect_spec("time_delay=0.004", e);
  EXPECT_EQ(e.delay_s, 0.004);
  EXPECT_EQ(active_effects(e), (std::vector<EffectKind>{EffectKind::kCogging, EffectKind::kTimeDelay,
                                                        EffectKind::kDeadzone}));
  // Every effect written as a spec reads back to the same doubles.
  Effects all;
  all.coulomb_v = 0.1 / 3.0;
  all.offset_v = -0.0264075031;
  all.gravity_v = 0.3;
  all.gravity_theta0_rad = 0.221;
  all.cogging_v = 0.0187;
  all.cogging_period_rad = 0.01994;
  all.cogging_phase_rad = -1.0 / 7.0;
  all.delay_s = 0.004;
  all.saturation_v = 0.12 / 1.3;
  all.deadzone_v = 0.013;
  Effects back;
  for (EffectKind k : active_effects(all)) apply_effect_spec(effect_spec_text(all, k), back);
  for (const EffectSpec& s : kEffectCatalogue)
    for (const EffectParameter& p : s) EXPECT_EQ(back.*p.member, all.*p.member) << p.name;
  EXPECT_EQ(effect_spec_text(all, EffectKind::kOffsetTorque), "offset_torque:offset_v=-0.0264075031");
}

TEST(EffectTable, BadSpecsNameTheOptionAndSayWhy) {
  const auto message = [](const std::string& spec) {
    Effects e;
    try {
      apply_effect_spec(spec, e);
    } catch (const Error& err) {
      // The option, or for a value out of range the option's parameter ("--effect NAME:PARAM").
      const std::string name = spec.substr(0, spec.find_first_of(":="));
      EXPECT_TRUE(err.field() == "--effect " + spec || err.field().rfind("--effect " + name + ":", 0) == 0)
          << err.field();
      return std::string(err.what());
    }
    return std::string("no throw");
  };
  EXPECT_NE(message("friction=0.1").find("unknown effect \"friction\""), std::string::npos);
  EXPECT_NE(message("none=1").find("\"none\" is not an effect"), std::string::npos);
  EXPECT_NE(message("gravity:g=0.1").find("PARAM one of gravity_v, gravity_theta0_rad"),
            std::string::npos);
  EXPECT_NE(message("offset_torque:offset_v=abc").find("expected a number for offset_v"),
            std::string::npos);
  EXPECT_NE(message("deadzone=0").find("leave deadzone off"), std::string::npos);
  EXPECT_NE(message("time_delay=2").find("0 <= delay_s <= 1 s"), std::string::npos);
  Effects e;
  try {
    apply_effect_spec("time_delay=2", e);
  } catch (const Error& err) {
    EXPECT_EQ(err.field(), "--effect time_delay:delay_s");
  }
  EXPECT_NE(message("coulomb_friction").find("expected NAME:PARAM=VALUE"), std::string::npos);
}

TEST(Effects, AnExternalDisturbanceIsATorqueOfTimeNotOfTheState) {
  Effects e;
  apply_effect_spec("external_disturbance=0.01", e);
  EXPECT_TRUE(effect_active(e, EffectKind::kExternalDisturbance));
  EXPECT_EQ(effect_spec(EffectKind::kExternalDisturbance).role, EffectRole::kTimeSeries);
  EXPECT_EQ(e.disturbance_window_s, 0.05);
  // No term of the state: the series enters the one plant input as the known d(t).
  EXPECT_EQ(effect_torque(e, 0.03, 0.5), 0.0);
  EXPECT_EQ(plant_torque(e, 1.0, 0.03, 0.5, KnownInputs{0.02, true}), 0.02);
  EXPECT_EQ(plant_input(e, 1.0, 0.1, 0.03, 0.5, KnownInputs{0.02, true}), 0.1 + 0.02);
}

}  // namespace
}  // namespace alphainv

namespace alphainv {
namespace {

// --- the discovered term -------------------------------------------------------------------------

TEST(DiscoveredTerm, TorqueIsTheSumOfItsTermsOverTheLibrary) {
  Effects e;
  e.discovered_smoothing_rad_s = 0.02;
  e.discovered_velocity_scale_rad_s = 1.5;
  e.discovered_position_center_rad = 0.01;
  e.discovered_position_scale_rad = 0.07;
  e.discovered_sign_v = -0.004;
  e.discovered_stribeck_mid_v = -0.003;
  e.discovered_sin2_v = 0.002;
  e.discovered_vel_abs_vel_v = 0.001;
  EXPECT_TRUE(effect_active(e, EffectKind::kDiscovered));
  EXPECT_EQ(active_effects(e), std::vector<EffectKind>{EffectKind::kDiscovered});
  const double pi = 3.14159265358979323846;
  for (double th : {-0.06, 0.0, 0.03}) {
    for (double v : {-2.0, -0.1, 0.01, 0.3, 3.0}) {
      const double sg = std::tanh(v / 0.02), w = v / 1.5, x = (th - 0.01) / 0.07;
      const double expected = -0.004 * sg - 0.003 * sg * std::exp(-(w / 0.15) * (w / 0.15)) +
                              0.002 * std::sin(2 * pi * x) + 0.001 * w * std::abs(w);
      EXPECT_NEAR(effect_torque(e, th, v), expected, 1e-15) << th << " " << v;
    }
  }
  // The library's functions in their order, at one point.
  std::array<double, kDiscoveredTerms> phi{};
  discovered_basis(e, 0.045, 0.75, phi);
  const double sg = std::tanh(0.75 / 0.02), w = 0.5, x = 0.5;
  const std::array<double, kDiscoveredTerms> want = {
      1.0, sg, w, w * sg, w * w, w * w * w, sg * std::exp(-100.0), sg * std::exp(-w * w / 0.0225),
      sg * std::exp(-1.0), x, sg * x, std::sin(pi * x), std::cos(pi * x), std::sin(2 * pi * x),
      std::cos(2 * pi * x), std::sin(3 * pi * x), std::cos(3 * pi * x)};
  for (std::size_t k = 0; k < kDiscoveredTerms; ++k) EXPECT_NEAR(phi[k], want[k], 1e-15) << k;
  // The coefficient members are the table's first parameters, in library order.
  const EffectSpec& spec = effect_spec(EffectKind::kDiscovered);
  ASSERT_EQ(spec.parameter_count, kDiscoveredTerms + 9);
  for (std::size_t k = 0; k < kDiscoveredTerms; ++k)
    EXPECT_EQ(spec.parameters[k].member, kDiscoveredLibrary[k].coefficient) << k;
  // … then its four scales, then the two memory coefficients (diagnose names them by this order).
  EXPECT_EQ(spec.parameters[kDiscoveredTerms + 4].member, &Effects::discovered_lag_sign_v);
  EXPECT_EQ(spec.parameters[kDiscoveredTerms + 5].member, &Effects::discovered_dahl_v);
  EXPECT_FALSE(spec.candidate);
  for (const EffectSpec& s : kEffectCatalogue) {
    if (s.kind != EffectKind::kDiscovered) {
      EXPECT_TRUE(s.candidate) << s.name;
    }
  }
}

TEST(DiscoveredTerm, EquationAndSpecListOnlyTheNonZeroTerms) {
  Effects e;
  e.discovered_smoothing_rad_s = 0.015;
  e.discovered_velocity_scale_rad_s = 1.5;
  e.discovered_position_scale_rad = 0.07;
  e.discovered_sign_v = -0.0041;
  e.discovered_pos_v = 0.002;
  EXPECT_EQ(discovered_equation(e),
            "n = -0.0041 sigma + 0.002 x; sigma = tanh(theta'/0.015), w = theta'/1.5, "
            "x = (theta - 0)/0.07");
  EXPECT_EQ(discovered_equation(Effects{}), "n = 0");
  const std::string spec = effect_spec_text(e, EffectKind::kDiscovered);
  EXPECT_EQ(spec.find("discovered_one_v"), std::string::npos) << spec;  // a zero term is left out
  Effects back;
  apply_effect_spec(spec, back);
  for (const EffectParameter& p : effect_spec(EffectKind::kDiscovered)) EXPECT_EQ(back.*p.member, e.*p.member) << p.name;
  // A scale out of range names its field.
  Effects bad = e;
  bad.discovered_velocity_scale_rad_s = 0.0;
  EXPECT_THROW(validate_effects(bad), Error);
  EXPECT_EQ(effects_text(e).find("discovered_one_v"), std::string::npos);
}

TEST(DiscoveredMemory, TheLagIsExactForAHeldVelocityAndTheDahlStateForAnyStepping) {
  Effects e;
  e.discovered_lag_s = 0.015;
  e.discovered_dahl_rad = 2e-3;
  e.discovered_lag_smoothing_rad_s = 0.01;
  e.discovered_lag_sign_v = -0.006;
  e.discovered_dahl_v = -0.004;
  EXPECT_TRUE(discovered_memory_active(e));
  EXPECT_FALSE(discovered_active(e));  // the library's terms are all 0
  EXPECT_TRUE(effect_active(e, EffectKind::kDiscovered));
  EXPECT_EQ(effect_torque(e, 0.1, 0.3), 0.0);  // no memory in the function of the state
  // A velocity step 0 → 0.2 held: f(t) = 0.2·(1 − exp(−t/T_f)) at every tick, to rounding.
  DiscoveredMemory m;
  m.reset(0.0);
  const double T = 1e-3, lambda = DiscoveredMemory::lag_decay(e, T);
  EXPECT_DOUBLE_EQ(lambda, std::exp(-T / 0.015));
  for (int k = 1; k <= 60; ++k) {
    m.advance(e, lambda, 0.2 * T, 0.2);
    EXPECT_NEAR(m.lag_velocity_rad_s, 0.2 * (1.0 - std::exp(-k * T / 0.015)), 1e-15) << k;
  }
  // The Dahl state after a monotonic displacement D from z0: 1 − (1 − z0)·exp(−D/δ), however the
  // displacement is cut into ticks; a reversal turns it towards −1.
  const double z0 = m.dahl_state;
  EXPECT_NEAR(z0, 1.0 - std::exp(-60 * 0.2 * T / 2e-3), 1e-12);
  DiscoveredMemory a, b;
  a.reset(0.0), b.reset(0.0);
  a.advance(e, lambda, 3e-3, 1.0);
  for (int k = 0; k < 7; ++k) b.advance(e, lambda, 3e-3 / 7, 1.0);
  EXPECT_NEAR(a.dahl_state, 1.0 - std::exp(-1.5), 1e-15);
  EXPECT_NEAR(b.dahl_state, a.dahl_state, 1e-14);
  a.advance(e, lambda, -1e-3, -1.0);  // back by δ/2: z = −1 + (1 + z)·exp(−1/2)
  EXPECT_NEAR(a.dahl_state, -1.0 + (2.0 - std::exp(-1.5)) * std::exp(-0.5), 1e-15);
  a.advance(e, lambda, 0.0, 0.0);  // no displacement: z held
  EXPECT_NEAR(a.dahl_state, -1.0 + (2.0 - std::exp(-1.5)) * std::exp(-0.5), 1e-15);
  // The torque: c_f·tanh(f/ε) + c_z·z.
  EXPECT_NEAR(m.torque(e), -0.006 * std::tanh(m.lag_velocity_rad_s / 0.01) - 0.004 * m.dahl_state,
              1e-17);
  // In the equation, the reading's file form and the table (after the four scales).
  const std::string eq = discovered_equation(e);
  EXPECT_NE(eq.find("-0.006 tanh(f/eps_f) - 0.004 z"), std::string::npos) << eq;
  EXPECT_NE(eq.find("lag of 0.015 s"), std::string::npos) << eq;
  const std::string spec = effect_spec_text(e, EffectKind::kDiscovered);
  Effects back;
  apply_effect_spec(spec, back);
  EXPECT_EQ(back.discovered_lag_sign_v, -0.006) << spec;
  EXPECT_EQ(back.discovered_dahl_rad, 2e-3) << spec;
  Effects bad = e;
  bad.discovered_lag_s = 0.0;
  EXPECT_THROW(validate_effects(bad), Error);
}

// torque_depends_on_state() must agree with effect_torque() for every parameter of the catalogue:
// a parameter that makes n vary with θ or θ̇ makes it true, a constant term (offset, the discovered
// term's c_1) leaves it false. A new torque term missing from torque_depends_on_state() fails here.
TEST(Effects, TorqueDependsOnStateExactlyWhenEffectTorqueVariesWithTheState) {
  const double states[][2] = {{0.0, 0.0}, {0.3, 0.05}, {-0.7, -0.4}, {1.1, 2.0}, {0.013, -0.002}};
  int constant_parameters = 0, state_parameters = 0;
  for (EffectKind kind : kAllEffectKinds) {
    const EffectSpec& spec = effect_spec(kind);
    if (spec.role != EffectRole::kTorque) continue;
    for (std::size_t i = 0; i < spec.parameter_count; ++i) {
      const EffectParameter& p = spec.parameters[i];
      if (p.modelling_choice) continue;
      Effects e;
      e.*p.member = 0.3;
      const double n0 = effect_torque(e, states[0][0], states[0][1]);
      bool varies = false;
      for (const auto& s : states) varies = varies || effect_torque(e, s[0], s[1]) != n0;
      EXPECT_EQ(torque_depends_on_state(e), varies) << spec.name << "." << p.name;
      if (varies) ++state_parameters;
      else if (n0 != 0.0) ++constant_parameters;  // a constant term (else: a scale alone, n = 0)
    }
  }
  EXPECT_EQ(constant_parameters, 2);  // offset_v and discovered_one_v
  EXPECT_GE(state_parameters, 20);
  EXPECT_FALSE(torque_depends_on_state(Effects{}));
}

// torque_depends_on_velocity(): true exactly for the parameters that make n vary with θ̇ at a
// fixed θ (the friction forms and the discovered term's terms in σ or w).
TEST(Effects, TorqueDependsOnVelocityExactlyWhenEffectTorqueVariesWithThetaDot) {
  const double theta_dots[] = {0.0, 0.05, -0.4, 2.0, -0.002};
  int velocity_parameters = 0, other_parameters = 0;
  for (EffectKind kind : kAllEffectKinds) {
    const EffectSpec& spec = effect_spec(kind);
    if (spec.role != EffectRole::kTorque) continue;
    for (std::size_t i = 0; i < spec.parameter_count; ++i) {
      const EffectParameter& p = spec.parameters[i];
      if (p.modelling_choice) continue;
      Effects e;
      e.*p.member = 0.3;
      bool varies = false;
      for (double theta : {0.0, 0.7, -1.3}) {
        const double n0 = effect_torque(e, theta, theta_dots[0]);
        for (double w : theta_dots) varies = varies || effect_torque(e, theta, w) != n0;
      }
      EXPECT_EQ(torque_depends_on_velocity(e), varies) << spec.name << "." << p.name;
      if (varies) ++velocity_parameters;
      else if (torque_depends_on_state(e)) ++other_parameters;
    }
  }
  EXPECT_GE(velocity_parameters, 14);
  EXPECT_EQ(other_parameters, 9);  // gravity g, cogging a; the discovered x and six sin/cos terms
}

// EffectSpec::take_in: a Coulomb level c moved into a generalisation is the same torque, both
// from the generalisation at zero (its start from the parent's fit in diagnose) and added onto
// one already fitted (a parent named in an earlier round taken in); an offset is no such form.
TEST(Effects, AGeneralisationTakesInACoulombLevelAsTheSameTorque) {
  int with_take_in = 0;
  for (EffectKind kind : kAllEffectKinds) {
    const EffectSpec& spec = effect_spec(kind);
    if (spec.take_in == nullptr) continue;
    ++with_take_in;
    EXPECT_TRUE(spec.generalises(EffectKind::kCoulombFriction)) << spec.name;
    Effects fitted;  // the generalisation fitted, smoothing as diagnose's initial model sets it
    fitted.stribeck_coulomb_v = 0.01, fitted.stribeck_breakaway_v = 0.03;
    fitted.stribeck_velocity_rad_s = 0.2;
    fitted.asymmetric_coulomb_pos_v = 0.02, fitted.asymmetric_coulomb_neg_v = 0.012;
    fitted.asymmetric_viscous_diff_v_s = 0.001;
    fitted.position_coulomb_v = 0.015, fitted.position_slope_v_per_rad = 0.05;
    fitted.coulomb_smoothing_rad_s = fitted.stribeck_smoothing_rad_s = 0.01;
    fitted.asymmetric_smoothing_rad_s = fitted.position_smoothing_rad_s = 0.01;
    Effects only;  // this effect alone
    only.coulomb_smoothing_rad_s = 0.01;
    for (const auto& p : effect_parameters(kind, true)) only.*(p.member) = fitted.*(p.member);
    Effects at_zero = only;  // its levels at zero, its shape (v_s) kept
    for (const auto& p : effect_parameters(kind)) {
      if (p.check != ParameterCheck::kPositiveIfActive) at_zero.*(p.member) = 0.0;
    }
    const double c = 0.007;
    Effects coulomb;
    coulomb.coulomb_v = c, coulomb.coulomb_smoothing_rad_s = 0.01;
    Effects both = only;  // named on top of a Coulomb level
    both.coulomb_v = c;
    ASSERT_TRUE(spec.take_in(EffectKind::kCoulombFriction, c, at_zero)) << spec.name;
    Effects taken = only;
    ASSERT_TRUE(spec.take_in(EffectKind::kCoulombFriction, c, taken)) << spec.name;
    Effects scratch = only;
    EXPECT_FALSE(spec.take_in(EffectKind::kOffsetTorque, c, scratch)) << spec.name;
    for (double theta : {-0.05, 0.0, 0.04}) {
      for (double w : {-1.5, -0.3, -0.004, 0.0, 0.002, 0.1, 0.8}) {
        EXPECT_NEAR(effect_torque(at_zero, theta, w), effect_torque(coulomb, theta, w), 1e-15)
            << spec.name << " from zero, theta " << theta << ", theta' " << w;
        EXPECT_NEAR(effect_torque(taken, theta, w), effect_torque(both, theta, w), 1e-15)
            << spec.name << " on top, theta " << theta << ", theta' " << w;
      }
    }
  }
  EXPECT_EQ(with_take_in, 3);  // Stribeck, asymmetric and position-dependent friction
}

}  // namespace
}  // namespace alphainv
