#pragma once
/// \file virtual_omni.hpp
/// The virtual Phantom Omni yaw joint: a plant stepped once per controller tick with the command
/// the device receives, and a closed-loop runner that drives it with a digital PID (the law of the
/// interchange format). Used by omni_gen to make datasets, by tests as ground truth, and as the
/// simulated device of a 1 kHz controller loop.
///
/// Plant, eq. (11) with the α-invariant model (37):
///     θ̈ + C(α, I)·θ̇ = β̃(α, I)·(e(t)·v_eff(t) + n(θ, θ̇) + d_ext(t))   (plant_input.hpp),
/// I = I(γ1, γ2) of eq. (6) at the pose, C and β̃ of eqs. (38)-(42), disturbances n in command
/// units:
///     n = −Fc·tanh(θ̇/ε)                  Coulomb friction (smoothed)
///       + d0                              constant offset torque
///       − g·sin(θ + θ0)                   gravity (a tilted yaw axis)
///       + a·sin(2π·θ/p + φ)               cogging, periodic in θ,
/// v_eff = S(Z(v(t − τ))): the command delayed by τ, through the amplifier's deadzone Z
/// (Z(v) = sign(v)·max(|v| − d, 0)) and then its saturation S (clamp to ±v_max); e(t) ∈ {0, 1}
/// the motor enable and d_ext a known external disturbance (step(command, KnownInputs)). The
/// discovered term's memory terms (effects.hpp DiscoveredMemory) are advanced at the start of each
/// tick from the true state and their torque is held over the tick, added to d_ext.
/// The command v is held constant over each tick (zero-order hold, like a DAC).
///
/// α inside the plant. Friction depends on the energy of the command the joint receives, so once
/// per tick the plant feeds the tick-average of v_eff to a streaming rt::AlphaEstimator (the same
/// 3rd-order Butterworth filter as the 1 kHz estimator) and uses its α̂ for C(α̂, I) and β̃(α̂, I)
/// during that tick. Consequence: for a sine command of amplitude A at ω, the plant runs at
/// α̂ = |H(ω)|²·A²ω², while eq. (36) (and any identification that uses it) computes A²ω². With the
/// default 25 Hz cut-off |H|² > 0.995 below 10 Hz, so an α-model fitted to sine runs matches the
/// truth up to an α bias below 0.5 % (its effect on C or β̃ is smaller still where the model is
/// flat). In transients α̂ lags v by about 2/ωc (12.7 ms). Disturbances n and d_ext are torques,
/// not command energy: they do not enter α̂.
///
/// Measurement: θ_meas = q·round((θ + w)/q), w ~ N(0, σ²) from a std::mt19937_64 seeded with
/// `measurement.seed` (Box-Muller on 53-bit uniforms, so the stream does not depend on the standard
/// library's distributions: the same seed gives the same numbers bit for bit on the same platform).
/// q = 0 skips quantisation, σ = 0 skips the noise (and draws nothing).
///
/// Integration: classical RK4 with `substeps` equal steps per tick (per constant-input segment
/// when a fractional delay splits the tick in two). The input is constant on each segment, so the
/// only error is RK4's own: against the exact sampled-data solution of the linear plant, 3e-14 rad
/// over a 2 s step response at 4 substeps. validate() rejects effects too stiff for the step.
/// With `exact_constant_segments` and an n free of the state, a segment of length h with the
/// constant input u = β̃·(v_eff + n + d) is stepped exactly:
///     θ̇(h) = θ̇0·e^(−Ch) + (u/C)·(1 − e^(−Ch)),
///     θ(h)  = θ0 + (u/C)·h + (θ̇0 − u/C)·(1 − e^(−Ch))/C
/// (1 − e^(−Ch) by expm1, so a small C·h loses nothing): the sampled-data solution itself, one
/// exponential per segment instead of 16 evaluations of the torque.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <random>
#include <vector>

#include "alphainv/model/controller.hpp"
#include "alphainv/model/damping_model.hpp"
#include "alphainv/data/dataset.hpp"
#include "alphainv/model/effects.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "alphainv/model/plant_input.hpp"
#include "alphainv/simulate/reference.hpp"
#include "alphainv/rt/alpha_estimator.hpp"

namespace alphainv {

/// Encoder effects on the measured angle.
struct MeasurementEffects {
  double quantisation_rad = 0.0;  ///< encoder step q [rad], ≥ 0 (0: none); the Omni's is ~1.5e-4
  double noise_std_rad = 0.0;  ///< additive Gaussian noise σ [rad], ≥ 0 (added before quantising)
  std::uint64_t seed = 0;      ///< seed of the noise generator (std::mt19937_64)
};

/// Constant parameters of a VirtualOmni. validate() names the first bad field.
struct VirtualOmniParams {
  InertiaModel inertia = paper_inertia_model();  ///< I(γ1, γ2), eq. (6)
  AlphaModel alpha_model = paper_alpha_model();  ///< C(α, I), β̃(α, I), eqs. (38)-(42)
  double gamma1_deg = 60.08;  ///< true pose γ1 [deg] (default: the 65°/90° pose's measured angles)
  double gamma2_deg = 87.00;  ///< true pose γ2 [deg]
  /// The plant's α filter; its sample_period_s must equal tick_period_s.
  rt::AlphaEstimatorConfig alpha_filter{};
  double tick_period_s = 1e-3;           ///< controller tick T [s]; the command is held over a tick
  int substeps = 4;                      ///< RK4 steps per tick, 1…1000
  /// When the effects' torque does not depend on the state (torque_depends_on_state() is false:
  /// no effect, or only constant ones), step each constant-input segment by the exact solution of
  /// the linear plant instead of RK4 (file comment). Off by default, so that the generator's runs
  /// stay RK4 bit for bit; the model simulation (simulate.hpp) turns it on.
  bool exact_constant_segments = false;
  /// Evaluate n(θ, θ̇) by TorqueEffects (torque_effects.hpp: the constants of effect_torque()
  /// precomputed once; equal to it to rounding, not bit for bit) instead of effect_torque(). Off by
  /// default, so that the generator's runs stay bit for bit; the model simulation (simulate.hpp)
  /// turns it on.
  bool precomputed_torque = false;
  double initial_theta_rad = 0.0;        ///< θ(0) [rad]
  double initial_theta_dot_rad_s = 0.0;  ///< θ̇(0) [rad/s]
  /// The command before the first tick [command unit]: fills the delay line and sets the α filter's
  /// steady state.
  double initial_command_v = 0.0;
  Effects effects;            ///< disturbances and amplifier effects (all off by default)
  MeasurementEffects measurement;  ///< encoder quantisation and noise (off by default)

  /// Throws alphainv::Error naming the field (e.g. "effects.coulomb_v") when a value is out of
  /// range, the inertia at the pose is not positive, or the RK4 step would be unstable for the
  /// stiffest effect (then it says how many substeps are needed). Not real-time.
  void validate() const;
};

/// The RK4 substeps a model simulation uses for `p` (its `substeps` ignored): when n depends on θ̇
/// (friction forms: stiff at θ̇ = 0), the first of 4, 16, 64, 256, 1000 that is stable, as the
/// generator's plant runs; when n depends on θ alone or not at all (smooth), the fewest of
/// 1, 2, 4, 8, … whose h·λ of the stiffest mode is ≤ 0.25 (RK4's relative error per step below
/// (h·λ)⁵/120 ≈ 1e-5 of the step's change, at the 1 kHz tick typically 1e-12 rad). 0 when none up
/// to 1000 is stable. Not real-time.
int model_simulation_substeps(const VirtualOmniParams& p) noexcept;

/// An AlphaModel whose C and β̃ do not depend on α: C = 1/(c_n1·I), β̃ = 1/(beta_tilde_n1·I).
/// With c_n1 = C̄0 and beta_tilde_n1 = 1 it is the global linear model (24)-(26).
AlphaModel constant_alpha_model(double c_n1, double beta_tilde_n1);

/// The virtual Omni yaw joint (see the file comment). Construct outside the loop (allocates the
/// delay line, may throw); step(), reset() and the accessors are real-time safe.
class VirtualOmni {
 public:
  /// Validates `params` (throws alphainv::Error naming the bad field) and sets the initial state,
  /// including the first measurement (theta_measured()).
  explicit VirtualOmni(const VirtualOmniParams& params);

  /// Advances one tick with `command_v` [command unit] held over it (and a known external
  /// disturbance `disturbance_v` [command unit] added to n, undelayed and unsaturated). Returns the
  /// measured θ at the end of the tick [rad].
  /// Real-time safe: noexcept, no allocation, no locks, no I/O.
  double step(double command_v, double disturbance_v = 0.0) noexcept {
    return step(command_v, KnownInputs{disturbance_v, true});
  }

  /// Advances one tick with `command_v` held over it and the known inputs `known` held over it:
  /// the disturbance d and the motor enable e of plant_input.hpp (e = 0: the amplifier gives
  /// nothing this tick, and the α filter is fed 0). Returns the measured θ at the end of the tick.
  /// Real-time safe: noexcept, no allocation, no locks, no I/O.
  double step(double command_v, const KnownInputs& known) noexcept;

  /// Feeds past commands (oldest first) through the command path (delay line, amplifier, α
  /// filter) without moving the joint: starts a simulation from the middle of a recorded run with
  /// the α filter and the delay line in the state the run left them. Real-time safe.
  void prime_commands(const double* commands_v, std::size_t n) noexcept;

  /// Back to the initial state of the parameters: θ, θ̇, command history, α filter, time and the
  /// noise generator (reseeded), then the first measurement again. Real-time safe.
  void reset() noexcept;

  /// Moves the other two joints to the true pose (γ1, γ2) [deg] and recomputes I. Returns false and
  /// changes nothing when I would not be positive or the RK4 step would be unstable there.
  /// Real-time safe.
  bool set_pose(double gamma1_deg, double gamma2_deg) noexcept;

  double theta_measured() const noexcept { return theta_measured_; }  ///< last measurement [rad]
  double theta() const noexcept { return theta_; }                    ///< true θ now [rad]
  double theta_dot() const noexcept { return theta_dot_; }            ///< true θ̇ now [rad/s]
  double alpha() const noexcept { return alpha_; }      ///< α̂ used in the last tick [unit²/s²]
  double damping() const noexcept { return damping_; }  ///< C(α̂, I) of the last tick [1/s]
  double beta_tilde() const noexcept { return beta_tilde_; }  ///< β̃(α̂, I) of the last tick
  /// Tick-average of v_eff in the last tick [command unit] (what the α filter was fed).
  double command_effective() const noexcept { return v_eff_mean_; }
  /// Largest |v_eff| applied during the last tick [command unit].
  double command_effective_peak() const noexcept { return v_eff_peak_; }
  /// n(θ, θ̇) at the current state [command unit] (the effect disturbances, without d_ext).
  double disturbance() const noexcept { return effect_torque(theta_, theta_dot_); }
  /// n(θ, θ̇) for any state [command unit]. Real-time safe.
  double effect_torque(double theta_rad, double theta_dot_rad_s) const noexcept;
  double inertia() const noexcept { return inertia_; }  ///< I at the pose
  double time_s() const noexcept { return time_s_; }    ///< ticks × T [s]
  long ticks() const noexcept { return ticks_; }        ///< ticks since construction or reset
  const VirtualOmniParams& params() const noexcept { return params_; }

 private:
  void integrate(double t0_s, double duration_s, double input_v, const KnownInputs& known) noexcept;
  template <class Torque>
  void integrate_rk4(const Torque& torque, double t0_s, double duration_s, double input_v,
                     const KnownInputs& known) noexcept;
  void command_path(double command_v, const KnownInputs& known, double& u_early,
                    double& u_late) noexcept;
  void integrate_exact(double duration_s, double input_v, const KnownInputs& known) noexcept;
  double measure(double theta_rad) noexcept;
  double gaussian() noexcept;

  VirtualOmniParams params_;
  double inertia_ = 1.0;
  AlphaModelAtInertia alpha_at_pose_;  ///< params_.alpha_model at inertia_ (bit for bit the same)
  bool exact_segments_ = false;  ///< exact_constant_segments and n free of the state
  TorqueEffects torque_;  ///< params_.effects precomputed (used with precomputed_torque)
  rt::AlphaEstimator estimator_;
  std::vector<double> delay_line_;  ///< last delay_line_.size() commands, sized at construction
  std::size_t delay_head_ = 0;      ///< index of the newest command
  std::size_t delay_ticks_ = 0;     ///< m = floor(τ/T)
  double delay_fraction_ = 0.0;     ///< τ/T − m
  std::mt19937_64 rng_;
  bool has_spare_gaussian_ = false;
  double spare_gaussian_ = 0.0;
  double theta_ = 0.0, theta_dot_ = 0.0, theta_measured_ = 0.0;
  double alpha_ = 0.0, damping_ = 0.0, beta_tilde_ = 0.0;
  double v_eff_mean_ = 0.0, v_eff_peak_ = 0.0;
  double time_s_ = 0.0;
  long ticks_ = 0;
  /// The discovered term's memory terms (effects.hpp DiscoveredMemory): advanced at the start of
  /// each tick from the true state, their torque held over the tick like d_ext.
  bool memory_on_ = false;
  double memory_lag_decay_ = 0.0;
  double memory_theta_prev_ = 0.0;
  DiscoveredMemory memory_;
};

/// Options of run_closed_loop.
struct ClosedLoopOptions {
  /// Add the truth columns `theta_true` [rad], `theta_dot_true` [rad/s] (state at t_k), `v_eff`
  /// (tick-average applied command of tick k), `alpha_true` (α̂ of tick k), `c_true`,
  /// `beta_tilde_true`.
  bool record_truth = false;
  /// A known external disturbance d_ext(t_k) [command unit], held over tick k and recorded as the
  /// `disturbance_v` column. Empty: none.
  std::function<double(double t_s)> disturbance_v;
  /// The motor enable e(t_k), held over tick k (false: the amplifier gives nothing) and recorded
  /// as the `torque_enable` column (1/0). Empty: always on, no column.
  std::function<bool(double t_s)> torque_enable;
  /// A torque on the joint [command unit] that the run does NOT record, from the true state
  /// (t_k, θ, θ̇) at the start of tick k and held over it: generator- and test-only, for effects
  /// no model knows (invented_effects.hpp). May keep state (called once per tick, in order).
  /// Empty: none.
  std::function<double(double t_s, double theta, double theta_dot)> hidden_torque_v;
  /// A compensation c_k [command unit] added to the PID's command before the clamp, as omni_ctl
  /// --compensate adds its model's (v_k = clamp(PID_k + c_k)), from the tick's time and measured
  /// θ_k; recorded as the `v_comp` column (a known input of simulate.hpp's loops). Empty: none.
  std::function<double(double t_s, double theta_measured)> command_offset_v;
};

/// Runs `omni` from its current state under a DIGITAL PID at its tick period T for `duration_s`:
/// samples k = 0 … N−1, N = round(duration_s/T) + 1, t_k = k·T from the run's start. At each tick
/// the controller reads r_k = r(t_k) and the measurement θ_k (for k = 0 the plant's current
/// measurement), computes
///     e_k = r_k − θ_k,  I_k = I_{k−1} + T·e_k (rectangle rule),
///     D_k = (e_k − e_{k−1})/T  or  −(θ_k − θ_{k−1})/T  (backward difference; D_0 = 0),
///     v_k = clamp(kp·e_k + ki·I_k + kd·D_k [+ c_k], ±v_limit) (eq. (10), no anti-windup),
/// records (t_k, r_k, θ_k, v_k) and steps the plant with v_k held over [t_k, t_k + T).
/// Returns the run in the interchange layout (RunData: t, r, theta = measured, v, plus the optional
/// columns). Not real-time (allocates the result); throws alphainv::Error for duration_s ≤ 0.
RunData run_closed_loop(VirtualOmni& omni, const Controller& controller, const Reference& reference,
                        double duration_s, const ClosedLoopOptions& options = {});

}  // namespace alphainv
