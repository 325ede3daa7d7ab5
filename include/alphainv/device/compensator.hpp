#pragma once
/// \file device/compensator.hpp
/// Model-based compensation for the 1 kHz tick (omni_ctl --compensate): the identified model used
/// to cancel what the P law would otherwise have to fight, in the plant of eq. (11)
///     θ̈ + C(α, I)·θ̇ = β̃(α, I)·(S(Z(v(t − τ))) + n(θ, θ̇)).
///
/// - effects: the torque effects n of the model file (effects.hpp: Coulomb and every other friction
///   form of the catalogue, offset, gravity, cogging) cancelled, and the amplifier deadzone Z
///   inverted: v = Z⁻¹(v_p + v_ff − n̂). n̂ is effect_torque() evaluated generically (no effect is
///   listed here) at the measured angle led by half a tick plus the model's delay,
///   θ_L = θ + θ̇_f·(T/2 + τ), and at a velocity w, with its velocity-dependent part faded in
///   through zero velocity (the model's torque effects are sorted once, in the constructor, by
///   whether their term depends on θ̇; the tick evaluates all terms in one pass and sums the two
///   kinds apart):
///       n̂ = n(θ_L, 0) + [n(θ_L, w) − n(θ_L, 0)]·s(|w|/ε_c),
///   s(x) = x·(1 − x²/6.75) for |x| ≤ 1.5, sign(x) beyond (a clamped cubic: odd, slope 1 at 0,
///   flat where it reaches ±1 at |x| = 1.5; no square root or division in the tick),
///   so the friction compensation is continuous and flat at w = 0 (no chatter on encoder steps, no
///   limit cycle at rest) and complete for |w| ≫ ε_c. At rest that alone leaves a stiction band:
///   the joint stops wherever the P law's kp·|e| no longer overcomes the friction (Fc/kp, 10 mrad
///   for 0.02 V at 2 V/rad). So at low speed the friction is compensated in the direction the P
///   law pushes (breakaway): with f = s(|w|/ε_c) and σ = s(e/e_b) (e = the P law's position error,
///   0 when kp = 0: free motion has no target),
///       n̂ = n(θ_L, 0) + [n(θ_L, w_c) − n(θ_L, 0)]·g,  w_c = w + ε_c·σ·(1 − f),  g = f + |σ|·(1 − f),
///   which is the formula above for |w| ≫ ε_c or e = 0, and the friction just above zero velocity
///   in the error's direction at rest. It acts like a spring stiffer than kp within e_b of the
///   target (restoring, so the hold stays within an encoder step or two: no limit cycle). w is the filtered velocity θ̇_f, except in the
///   mode `all` while the reference moves (a sine): there the joint follows the reference and w is
///   ṙ at the tick's middle plus τ, which reverses when the motion does, not a few ticks later (a
///   filtered velocity fades the compensation out at each reversal, and the joint sticks there
///   until the P law alone overcomes the friction). The deadzone is inverted smoothly,
///   Z⁻¹(x) = x + d·s(x/δ) (δ = deadzone_smoothing_v), exact for |x| ≥ 1.5·δ.
/// - damping (opt-in, in the mode `effects`): a fraction κ of the α-model's own damping cancelled
///   for free motion (transparency: kp = 0, a hand moving the joint), v += κ·(C/β̃)·θ̇_f, so the
///   hand feels C·(1 − κ) of it. Not in the modes that feed forward (their v_ff already holds
///   C·ṙ along the reference, and at rest ṙ = 0). A feedback on θ̇: the loop keeps the net damping
///   (1 − κ·m)·C > 0 when the model's C is m times the plant's, so κ < 1 and, for a model 30 %
///   high, κ < 0.77.
/// - feedforward: the α-model inverted along the reference, v_ff from
///       r̈ + C(α̂, I)·ṙ = β̃(α̂, I)·v_ff          (eq. (37) with θ = r),
///   with α̂ the streaming α of the command history (eq. (33)) and I(γ1, γ2) at the measured pose
///   (eq. (6)); the reference's derivatives are taken at the tick's middle plus τ.
///
/// The discovered term's memory terms (effects.hpp DiscoveredMemory: a lagged velocity's sign, a
/// Dahl state) are advanced once per tick by observe() from the observer's displacement and θ̇_f,
/// and their torque joins n̂ as it is (not faded: the lag's sign passes through zero on its own,
/// and a Dahl state at rest is the torque the joint holds).
///
/// θ̇_f comes from a second-order tracking observer (an α-β filter with both poles at
/// exp(−2π·velocity_bandwidth_hz·T)): zero steady-state error on a ramp in θ, and an encoder step q
/// moves θ̇_f by only (1 − p)²·q/T.
///
/// Split like the loop: the constructor validates; observe(), command(), reset() are noexcept and
/// real-time safe (no allocation, no locks, no I/O).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

#include "alphainv/model/effects.hpp"
#include "alphainv/model/torque_effects.hpp"

namespace alphainv::rt {

/// What --compensate adds to the P law.
enum class CompensationMode : std::uint8_t {
  kNone,         ///< the P law alone (the default)
  kEffects,      ///< the model's torque effects cancelled, its deadzone inverted
  kFeedforward,  ///< the α-model inverted along the reference
  kAll,          ///< both
};

/// "none", "effects", "feedforward", "all". Real-time safe.
const char* to_string(CompensationMode mode) noexcept;
/// The mode `name` names (to_string's spelling); throws alphainv::Error naming `field` otherwise.
CompensationMode compensation_mode_from_name(const std::string& name,
                                             const std::string& field = "--compensate");
/// True when `mode` cancels the effects (kEffects, kAll). Real-time safe.
inline bool cancels_effects(CompensationMode mode) noexcept {
  return mode == CompensationMode::kEffects || mode == CompensationMode::kAll;
}
/// True when `mode` adds the feedforward (kFeedforward, kAll). Real-time safe.
inline bool feeds_forward(CompensationMode mode) noexcept {
  return mode == CompensationMode::kFeedforward || mode == CompensationMode::kAll;
}

/// Settings of the compensator. validate() names a bad field.
struct CompensatorConfig {
  CompensationMode mode = CompensationMode::kNone;
  /// Bandwidth of the velocity observer [Hz] (both poles at exp(−2π·f·T)); < 0.2/T.
  double velocity_bandwidth_hz = 30.0;
  /// ε_c [rad/s]: the velocity-dependent effects fade in as s(|w|/ε_c) (file comment).
  double friction_smoothing_rad_s = 0.03;
  /// δ [command unit]: width of the smooth deadzone inverse x + d·s(x/δ).
  double deadzone_smoothing_v = 1e-3;
  /// e_b [rad]: at low speed the velocity-dependent effects are evaluated in the direction of the
  /// P law's position error e, faded in as s(e/e_b) (breakaway, file comment); 2 encoder steps.
  double breakaway_smoothing_rad = 3e-4;
  /// η: in the modes that feed forward, a jump of the reference (a step, a square wave's edge) is
  /// followed along the fastest cycloid whose feedforward needs at most η·max_command_v of the
  /// clamp (control_loop.hpp); 0 < η ≤ 1.
  double transition_command_fraction = 0.6;
  /// κ: in the mode `effects`, the fraction of the α-model's damping C·θ̇ cancelled (file comment);
  /// 0 (the default) cancels none; 0 ≤ κ < 1.
  double damping_fraction = 0.0;
  /// Evaluate position-dependent effects at θ + θ̇_f·(T/2 + τ) rather than at θ.
  bool lead = true;

  /// Throws alphainv::Error naming the field ("compensation.velocity_bandwidth_hz", …) for a
  /// value out of range; `period_s` is the tick period T [s]. Not real-time.
  void validate(double period_s) const;
};

/// v_ff [command unit] from r̈ + C·ṙ = β̃·v_ff: `r_dot` [rad/s], `r_ddot` [rad/s²], C [1/s],
/// β̃ [rad/s² per command unit] (> 0). Real-time safe.
inline double feedforward_command(double r_dot, double r_ddot, double damping,
                                  double beta_tilde) noexcept {
  return (r_ddot + damping * r_dot) / beta_tilde;
}

/// The compensator of one loop (see the file comment). Not thread-safe: the tick's thread only.
class Compensator {
 public:
  /// Validates `config` for tick period `period_s` [s] (throws alphainv::Error naming the field);
  /// `model_effects` are the model file's effects (validated by the caller).
  Compensator(const CompensatorConfig& config, const Effects& model_effects, double period_s);

  /// Feeds the tick's measured θ [rad] to the velocity observer (`new_report`: a new measurement
  /// arrived; otherwise the observer only predicts). Real-time safe.
  void observe(double theta_rad, bool new_report) noexcept;
  /// Forgets the observer's state (e.g. after the measurements stopped). Real-time safe.
  void reset() noexcept;

  /// n̂ [command unit]: the model's torque effects at the observer's angle (led) and the velocity
  /// `velocity_rad_s`, smoothed through zero velocity, with the breakaway direction
  /// `breakaway` = σ ∈ [−1, 1] (file comment); 0 before the first measurement. Real-time safe.
  double effect_torque_estimate(double velocity_rad_s, double breakaway = 0.0) const noexcept;
  /// The same at the filtered velocity θ̇_f. Real-time safe.
  double effect_torque_estimate() const noexcept { return effect_torque_estimate(velocity_); }
  /// σ = s(e/e_b) for the P law's position error `error_rad` (0 when `p_command_v` is 0: no
  /// target to break away towards). Real-time safe.
  double breakaway_direction(double error_rad, double p_command_v) const noexcept;
  /// Z⁻¹ smoothed: the command [command unit] whose deadzone output is `desired_v`. Real-time safe.
  double invert_deadzone(double desired_v) const noexcept;
  /// The command before the clamp [command unit] for the P law's `p_command_v` and the feedforward
  /// `feedforward_v` (used only in the modes that feed forward): in the modes that cancel effects
  /// Z⁻¹(v_p + v_ff − n̂), otherwise v_p + v_ff. `reference_rate_rad_s`: ṙ at the tick's middle
  /// plus τ when the reference moves (n̂'s velocity in the mode `all`, file comment), else 0;
  /// `error_rad` the P law's position error (the breakaway direction); `damping_per_beta` C/β̃
  /// [command unit·s/rad] of the α-model at this tick (the damping compensation, in the mode
  /// `effects` only: + κ·(C/β̃)·θ̇_f). Real-time safe.
  double command(double p_command_v, double feedforward_v, double reference_rate_rad_s = 0.0,
                 double error_rad = 0.0, double damping_per_beta = 0.0) const noexcept;

  /// Filtered velocity θ̇_f [rad/s]. Real-time safe.
  double velocity_rad_s() const noexcept { return velocity_; }
  /// The observer's angle θ̂ [rad] (what the memory terms' displacement is taken from). Real-time
  /// safe.
  double angle_rad() const noexcept { return theta_hat_; }
  /// Time by which position-dependent effects and the reference are led [s]: T/2 + τ.
  double lead_s() const noexcept { return lead_s_; }
  const CompensatorConfig& config() const noexcept { return config_; }

 private:
  /// The smooth sign s(x) [−1, 1] of the file comment: x·(1 − x²/6.75) on |x| ≤ 1.5, ±1 beyond;
  /// odd, slope 1 at 0, continuous slope. (It was x/√(1 + x²): its square root and division
  /// were a sixth of the compensated tick's time, perf; the closed-loop figures of
  /// docs/compensation.md were measured again with this one.)
  static double smooth_sign(double x) noexcept {
    const double c = std::min(std::max(x, -1.5), 1.5);
    return c * (1.0 - c * c * (1.0 / 6.75));
  }

  /// effect_torque_sum's sum split in two: the terms of moving_terms (a mask of
  /// detail::torque_term_bit) and the others with the offset.
  struct SplitTorqueSum {
    unsigned moving_terms = 0;
    double still = 0.0, moving = 0.0;
    void start(double offset) noexcept {
      still = offset;
      moving = 0.0;
    }
    void add(detail::TorqueTerm term, double addend) noexcept {
      if ((moving_terms & detail::torque_term_bit(term)) != 0u) {
        moving += addend;
      } else {
        still += addend;
      }
    }
  };

  CompensatorConfig config_;
  Effects effects_;
  /// The model's torque effects with their constants precomputed (torque_effects.hpp), evaluated
  /// in one pass per tick, their sum split by moving_terms_: the terms of the effects whose
  /// torque depends on θ̇ (probed once, in the constructor, through the catalogue).
  TorqueEffects torque_effects_;
  unsigned moving_terms_ = 0;
  /// Whether the moving terms vanish at θ̇ = 0 by construction (TorqueEffects::zero_at_rest()).
  bool moving_zero_at_rest_ = true;
  double period_s_;
  double lead_s_;
  double gain_position_ = 0.0, gain_velocity_ = 0.0;  ///< α-β gains a, b/T
  /// 1/ε_c, 1/δ, 1/e_b (precomputed: the tick multiplies).
  double inv_friction_smoothing_ = 0.0, inv_deadzone_smoothing_ = 0.0, inv_breakaway_ = 0.0;
  bool have_state_ = false;
  double theta_meas_ = 0.0;  ///< newest measured θ [rad]
  double theta_hat_ = 0.0;   ///< observer's θ [rad]
  double velocity_ = 0.0;    ///< observer's θ̇ [rad/s]
  /// The discovered term's memory terms (effects.hpp DiscoveredMemory), advanced by observe()
  /// with the observer's displacement and velocity; their torque (0 when off) joins n̂.
  bool memory_on_ = false;
  double memory_lag_decay_ = 0.0;
  DiscoveredMemory memory_;
  double memory_torque_ = 0.0;
};

// The tick's part, inline: the tick (control_loop.cpp) calls it every period, and a call per
// method across translation units was a tenth of the compensated tick's instructions (callgrind).

inline void Compensator::observe(double theta_rad, bool new_report) noexcept {
  if (!have_state_) {
    if (!new_report) return;
    have_state_ = true;
    theta_hat_ = theta_meas_ = theta_rad;
    velocity_ = 0.0;
    memory_.reset(0.0);
    memory_torque_ = 0.0;
    return;
  }
  const double theta_before = theta_hat_;
  const double predicted = theta_hat_ + period_s_ * velocity_;
  if (!new_report) {
    theta_hat_ = predicted;
  } else {
    theta_meas_ = theta_rad;
    const double residual = theta_rad - predicted;
    theta_hat_ = predicted + gain_position_ * residual;
    velocity_ += gain_velocity_ * residual;
  }
  if (memory_on_) {
    memory_.advance(effects_, memory_lag_decay_, theta_hat_ - theta_before, velocity_);
    memory_torque_ = memory_.torque(effects_);
  }
}

inline double Compensator::effect_torque_estimate(double w, double breakaway) const noexcept {
  if (!have_state_) return 0.0;
  const double theta_lead = theta_meas_ + velocity_ * lead_s_;
  // The effects that do not depend on θ̇, plus those that do, faded in through zero velocity and
  // at low speed turned towards the P law's target (breakaway, file comment).
  // One pass at w_c: the terms that do not depend on θ̇ are the same there as at rest.
  SplitTorqueSum sum;
  sum.moving_terms = moving_terms_;
  if (moving_terms_ == 0u) {  // nothing depends on θ̇
    torque_effects_.sum_terms(theta_lead, 0.0, sum);
    return sum.still + memory_torque_;
  }
  const double f = smooth_sign(std::abs(w) * inv_friction_smoothing_);
  const double rest = 1.0 - f;
  const double w_c = w + config_.friction_smoothing_rad_s * breakaway * rest;
  const double g = f + std::abs(breakaway) * rest;
  torque_effects_.sum_terms(theta_lead, w_c, sum);
  // (Friction alone vanishes at rest: tanh(0) = 0 makes the evaluation +0 exactly, skipped.)
  double at_rest = 0.0;
  if (!moving_zero_at_rest_) {
    SplitTorqueSum rest_sum;
    rest_sum.moving_terms = moving_terms_;
    torque_effects_.sum_terms(theta_lead, 0.0, rest_sum);
    at_rest = rest_sum.moving;
  }
  return sum.still + at_rest + (sum.moving - at_rest) * g + memory_torque_;
}

inline double Compensator::breakaway_direction(double error_rad, double p_command_v) const noexcept {
  return p_command_v != 0.0 ? smooth_sign(error_rad * inv_breakaway_) : 0.0;
}

inline double Compensator::invert_deadzone(double desired_v) const noexcept {
  const double d = effects_.deadzone_v;
  if (!(d > 0.0)) return desired_v;
  return desired_v + d * smooth_sign(desired_v * inv_deadzone_smoothing_);
}

inline double Compensator::command(double p_command_v, double feedforward_v, double reference_rate_rad_s,
                            double error_rad, double damping_per_beta) const noexcept {
  const bool ff = feeds_forward(config_.mode);
  double v = p_command_v + (ff ? feedforward_v : 0.0);
  if (!cancels_effects(config_.mode)) return v;
  // With the feedforward the reference's velocity (0 at rest): friction compensated by the
  // measured velocity is a feedback that, over-estimated, injects energy (negative friction) and
  // sustains a limit cycle at rest; by ṙ and the position error it is not a feedback on θ̇.
  const double w = ff ? reference_rate_rad_s : velocity_;
  // A fraction of the α-model's damping, in the mode `effects` (file comment).
  if (!ff && have_state_) v += config_.damping_fraction * damping_per_beta * velocity_;
  return invert_deadzone(
      v - effect_torque_estimate(w, breakaway_direction(error_rad, p_command_v)));
}

}  // namespace alphainv::rt
