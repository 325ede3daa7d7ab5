#pragma once
/// \file invented_effects.hpp
/// Invented effects: torques on the joint that no model of this project knows. They are kept OUT
/// of the effect table (effects.hpp: no EffectKind, no model.json entry, no online model) and
/// away from the exact forms of the discovered term's library, so that `omni_fit diagnose` can
/// be tried in the open world (issue #15): on them, no named effect may be claimed as the whole
/// story. Generator- and test-only: `omni_gen --invented`, ExperimentPlanOptions::invented and
/// ClosedLoopOptions::hidden_torque_v (the run does not record the torque). Not real-time.
///
/// n_inv = −F with, per kind (σ_a(x; v) = x/√(x² + v²), an algebraic sign, not a tanh):
///   lugre       a dynamic friction with an internal bristle state z (LuGre-like):
///                 ż = θ̇ − σ0·|θ̇|·z/g(θ̇), g = Fc + (Fs − Fc)·exp(−|θ̇/v_s|), F = σ0·z;
///               z advanced exactly over each tick with θ̇ held (stiff at high speed);
///   drift       a friction level that drifts between runs: F = Fc_i·σ_a(θ̇; v), Fc_i =
///               Fc·(1 + drift·(2·frac(0.618·(i + 1)) − 1)) for run i;
///   hysteresis  a velocity-dependent hysteresis (frictional lag): F = Fc·σ_a(v_lag; v), the
///               velocity through a first-order lag, v̇_lag = (θ̇ − v_lag)/τ.

#include <cstddef>
#include <functional>
#include <string>

namespace alphainv {

/// Which invented effect.
enum class InventedKind { kNone, kLuGre, kDrift, kHysteresis };

/// An invented effect and its parameters (file comment); kind kNone: off.
struct InventedEffect {
  InventedKind kind = InventedKind::kNone;
  double level_v = 0.008;              ///< Fc [command unit], > 0
  double breakaway_v = 0.016;          ///< lugre: Fs [command unit], ≥ Fc
  double velocity_rad_s = 0.1;         ///< lugre: v_s; drift, hysteresis: v [rad/s], > 0
  double stiffness_v_per_rad = 16.0;   ///< lugre: σ0 [command unit/rad], > 0
  double lag_s = 0.015;                ///< hysteresis: τ [s], > 0
  double drift = 0.6;                  ///< drift: the run-to-run spread, in [0, 1)

  bool active() const noexcept { return kind != InventedKind::kNone; }
  /// "lugre:level_v=0.008,breakaway_v=0.016,velocity_rad_s=0.1,stiffness_v_per_rad=16" (its
  /// kind's parameters; "none" when off), which parse_invented_effect() reads back.
  std::string text() const;
};

/// Reads "KIND" or "KIND:PARAM=VALUE[,PARAM=VALUE]" (KIND lugre, drift or hysteresis; PARAM a
/// member name above), the other parameters at their defaults. Throws alphainv::Error naming
/// `option` for an unknown kind or parameter or a value out of range.
InventedEffect parse_invented_effect(const std::string& spec,
                                     const std::string& option = "--invented");

/// The torque n_inv(t, θ, θ̇) [command unit] of run `run_index` (a fresh internal state), as
/// ClosedLoopOptions::hidden_torque_v calls it: once per tick, in order of time.
std::function<double(double t_s, double theta, double theta_dot)> invented_torque(
    const InventedEffect& effect, std::size_t run_index);

}  // namespace alphainv
