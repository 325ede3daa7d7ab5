#pragma once
/// \file effects.hpp
/// The physical effects beyond the α-invariant model (the catalogue of `omni_fit diagnose`), as
/// terms added to eq. (11):
///     θ̈ + C(α, I)·θ̇ = β̃(α, I)·(S(Z(v(t − τ))) + n(θ, θ̇)),
///     n = −Fc·tanh(θ̇/ε)          coulomb_friction (smoothed)
///       + d0                      offset_torque
///       − g·sin(θ + θ0)           gravity
///       + a·sin(2π·θ/p + φ)       cogging, periodic in θ,
/// with τ the command delay (time_delay), Z the deadzone Z(v) = sign(v)·max(|v| − d, 0) (deadzone)
/// and S the clamp to ±v_max (saturation). Torques are in command units. Every effect is off at its
/// default. The virtual plant, the simulator and the 1 kHz online model all use these functions.

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "alphainv/error.hpp"
#include "alphainv/model/detail/field_checks.hpp"

namespace alphainv {

/// Effect parameters. Each effect is off at its default value (0, or infinity for the saturation).
struct Effects {
  double coulomb_v = 0.0;                 ///< Coulomb friction level Fc [command unit], ≥ 0
  double coulomb_smoothing_rad_s = 1e-3;  ///< tanh smoothing velocity ε [position unit/s], > 0
  double offset_v = 0.0;                  ///< constant offset torque d0 [command unit]
  double gravity_v = 0.0;                 ///< gravity torque amplitude g [command unit]
  double gravity_theta0_rad = 0.0;        ///< gravity phase θ0 [rad]: n = −g·sin(θ + θ0)
  double cogging_v = 0.0;                 ///< cogging amplitude a [command unit]
  double cogging_period_rad = 0.02;       ///< cogging period p in θ [position unit], > 0
  double cogging_phase_rad = 0.0;         ///< cogging phase φ [rad]
  double delay_s = 0.0;  ///< command transport delay τ [s], 0 ≤ τ ≤ kMaxDelayS
  double saturation_v = std::numeric_limits<double>::infinity();  ///< amplifier limit v_max > 0
  double deadzone_v = 0.0;  ///< amplifier deadzone half-width d [command unit], ≥ 0

  /// Longest delay accepted [s] (delay lines are sized from it).
  static constexpr double kMaxDelayS = 1.0;
};

/// n(θ, θ̇) [command unit]: the torque-like effects (file comment). Real-time safe.
inline double effect_torque(const Effects& e, double theta, double theta_dot) noexcept {
  constexpr double kTwoPi = 6.283185307179586476925;
  double n = e.offset_v;
  if (e.coulomb_v > 0.0) n -= e.coulomb_v * std::tanh(theta_dot / e.coulomb_smoothing_rad_s);
  if (e.gravity_v != 0.0) n -= e.gravity_v * std::sin(theta + e.gravity_theta0_rad);
  if (e.cogging_v != 0.0) {
    n += e.cogging_v * std::sin(kTwoPi * theta / e.cogging_period_rad + e.cogging_phase_rad);
  }
  return n;
}

/// S(Z(v)): the amplifier's deadzone, then its saturation [command unit]. Real-time safe.
inline double amplifier(const Effects& e, double v) noexcept {
  if (e.deadzone_v > 0.0) {  // Z(v) = sign(v)·max(|v| − d, 0)
    const double mag = std::abs(v) - e.deadzone_v;
    v = mag > 0.0 ? std::copysign(mag, v) : 0.0;
  }
  return std::clamp(v, -e.saturation_v, e.saturation_v);  // S(v)
}

/// The catalogue of `omni_fit diagnose`.
enum class EffectKind {
  kNone,
  kCoulombFriction,
  kOffsetTorque,
  kGravity,
  kCogging,
  kTimeDelay,
  kSaturation,
  kDeadzone,
};

/// Every kind, kNone first.
inline constexpr std::array<EffectKind, 8> kAllEffectKinds = {
    EffectKind::kNone,    EffectKind::kCoulombFriction, EffectKind::kOffsetTorque,
    EffectKind::kGravity, EffectKind::kCogging,         EffectKind::kTimeDelay,
    EffectKind::kSaturation, EffectKind::kDeadzone};

/// The catalogue name: "none", "coulomb_friction", "offset_torque", "gravity", "cogging",
/// "time_delay", "saturation", "deadzone".
inline const char* effect_name(EffectKind kind) noexcept {
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

/// The kind of a catalogue name; throws alphainv::Error naming the field `field` otherwise.
inline EffectKind effect_kind_from_name(std::string_view name, const std::string& field = "effect") {
  for (EffectKind k : kAllEffectKinds) {
    if (name == effect_name(k)) return k;
  }
  std::string known;
  for (EffectKind k : kAllEffectKinds) known += std::string(known.empty() ? "" : ", ") + effect_name(k);
  throw Error("unknown effect \"" + std::string(name) + "\"; expected one of " + known, {}, 0,
              field);
}

/// One named parameter of an effect and the Effects member that holds it.
struct EffectParameter {
  const char* name;         ///< e.g. "coulomb_v"
  double Effects::*member;  ///< where it lives
  const char* unit;         ///< "command unit", "rad", "s", …
};

/// The parameters an effect of `kind` adds to the model (empty for kNone). The smoothing ε of the
/// Coulomb term is a modelling choice, not a fitted parameter, and is listed (last) only with
/// `with_modelling_choices` (what a model file stores and a simulation needs).
inline std::vector<EffectParameter> effect_parameters(EffectKind kind, bool with_modelling_choices = false) {
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

/// Whether `e` has the effect of `kind` switched on.
inline bool effect_active(const Effects& e, EffectKind kind) noexcept {
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

/// The kinds switched on in `e`, in catalogue order.
inline std::vector<EffectKind> active_effects(const Effects& e) {
  std::vector<EffectKind> out;
  for (EffectKind k : kAllEffectKinds) {
    if (effect_active(e, k)) out.push_back(k);
  }
  return out;
}

/// The active effects with their parameters (modelling choices included), e.g.
/// "coulomb_friction (coulomb_v = 0.004, coulomb_smoothing_rad_s = 0.001)"; "none" when all are off.
inline std::string effects_text(const Effects& e) {
  std::string text;
  for (EffectKind kind : active_effects(e)) {
    std::string params;
    for (const EffectParameter& p : effect_parameters(kind, true)) {
      params += (params.empty() ? "" : ", ") + std::string(p.name) + " = " + detail::num(e.*p.member);
    }
    text += (text.empty() ? "" : "; ") + std::string(effect_name(kind)) + " (" + params + ")";
  }
  return text.empty() ? "none" : text;
}

/// Throws alphainv::Error naming the field (prefix + member, e.g. "effects.coulomb_v") when a value
/// is out of range.
inline void validate_effects(const Effects& e, const std::string& prefix = "effects.") {
  const std::string& p = prefix;
  detail::require_nonnegative(p + "coulomb_v", e.coulomb_v);
  if (e.coulomb_v > 0.0) detail::require_positive(p + "coulomb_smoothing_rad_s", e.coulomb_smoothing_rad_s);
  detail::require_finite(p + "offset_v", e.offset_v);
  detail::require_finite(p + "gravity_v", e.gravity_v);
  detail::require_finite(p + "gravity_theta0_rad", e.gravity_theta0_rad);
  detail::require_finite(p + "cogging_v", e.cogging_v);
  if (e.cogging_v != 0.0) detail::require_positive(p + "cogging_period_rad", e.cogging_period_rad);
  detail::require_finite(p + "cogging_phase_rad", e.cogging_phase_rad);
  if (!std::isfinite(e.delay_s) || e.delay_s < 0.0 || e.delay_s > Effects::kMaxDelayS) {
    detail::bad(p + "delay_s", "0 <= delay_s <= " + detail::num(Effects::kMaxDelayS) + " s", e.delay_s);
  }
  if (std::isnan(e.saturation_v) || !(e.saturation_v > 0.0)) {
    detail::bad(p + "saturation_v", "a limit > 0 (infinity: none)", e.saturation_v);
  }
  detail::require_nonnegative(p + "deadzone_v", e.deadzone_v);
}

}  // namespace alphainv
