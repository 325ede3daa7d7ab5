#pragma once
/// \file plant_input.hpp
/// The one place the plant's input of eq. (11) is written:
///     u(t) = e(t)·S(Z(v(t − τ))) + n(θ, θ̇, t) + d(t),
/// the command v delayed by τ through the amplifier's deadzone Z and saturation S (amplifier() of
/// effects.hpp), switched by the motor enable e(t) ∈ {0, 1} (a run's `torque_enable` column: 0 is
/// free motion, the amplifier gives nothing), plus the torque-like effects n (effect_torque() of
/// effects.hpp) and a known external disturbance d(t) [command unit] (a run's `disturbance_v`
/// column, undelayed and unsaturated: it is a torque on the joint, not a command). The plant is
///     θ̈ + C(α, I)·θ̇ = β̃(α, I)·u(t).
/// Every user of the equation calls these functions: the simulator, the virtual plant, the 1 kHz
/// online model, the time-domain fits, the local points with effects and diagnose; a new effect in
/// effects.hpp reaches all of them through amplifier() and effect_torque().
///
/// The delay τ is the caller's: each keeps its own delay line (interpolated in the continuous
/// simulator, whole and fractional ticks in the virtual plant) and passes v(t − τ). The time t [s]
/// is passed on for effects that depend on time. Header-only, no allocation.

#include "alphainv/model/effects.hpp"
#include "alphainv/model/torque_effects.hpp"

namespace alphainv {

/// The known inputs of a run at one instant (KnownInputSeries in simulate/ reads them from a
/// run's columns).
struct KnownInputs {
  double disturbance_v = 0.0;  ///< d(t): a known external torque [command unit]
  bool torque_enabled = true;  ///< e(t): false while the motor is switched off (free motion)
  /// c(t): a known addition to the controller's command, before its clamp [command unit] (a run's
  /// `v_comp` column: omni_ctl's model-based compensation). Not part of u: the controller adds it
  /// (simulate.hpp's loops: v = clamp(PID + c)), so it passes the delay, deadzone and saturation.
  double command_offset_v = 0.0;
};

/// e(t)·S(Z(v(t − τ))) [command unit]: the part of u that comes through the amplifier, from the
/// delayed command `delayed_command_v`. Real-time safe.
inline double applied_command(const Effects& effects, double delayed_command_v,
                              const KnownInputs& known = {}) noexcept {
  return known.torque_enabled ? amplifier(effects, delayed_command_v) : 0.0;
}

/// n(θ, θ̇, t) + d(t) [command unit]: the torques on the joint (effects and the known
/// disturbance) at time `t_s` [s], position `theta` and velocity `theta_dot`. Real-time safe.
inline double plant_torque(const Effects& effects, double t_s, double theta, double theta_dot,
                           const KnownInputs& known = {}) noexcept {
  // The one torque of time, external_disturbance, is per run: it comes in as known.disturbance_v
  // (a recorded `disturbance_v` column or diagnose's estimate of it), not from `effects`.
  (void)t_s;
  const double n = effect_torque(effects, theta, theta_dot);
  return known.disturbance_v != 0.0 ? n + known.disturbance_v : n;
}

/// plant_torque() with the torque effects precomputed (torque_effects.hpp; the 1 kHz online
/// model): equal to plant_torque(torque.effects(), …) to rounding. Real-time safe.
inline double plant_torque(const TorqueEffects& torque, double t_s, double theta, double theta_dot,
                           const KnownInputs& known = {}) noexcept {
  (void)t_s;  // as plant_torque(Effects): the torque of time comes in as known.disturbance_v
  const double n = torque.torque(theta, theta_dot);
  return known.disturbance_v != 0.0 ? n + known.disturbance_v : n;
}

/// u(t) of the file comment [command unit]: applied_command() + plant_torque(). Real-time safe.
inline double plant_input(const Effects& effects, double t_s, double delayed_command_v,
                          double theta, double theta_dot, const KnownInputs& known = {}) noexcept {
  return applied_command(effects, delayed_command_v, known) +
         plant_torque(effects, t_s, theta, theta_dot, known);
}

}  // namespace alphainv
