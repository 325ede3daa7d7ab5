#include "alphainv/device/compensator.hpp"

#include <cmath>

#include "alphainv/error.hpp"
#include "alphainv/model/detail/field_checks.hpp"

namespace alphainv::rt {

namespace {

/// Whether the torque of `e` depends on the velocity (probed at a few states).
bool depends_on_velocity(const Effects& e) noexcept {
  for (double theta : {-0.3, 0.0, 0.37}) {
    const double at_rest = effect_torque(e, theta, 0.0);
    for (double w : {-1.0, -1e-3, 1e-2, 2.0}) {
      if (effect_torque(e, theta, w) != at_rest) return true;
    }
  }
  return false;
}

}  // namespace

const char* to_string(CompensationMode mode) noexcept {
  switch (mode) {
    case CompensationMode::kNone:
      return "none";
    case CompensationMode::kEffects:
      return "effects";
    case CompensationMode::kFeedforward:
      return "feedforward";
    case CompensationMode::kAll:
      return "all";
  }
  return "none";
}

CompensationMode compensation_mode_from_name(const std::string& name, const std::string& field) {
  for (CompensationMode m : {CompensationMode::kNone, CompensationMode::kEffects,
                             CompensationMode::kFeedforward, CompensationMode::kAll}) {
    if (name == to_string(m)) return m;
  }
  throw Error("expected effects, feedforward, all or none, got '" + name + "'", {}, 0, field);
}

void CompensatorConfig::validate(double period_s) const {
  const double f = velocity_bandwidth_hz;
  if (!(std::isfinite(f) && f > 0.0 && f < 0.2 / period_s)) {
    detail::bad("compensation.velocity_bandwidth_hz",
                "0 < bandwidth < " + detail::num(0.2 / period_s) + " Hz (0.2/T)", f);
  }
  detail::require_positive("compensation.friction_smoothing_rad_s", friction_smoothing_rad_s);
  detail::require_positive("compensation.deadzone_smoothing_v", deadzone_smoothing_v);
  detail::require_positive("compensation.breakaway_smoothing_rad", breakaway_smoothing_rad);
  const double eta = transition_command_fraction;
  if (!(std::isfinite(eta) && eta > 0.0 && eta <= 1.0)) {
    detail::bad("compensation.transition_command_fraction", "0 < fraction <= 1", eta);
  }
  const double kappa = damping_fraction;
  if (!(std::isfinite(kappa) && kappa >= 0.0 && kappa < 1.0)) {
    detail::bad("compensation.damping_fraction", "0 <= fraction < 1", kappa);
  }
}

Compensator::Compensator(const CompensatorConfig& config, const Effects& model_effects,
                         double period_s)
    : config_((config.validate(period_s), config)),
      effects_(model_effects),
      period_s_(period_s),
      lead_s_(config.lead ? 0.5 * period_s + model_effects.delay_s : 0.0) {
  // α-β observer with both error poles at p: a = 1 − p², b = (1 − p)² (characteristic
  // polynomial z² − (2 − a − b)z + (1 − a) = (z − p)²).
  const double p = std::exp(-2.0 * 3.14159265358979323846 * config.velocity_bandwidth_hz * period_s);
  gain_position_ = 1.0 - p * p;
  gain_velocity_ = (1.0 - p) * (1.0 - p) / period_s;
  inv_friction_smoothing_ = 1.0 / config.friction_smoothing_rad_s;
  inv_deadzone_smoothing_ = 1.0 / config.deadzone_smoothing_v;
  inv_breakaway_ = 1.0 / config.breakaway_smoothing_rad;
  // Sort the torque effects generically, through the catalogue: each active one alone, probed;
  // the terms it turns on join the moving mask when its torque depends on θ̇.
  Effects torque_group, moving_group;
  for (const EffectSpec& spec : kEffectCatalogue) {
    if (spec.role != EffectRole::kTorque || !spec.active(model_effects)) continue;
    const auto add_to = [&](Effects& group) {
      for (const EffectParameter& q : spec) group.*(q.member) = model_effects.*(q.member);
    };
    Effects alone;
    add_to(alone);
    add_to(torque_group);
    if (!depends_on_velocity(alone)) continue;
    add_to(moving_group);
    moving_terms_ |= TorqueEffects(alone).terms_on();
  }
  torque_effects_ = TorqueEffects(torque_group);
  moving_zero_at_rest_ = TorqueEffects(moving_group).zero_at_rest();
  memory_on_ = discovered_memory_active(model_effects);
  memory_lag_decay_ = DiscoveredMemory::lag_decay(model_effects, period_s);
}

void Compensator::reset() noexcept {
  have_state_ = false;
  theta_hat_ = theta_meas_ = velocity_ = 0.0;
  memory_.reset(0.0);
  memory_torque_ = 0.0;
}

}  // namespace alphainv::rt
