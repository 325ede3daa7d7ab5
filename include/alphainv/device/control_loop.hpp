#pragma once
/// \file rt/control_loop.hpp
/// The 1 kHz tick of omni_ctl, without timing or I/O: the safety supervisor, the P law (eq. (10))
/// with the model-based compensation added to it when asked for (compensator.hpp: the model's
/// effects cancelled, the α-model fed forward along the reference, a jump of the reference
/// followed along a cycloid the clamp allows), behind its clamp and slew limit, the streaming α of
/// the command history (eq. (33)), C(α, I) and
/// β̃(α, I) (eqs. (38)-(42)) with I(γ1, γ2) from the measured pose (eq. (6)). The model's
/// one-step prediction of θ, a monitoring quantity the command does not use, is made off the
/// real-time thread from the records (one_step_predictor.hpp).
///
/// Split like ros2_control: the constructor validates and allocates nothing on the heap after it
/// returns; tick(), set_reference(), set_kp() are noexcept and real-time safe.

#include <array>
#include <cstddef>
#include <cstdint>

#include "alphainv/model/damping_model.hpp"
#include "alphainv/device/compensator.hpp"
#include "alphainv/device/hid_report.hpp"
#include "alphainv/device/transport.hpp"
#include "alphainv/model/effects.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "alphainv/rt/alpha_estimator.hpp"
#include "alphainv/rt/sine_phasor.hpp"

namespace alphainv::rt {

/// Why the loop stopped driving the motor.
enum class Fault : std::uint8_t {
  kNone,
  kDisconnected,    ///< a read or write failed: the device is gone
  kReadStall,       ///< no input report for SafetyLimits::stall_periods ticks
  kCorruptReport,   ///< an input report failed to decode (length, id, checksum)
  kOutOfSequence,   ///< an input report's sequence number repeated, went back or skipped too far
  kEncoderJump,     ///< θ changed by more than max_theta_step_rad in one tick
  kAngleLimit,      ///< |θ| exceeded theta_limit_rad
  kDeadlineMisses,  ///< max_missed_deadlines deadlines in a row were missed
};

/// A one-line description of a fault ("device disconnected", ...). Real-time safe.
const char* to_string(Fault fault) noexcept;

/// Limits the supervisor enforces. Always on; validate() names a bad field.
struct SafetyLimits {
  double max_command_v = 1.0;        ///< |v| ≤ max_command_v [V]
  double max_slew_v_per_s = 200.0;   ///< |v_k − v_{k−1}| ≤ max_slew_v_per_s·T [V/s]
  double theta_limit_rad = 1.0;      ///< |θ| ≤ theta_limit_rad [rad]
  double max_theta_step_rad = 0.05;  ///< |θ_k − θ_{k−1}| per report [rad] (50 rad/s at 1 kHz)
  int stall_periods = 20;            ///< ticks without a new input report before kReadStall
  int max_missed_deadlines = 10;     ///< consecutive deadline misses before kDeadlineMisses
  int max_sequence_gap = 32;         ///< a report's sequence may advance by 1 … this per tick

  /// True when max_command_v fits the DAC (≤ 32767 counts at `dac_counts_per_v`).
  bool scaling_ok(double dac_counts_per_v) const noexcept {
    return max_command_v * dac_counts_per_v <= 32767.0;
  }
};

/// Reference waveforms r(t) (relative to the start of a run, around `offset_rad`).
enum class WaveKind : std::uint8_t { kHold, kSine, kSquare, kStep };

/// r(t) of one run. Real-time safe.
struct Waveform {
  WaveKind kind = WaveKind::kHold;
  double amplitude_rad = 0.0;  ///< A [rad]
  double freq_hz = 0.0;        ///< f [Hz] (sine, square)
  double offset_rad = 0.0;     ///< centre / hold position [rad]

  /// r at t_s [s] since the run's start: hold → offset; sine → offset + A sin(2πft);
  /// square → offset ± A (+A for frac(ft) < 1/2); step → offset + A for t ≥ 0.
  double at(double t_s) const noexcept;
  /// ṙ [rad/s] and r̈ [rad/s²] at t_s: sine Aω·cos(ωt), −Aω²·sin(ωt); the others 0 (their jumps
  /// have no derivative the command could follow). Real-time safe.
  void rates(double t_s, double& r_dot, double& r_ddot) const noexcept;
};

/// y(x) piecewise linear over increasing breakpoints, held outside them, with the segment slopes
/// precomputed (AlphaModel's interpolation without a division in the tick). Real-time safe.
struct HeldLine {
  std::size_t n = 0;
  std::array<double, kMaxBreakpoints> x{}, y{}, slope{};

  /// The line through (x[k], y[k]), k < n (1 ≤ n ≤ kMaxBreakpoints, x increasing); for set-up
  /// (it divides n − 1 times), real-time safe.
  static HeldLine through(const double* x, const double* y, std::size_t n) noexcept;
  /// y at `at`: y[0] below x[0], y[n−1] above x[n−1]. Real-time safe.
  double at(double at_x) const noexcept {
    if (n == 1 || at_x <= x[0]) return y[0];
    if (at_x >= x[n - 1]) return y[n - 1];
    std::size_t k = 1;
    while (at_x > x[k]) ++k;  // x[k-1] < at <= x[k]
    return y[k - 1] + (at_x - x[k - 1]) * slope[k - 1];
  }
};

/// A jump of the reference followed along a cycloid (the modes that feed forward): from r0 to r1
/// over D seconds from t0,
///     r(t) = r0 + (r1 − r0)·(u − sin(2πu)/(2π)),  u = (t − t0)/D ∈ [0, 1],
/// whose velocity and acceleration start and end at 0 (no impulse in the feedforward) and peak at
/// 2(r1 − r0)/D and 2π(r1 − r0)/D². Real-time safe.
struct ReferenceTransition {
  double from_rad = 0.0, to_rad = 0.0, t0_s = 0.0, duration_s = 0.0;
  /// r [rad], ṙ [rad/s], r̈ [rad/s²] at t_s.
  void sample(double t_s, double& r, double& r_dot, double& r_ddot) const noexcept;
  /// D [s] of the fastest such transition over `distance_rad` whose feedforward
  /// (r̈ + C·ṙ)/β̃ stays within `command_v` (bounded by its peaks, with the largest C [1/s] and
  /// the smallest β̃ the model has at this pose): 2π·h/D² + 2C·h/D = β̃·command_v.
  static double fastest_duration_s(double distance_rad, double damping_max,
                                   double beta_tilde_min, double command_v) noexcept;
};

/// Constant parameters of the loop.
struct ControlLoopConfig {
  double period_s = 1e-3;  ///< tick period T [s]
  double kp = 2.0;         ///< P gain [V/rad]
  double kp_max = 10.0;    ///< largest P gain set_kp() accepts [V/rad]
  SafetyLimits safety;
  AlphaEstimatorConfig estimator{};              ///< its sample_period_s is set to period_s
  InertiaModel inertia = paper_inertia_model();  ///< I(γ1, γ2), eq. (6)
  AlphaModel model = paper_alpha_model();        ///< C(α, I), β̃(α, I), eqs. (38)-(42)
  /// Effects of the model (effects.hpp; model.json's "effects", e.g. from omni_fit diagnose): α̂
  /// is that of S(Z(v(t − τ))), the compensation cancels them, and the prediction
  /// (one_step_predictor.hpp) uses u = S(Z(v(t − τ))) + n(θ, θ̇) for v. The delay is rounded to
  /// whole ticks, at most ControlLoop::kMaxDelayTicks.
  Effects effects;
  device::ReportScaling scaling;                 ///< counts ↔ rad, V ↔ DAC counts
  /// What is added to the P law (off by default): `effects` cancelled, the α-model fed forward.
  CompensatorConfig compensation;

  /// Throws alphainv::Error naming the first bad field. Not real-time.
  void validate() const;
};

/// What one tick did (one row of the recording).
struct TickRecord {
  double t_s = 0.0;              ///< time since the loop started [s]
  double r_rad = 0.0;            ///< reference [rad]
  double theta_rad = 0.0;        ///< measured θ [rad] (held when no new report arrived)
  double gamma1_rad = 0.0;       ///< measured γ1 [rad]
  double gamma2_rad = 0.0;       ///< measured γ2 [rad]
  double command_v = 0.0;        ///< command sent, after clamp, slew limit and DAC rounding [V]
  double p_command_v = 0.0;      ///< the P law's kp·(r − θ) [V]
  double comp_command_v = 0.0;   ///< the compensation added to it, before the clamp [V]
  double alpha = 0.0;            ///< α̂ of the command history [V²/s²], eq. (33)
  double damping = 0.0;          ///< C(α̂, I) [1/s]
  double beta_tilde = 0.0;       ///< β̃(α̂, I) [rad/s² per V]
  double inertia = 0.0;          ///< I(γ1, γ2)
  /// The model's prediction of this θ, made one tick earlier [rad]: filled off the real-time
  /// thread by OneStepPredictor::add() (the tick leaves it 0).
  double theta_pred_rad = 0.0;
  double wake_latency_s = 0.0;   ///< wake-up time minus the deadline [s] (set by the runner)
  double period_jitter_s = 0.0;  ///< |wake-up − previous wake-up − T| [s] (set by the runner)
  double read_s = 0.0;           ///< duration of read_latest() [s] (set by the runner)
  double write_s = 0.0;          ///< duration of write() [s] (set by the runner)
  std::uint16_t sequence = 0;    ///< sequence of the newest input report
  std::int16_t dac_counts = 0;   ///< DAC counts sent
  bool enable = false;           ///< amplifier enable sent
  bool new_report = false;       ///< a new input report arrived this tick
  bool deadline_missed = false;  ///< the previous tick overran its period
  /// Deadlines passed without a tick before this one: the previous tick overran them (set by the
  /// runner; ≥ 1 when deadline_missed).
  std::uint32_t deadlines_skipped = 0;
  Fault fault = Fault::kNone;    ///< the fault in force (the command is then 0, disabled)
};

/// The tick (see the file comment). Not thread-safe: one thread calls tick(), set_reference() and
/// set_kp().
class ControlLoop {
 public:
  /// Validates `config` (throws alphainv::Error naming the field).
  explicit ControlLoop(const ControlLoopConfig& config);

  /// One tick at time t_s [s]: supervises `input` (and `deadline_missed`, whether the previous
  /// tick overran), runs the P law on the reference, and fills `out_report` with the output report
  /// to send now (0 and disabled once a fault is latched, or before the first report).
  /// Real-time safe: no allocation, no locks, no I/O.
  TickRecord tick(double t_s, const device::ReadResult& input, bool deadline_missed,
                  device::OutputReport& out_report) noexcept;

  /// Latches a fault from outside (e.g. a failed write); the next report is 0 and disabled.
  /// Real-time safe.
  void latch(Fault fault) noexcept;
  /// Starts waveform `wave` at t_start_s [s]; with `relative`, its offset is added to the current
  /// measured θ. Real-time safe.
  void set_reference(const Waveform& wave, double t_start_s, bool relative) noexcept;
  /// Holds the current measured θ. Real-time safe.
  void hold() noexcept;
  /// Sets the P gain; false (unchanged) unless 0 ≤ kp ≤ kp_max. Real-time safe.
  [[nodiscard]] bool set_kp(double kp) noexcept;
  /// An output report that zeroes the command and disables the motor (next sequence number).
  /// Real-time safe.
  device::OutputReport safe_report() noexcept;

  Fault fault() const noexcept { return fault_; }
  double kp() const noexcept { return kp_; }
  double theta_rad() const noexcept { return theta_; }
  bool has_measurement() const noexcept { return have_report_; }
  const Waveform& waveform() const noexcept { return wave_; }
  const ControlLoopConfig& config() const noexcept { return config_; }

  /// The longest model delay the command history holds [ticks].
  static constexpr std::size_t kMaxDelayTicks = 1023;
  /// The model's delay in whole ticks (config.effects.delay_s rounded, at most kMaxDelayTicks):
  /// the tick's and the prediction's (one_step_predictor.hpp).
  static std::size_t delay_ticks(const ControlLoopConfig& config) noexcept;

 private:
  void supervise(const device::ReadResult& input, bool deadline_missed) noexcept;

  /// I(γ1, γ2) and 1/I at the measured pose (the tick calls it only when the pose changed).
  void update_inertia() noexcept;
  /// In the modes that feed forward, for the piecewise-constant waveforms (the tick calls it only
  /// there; the sine is followed as it is, in the tick; without the feedforward r is the
  /// waveform's own): the reference r the P law tracks and ṙ and r̈ at the tick's middle plus τ (`lead_s`),
  /// at t_wave [s] since the waveform's start; `raw` is the waveform's own r (recorded).
  void reference(double t_wave, double lead_s, double raw, double& r, double& r_dot,
                 double& r_ddot) noexcept;

  ControlLoopConfig config_;
  AlphaEstimator estimator_;
  Compensator compensator_;
  /// C·I and β̃·I of the model against α (C = damping_line_.at(α)/I, eqs. (38)-(42)); their
  /// largest and smallest values (the transition's budget).
  HeldLine damping_line_, beta_line_;
  double damping_i_max_ = 0.0, beta_i_min_ = 0.0;
  double inertia_ = 0.0, inv_inertia_ = 0.0;
  double inertia_gamma1_ = 0.0, inertia_gamma2_ = 0.0;
  bool have_inertia_ = false;
  /// The sine's ω = 2πf, and cos, sin of ω·lead (the feedforward's reference, rotated).
  double omega_ = 0.0, cos_lead_ = 1.0, sin_lead_ = 0.0;
  /// sin, cos of the sine's phase ω·t, rotated by ω·T from the previous tick's (sine_phasor.hpp).
  SinePhasor reference_phasor_;
  /// The jump being followed (feedforward modes) and the waveform's value it goes to.
  ReferenceTransition transition_;
  double raw_target_ = 0.0;
  bool have_raw_target_ = false;
  bool have_reference_ = false;  ///< transition_ holds the reference now followed
  /// A default TickRecord, copied into each tick's record: the compiler turns a value-initialised
  /// record into a `rep stos`, whose start-up cost was 9 % of the tick (perf), and a copy of a
  /// member it cannot see into into nine SSE moves.
  TickRecord blank_record_{};
  double alpha_prev_ = 0.0;  ///< the previous tick's α̂ (for the feedforward)
  /// The previous tick's C(α̂, I) and β̃(α̂, I) (the feedforward's; 0 before the first tick).
  double c_last_ = 0.0, beta_last_ = 0.0;
  double kp_;
  Waveform wave_;
  double wave_start_s_ = 0.0;
  Fault fault_ = Fault::kNone;
  bool have_report_ = false;
  std::uint16_t last_sequence_ = 0;
  int ticks_without_report_ = 0;
  int consecutive_misses_ = 0;
  std::uint16_t out_sequence_ = 0;
  double theta_ = 0.0, gamma1_ = 0.0, gamma2_ = 0.0;
  double v_prev_ = 0.0;  ///< the previous tick's command (the slew limit)
  /// Commands sent, for the model's delay (a ring; no allocation in the tick).
  std::array<double, kMaxDelayTicks + 1> v_history_{};
  std::size_t v_head_ = 0;
  std::size_t delay_ticks_ = 0;
};

}  // namespace alphainv::rt
