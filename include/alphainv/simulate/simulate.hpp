#pragma once
/// \file simulate.hpp
/// Closed-loop simulation of θ̈ + C(α,I)·θ̇ = β̃(α,I)·v(t) under the PID law, eq. (43), by the
/// paper's fixed-point scheme (44)-(46) on a fixed-step RK4 grid, or by SUNDIALS CVODE on the same
/// right-hand side, with the effects of effects.hpp added to eq. (11). Or, with
/// SimulationOptions::loop_period_s > 0, as the digital loop a real rig runs: the PID law sampled
/// every tick with its command held over the tick (zero-order hold) and α from the streaming
/// estimator on the applied command (the plant of virtual_omni.hpp, without measurement effects;
/// each tick stepped exactly where no effect depends on the state, by one RK4 step where the
/// torque is a smooth function of θ, by the generator's 4 or more with friction:
/// model_simulation_substeps(); the torque n(θ, θ̇) by TorqueEffects, equal to effect_torque() to
/// rounding: VirtualOmniParams::precomputed_torque).
/// Not real-time (allocates the result); never throws on bad input: the result says.

#include <cstddef>
#include <string>
#include <vector>

#include "alphainv/model/controller.hpp"
#include "alphainv/model/damping_model.hpp"
#include "alphainv/model/effects.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "alphainv/simulate/known_inputs.hpp"
#include "alphainv/simulate/reference.hpp"

namespace alphainv {

/// The joint model at one pose (constant inertia I during a run).
struct JointModelAtPose {
  bool use_alpha = true;          ///< false: the global linear model (26), C and β̃ constant
  double inertia = 1.0;           ///< I at the run's pose (use 1 with per-pose C_n1 = 1/C_n)
  double c_linear = 0.0;          ///< C_linear(I) [1/s]; also the start of the fixed point (45)
  double beta_tilde_linear = 0.0; ///< β̃_linear(I) [rad/s² per command unit]
  AlphaModel alpha;               ///< used when use_alpha
  Effects effects;                ///< effects beyond the model (effects.hpp), all off by default
};

/// The model at pose (γ1, γ2): I from the inertia model (6), C_linear and β̃_linear from (24)-(25),
/// and the α-model. Real-time safe.
inline JointModelAtPose model_at_pose(const LinearModel& linear, const AlphaModel& alpha,
                                      double gamma1_rad, double gamma2_rad,
                                      bool use_alpha = true) noexcept {
  JointModelAtPose m;
  m.use_alpha = use_alpha;
  m.inertia = linear.inertia.inertia(gamma1_rad, gamma2_rad);
  m.c_linear = linear.damping(m.inertia);
  m.beta_tilde_linear = linear.beta_tilde(m.inertia);
  m.alpha = alpha;
  return m;
}

/// Which integrator.
enum class Integrator { kFixedPointRk4, kCvode };

/// Simulation settings.
struct SimulationOptions {
  Integrator integrator = Integrator::kFixedPointRk4;
  double max_step_s = 1e-3;         ///< RK4 step bound [s] (steps also end at every output time)
  double alpha_abs_tol = 1e-6;      ///< eq. (46) absolute tolerance
  double alpha_rel_tol = 1e-3;      ///< eq. (46) relative tolerance
  int max_iterations = 50;          ///< fixed-point iteration cap per right-hand-side evaluation
  double cvode_rel_tol = 1e-8;      ///< CVODE relative tolerance
  double cvode_abs_tol = 1e-10;     ///< CVODE absolute tolerance
  /// > 0: simulate the digital loop with this tick period [s] (see the file comment); the output
  /// times are then interpolated linearly from the ticks t0 + k·T. 0: the continuous law (43).
  double loop_period_s = 0.0;
  /// Digital loop: the α estimator's cut-off [Hz], used up to 0.2/T (a cut-off must lie below
  /// 0.25/T, the filter's stability bound: data at 40 Hz run the filter at 8 Hz), see
  /// loop_alpha_cutoff_hz(const SimulationOptions&).
  double loop_alpha_cutoff_hz = 25.0;
};

/// The α estimator's cut-off the digital loop uses [Hz]: min(loop_alpha_cutoff_hz, 0.2/T) with
/// T = loop_period_s (loop_alpha_cutoff_hz when T ≤ 0). Real-time safe.
inline double loop_alpha_cutoff_hz(const SimulationOptions& options) noexcept {
  const double T = options.loop_period_s;
  return T > 0.0 && options.loop_alpha_cutoff_hz > 0.2 / T ? 0.2 / T
                                                            : options.loop_alpha_cutoff_hz;
}

/// Simulated trajectory at the requested times and how the solver did.
struct SimulationResult {
  std::vector<double> t;           ///< [s]
  std::vector<double> theta;       ///< θ [position unit]
  std::vector<double> theta_dot;   ///< Φ = θ̇ [position unit/s]
  std::vector<double> v;           ///< command [command unit]
  std::vector<double> alpha;       ///< α [command unit²/s²]
  std::vector<double> damping;     ///< C(α, I) [1/s]
  std::vector<double> beta_tilde;  ///< β̃(α, I)
  long rhs_evaluations = 0;
  long fixed_point_iterations = 0;  ///< summed over all right-hand-side evaluations
  int max_fixed_point_iterations = 0;
  long fixed_point_not_converged = 0;  ///< evaluations that hit max_iterations
  bool ok = false;
  std::string message;
  double mean_iterations() const {
    return rhs_evaluations > 0 ? static_cast<double>(fixed_point_iterations) /
                                     static_cast<double>(rhs_evaluations)
                               : 0.0;
  }
};

/// Initial state.
struct InitialState {
  InitialState() = default;
  InitialState(double theta_0, double theta_dot_0 = 0.0, double integral_0 = 0.0)
      : theta(theta_0), theta_dot(theta_dot_0), integral(integral_0) {}

  double theta = 0.0;      ///< θ(t0)
  double theta_dot = 0.0;  ///< θ̇(t0)
  double integral = 0.0;   ///< ∫e dt at t0 (PID only)
  /// Digital loop only: the commands of the ticks before t0 (oldest first), which prime the α
  /// filter and the delay line as a run started mid-way left them. Empty: at rest before t0.
  std::vector<double> command_history;
};

/// Simulates from times.front() and reports at each entry of `times_s` (strictly increasing).
/// A time delay in model.effects needs the fixed-point RK4 integrator (v(t − τ) is interpolated
/// linearly between the commands at the starts of the steps taken and, for τ shorter than a step,
/// the command at t; the steps do not depend on τ) or the digital loop.
/// `known_inputs` (a disturbance d(t) and the motor enable e(t), known_inputs.hpp) enter the
/// plant's input u of plant_input.hpp: held over each RK4 step at their value at the step's middle
/// (their zero-order hold when their samples are output times), at each tick of the digital loop,
/// and at every evaluation of CVODE. α stays that of the controller's command.
SimulationResult simulate(const JointModelAtPose& model, const Controller& controller,
                          const Reference& reference, const std::vector<double>& times_s,
                          const InitialState& initial = {}, const SimulationOptions& options = {},
                          const KnownInputSeries& known_inputs = KnownInputSeries{});

/// Simulates an open-loop run: θ̈ + C(α, I)·θ̇ = β̃(α, I)·u with the command v(t) = command.r(t)
/// (a recorded voltage, e.g. SampledReference of a run's v column; its slopes r_dot, r_ddot give
/// α by eq. (33)) instead of a controller's law; no clamp (the command is what was applied). The
/// digital loop (options.loop_period_s > 0) holds command.r(t_k) over tick k. Otherwise as
/// simulate().
SimulationResult simulate_open_loop(const JointModelAtPose& model, const Reference& command,
                                    const std::vector<double>& times_s,
                                    const InitialState& initial = {},
                                    const SimulationOptions& options = {},
                                    const KnownInputSeries& known_inputs = KnownInputSeries{});

/// Whether `controller` is no controller: kp = ki = kd = 0 (kUnstatedController, a dataset that
/// states none): the run is open loop, its recorded v the input. Real-time safe.
inline bool is_open_loop(const Controller& controller) noexcept {
  return controller.kp == 0.0 && controller.ki == 0.0 && controller.kd == 0.0;
}

/// Uniform time grid t0, t0 + dt, …, up to and including duration (within dt/2).
std::vector<double> uniform_times(double duration_s, double dt_s, double t0_s = 0.0);

}  // namespace alphainv
