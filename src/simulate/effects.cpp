#include "alphainv/effects.hpp"

#include "alphainv/error.hpp"
#include "field_checks.hpp"

namespace alphainv {

using detail::bad;
using detail::num;
using detail::require_finite;
using detail::require_nonnegative;
using detail::require_positive;

const char* effect_name(EffectKind kind) noexcept {
  switch (kind) {
    case EffectKind::kNone: return "none";
    case EffectKind::kCoulombFriction: return "coulomb_friction";
    case EffectKind::kOffsetTorque: return "offset_torque";
    case EffectKind::kGravity: return "gravity";
    case EffectKind::kCogging: return "cogging";
    case EffectKind::kTimeDelay: return "time_delay";
    case EffectKind::kSaturation: return "saturation";
    case EffectKind::kDeadzone: return "deadzone";
  }
  return "none";
}

EffectKind effect_kind_from_name(std::string_view name, const std::string& field) {
  for (EffectKind k : kAllEffectKinds) {
    if (name == effect_name(k)) return k;
  }
  std::string known;
  for (EffectKind k : kAllEffectKinds) known += std::string(known.empty() ? "" : ", ") + effect_name(k);
  throw Error("unknown effect \"" + std::string(name) + "\"; expected one of " + known, {}, 0,
              field);
}

std::vector<EffectParameter> effect_parameters(EffectKind kind, bool with_modelling_choices) {
  switch (kind) {
    case EffectKind::kNone: return {};
    case EffectKind::kCoulombFriction:
      if (with_modelling_choices) {
        return {{"coulomb_v", &Effects::coulomb_v, "command unit"},
                {"coulomb_smoothing_rad_s", &Effects::coulomb_smoothing_rad_s, "position unit/s"}};
      }
      return {{"coulomb_v", &Effects::coulomb_v, "command unit"}};
    case EffectKind::kOffsetTorque: return {{"offset_v", &Effects::offset_v, "command unit"}};
    case EffectKind::kGravity:
      return {{"gravity_v", &Effects::gravity_v, "command unit"},
              {"gravity_theta0_rad", &Effects::gravity_theta0_rad, "rad"}};
    case EffectKind::kCogging:
      return {{"cogging_v", &Effects::cogging_v, "command unit"},
              {"cogging_period_rad", &Effects::cogging_period_rad, "position unit"},
              {"cogging_phase_rad", &Effects::cogging_phase_rad, "rad"}};
    case EffectKind::kTimeDelay: return {{"delay_s", &Effects::delay_s, "s"}};
    case EffectKind::kSaturation:
      return {{"saturation_v", &Effects::saturation_v, "command unit"}};
    case EffectKind::kDeadzone: return {{"deadzone_v", &Effects::deadzone_v, "command unit"}};
  }
  return {};
}

bool effect_active(const Effects& e, EffectKind kind) noexcept {
  switch (kind) {
    case EffectKind::kNone: return false;
    case EffectKind::kCoulombFriction: return e.coulomb_v > 0.0;
    case EffectKind::kOffsetTorque: return e.offset_v != 0.0;
    case EffectKind::kGravity: return e.gravity_v != 0.0;
    case EffectKind::kCogging: return e.cogging_v != 0.0;
    case EffectKind::kTimeDelay: return e.delay_s > 0.0;
    case EffectKind::kSaturation: return std::isfinite(e.saturation_v);
    case EffectKind::kDeadzone: return e.deadzone_v > 0.0;
  }
  return false;
}

std::vector<EffectKind> active_effects(const Effects& e) {
  std::vector<EffectKind> out;
  for (EffectKind k : kAllEffectKinds) {
    if (effect_active(e, k)) out.push_back(k);
  }
  return out;
}

std::string effects_text(const Effects& e) {
  std::string text;
  for (EffectKind kind : active_effects(e)) {
    std::string params;
    for (const EffectParameter& p : effect_parameters(kind, true)) {
      params += (params.empty() ? "" : ", ") + std::string(p.name) + " = " + num(e.*p.member);
    }
    text += (text.empty() ? "" : "; ") + std::string(effect_name(kind)) + " (" + params + ")";
  }
  return text.empty() ? "none" : text;
}

void validate_effects(const Effects& e, const std::string& prefix) {
  const std::string& p = prefix;
  require_nonnegative(p + "coulomb_v", e.coulomb_v);
  if (e.coulomb_v > 0.0) require_positive(p + "coulomb_smoothing_rad_s", e.coulomb_smoothing_rad_s);
  require_finite(p + "offset_v", e.offset_v);
  require_finite(p + "gravity_v", e.gravity_v);
  require_finite(p + "gravity_theta0_rad", e.gravity_theta0_rad);
  require_finite(p + "cogging_v", e.cogging_v);
  if (e.cogging_v != 0.0) require_positive(p + "cogging_period_rad", e.cogging_period_rad);
  require_finite(p + "cogging_phase_rad", e.cogging_phase_rad);
  if (!std::isfinite(e.delay_s) || e.delay_s < 0.0 || e.delay_s > Effects::kMaxDelayS) {
    bad(p + "delay_s", "0 <= delay_s <= " + num(Effects::kMaxDelayS) + " s", e.delay_s);
  }
  if (std::isnan(e.saturation_v) || !(e.saturation_v > 0.0)) {
    bad(p + "saturation_v", "a limit > 0 (infinity: none)", e.saturation_v);
  }
  require_nonnegative(p + "deadzone_v", e.deadzone_v);
}

}  // namespace alphainv
