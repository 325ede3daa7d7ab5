#include "alphainv/device/control_loop.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "alphainv/error.hpp"
#include "alphainv/model/detail/fast_math.hpp"
#include "alphainv/model/plant_input.hpp"

namespace alphainv::rt {
namespace {

AlphaEstimatorConfig estimator_for(const ControlLoopConfig& c) {
  AlphaEstimatorConfig e = c.estimator;
  e.sample_period_s = c.period_s;
  return e;
}

/// sin x and cos x in one inline evaluation (fast_math.hpp: within 2 ulp of std::sin, std::cos;
/// glibc's sincos was 13 % of the compensated tick). Real-time safe.
inline void sin_cos(double x, double& s, double& c) noexcept { detail::fast_sin_cos(x, s, c); }

void require(bool ok, const std::string& field, const std::string& expected, double got) {
  if (!ok) throw Error("expected " + expected + ", got " + std::to_string(got), {}, 0, field);
}

}  // namespace

const char* to_string(Fault fault) noexcept {
  switch (fault) {
    case Fault::kNone:
      return "no fault";
    case Fault::kDisconnected:
      return "device disconnected (a read or write failed)";
    case Fault::kReadStall:
      return "input reports stalled (no new report for too many periods)";
    case Fault::kCorruptReport:
      return "corrupt input report (length, report id or checksum)";
    case Fault::kOutOfSequence:
      return "input report out of sequence";
    case Fault::kEncoderJump:
      return "encoder jump (theta changed too much in one tick)";
    case Fault::kAngleLimit:
      return "angle limit exceeded";
    case Fault::kDeadlineMisses:
      return "too many deadlines missed in a row";
  }
  return "unknown fault";
}

double Waveform::at(double t_s) const noexcept {
  switch (kind) {
    case WaveKind::kHold:
      return offset_rad;
    case WaveKind::kSine:
      return offset_rad + amplitude_rad * std::sin(2.0 * kPi * freq_hz * t_s);
    case WaveKind::kSquare: {
      const double cycles = freq_hz * t_s;
      return cycles - std::floor(cycles) < 0.5 ? offset_rad + amplitude_rad
                                               : offset_rad - amplitude_rad;
    }
    case WaveKind::kStep:
      return t_s >= 0.0 ? offset_rad + amplitude_rad : offset_rad;
  }
  return offset_rad;
}

void Waveform::rates(double t_s, double& r_dot, double& r_ddot) const noexcept {
  r_dot = r_ddot = 0.0;
  if (kind != WaveKind::kSine) return;
  const double w = 2.0 * kPi * freq_hz;
  r_dot = amplitude_rad * w * std::cos(w * t_s);
  r_ddot = -amplitude_rad * w * w * std::sin(w * t_s);
}

HeldLine HeldLine::through(const double* x, const double* y, std::size_t n) noexcept {
  HeldLine l;
  l.n = std::min(n, kMaxBreakpoints);
  for (std::size_t k = 0; k < l.n; ++k) {
    l.x[k] = x[k];
    l.y[k] = y[k];
  }
  for (std::size_t k = 0; k + 1 < l.n; ++k) l.slope[k] = (y[k + 1] - y[k]) / (x[k + 1] - x[k]);
  return l;
}

void ReferenceTransition::sample(double t_s, double& r, double& r_dot,
                                 double& r_ddot) const noexcept {
  r_dot = r_ddot = 0.0;
  if (!(duration_s > 0.0) || t_s >= t0_s + duration_s) {
    r = to_rad;
    return;
  }
  if (t_s <= t0_s) {
    r = from_rad;
    return;
  }
  const double u = (t_s - t0_s) / duration_s;
  const double phase = 2.0 * kPi * u;
  double s = 0.0, c = 1.0;
  sin_cos(phase, s, c);
  const double h = to_rad - from_rad;
  r = from_rad + h * (u - s / (2.0 * kPi));
  r_dot = h / duration_s * (1.0 - c);
  r_ddot = h * 2.0 * kPi / (duration_s * duration_s) * s;
}

double ReferenceTransition::fastest_duration_s(double distance_rad, double damping_max,
                                               double beta_tilde_min, double command_v) noexcept {
  const double h = std::abs(distance_rad);
  if (!(h > 0.0) || !(beta_tilde_min > 0.0) || !(command_v > 0.0)) return 0.0;
  // x = 1/D solves 2πh·x² + 2Ch·x − β̃V = 0 (the peaks of r̈ and C·ṙ added: a bound).
  const double c = std::max(damping_max, 0.0);
  const double b = 2.0 * c * h;
  const double x = (-b + std::sqrt(b * b + 8.0 * kPi * h * beta_tilde_min * command_v)) /
                   (4.0 * kPi * h);
  return 1.0 / x;
}

void ControlLoopConfig::validate() const {
  validate_effects(effects, "effects.");
  compensation.validate(period_s);
  require(std::isfinite(period_s) && period_s >= 1e-5 && period_s <= 0.1, "period_s",
          "10 us <= period <= 100 ms", period_s);
  require(std::isfinite(kp_max) && kp_max > 0.0, "kp_max", "a positive number", kp_max);
  require(std::isfinite(kp) && kp >= 0.0 && kp <= kp_max, "kp",
          "0 <= kp <= " + std::to_string(kp_max), kp);
  const SafetyLimits& s = safety;
  require(std::isfinite(s.max_command_v) && s.max_command_v > 0.0 &&
              s.scaling_ok(scaling.dac_counts_per_v),
          "max_command_v", "0 < max command <= the DAC's full scale", s.max_command_v);
  require(std::isfinite(s.max_slew_v_per_s) && s.max_slew_v_per_s > 0.0, "max_slew_v_per_s",
          "a positive slew limit [V/s]", s.max_slew_v_per_s);
  require(std::isfinite(s.theta_limit_rad) && s.theta_limit_rad > 0.0, "theta_limit_rad",
          "a positive angle limit [rad]", s.theta_limit_rad);
  require(std::isfinite(s.max_theta_step_rad) && s.max_theta_step_rad > 0.0, "max_theta_step_rad",
          "a positive step [rad]", s.max_theta_step_rad);
  require(s.stall_periods >= 1, "stall_periods", "at least 1", s.stall_periods);
  require(s.max_missed_deadlines >= 1, "max_missed_deadlines", "at least 1",
          s.max_missed_deadlines);
  require(s.max_sequence_gap >= 1 && s.max_sequence_gap < 32768, "max_sequence_gap", "1 … 32767",
          s.max_sequence_gap);
  for (std::size_t j = 0; j < 3; ++j) {
    require(std::isfinite(scaling.counts_per_rad[j]) && scaling.counts_per_rad[j] > 0.0,
            "scaling.counts_per_rad[" + std::to_string(j) + "]", "a positive number",
            scaling.counts_per_rad[j]);
  }
  require(model.valid(), "model", "a valid alpha model (breakpoints increasing, C_n1 > 0)",
          static_cast<double>(model.n_breakpoints));
}

ControlLoop::ControlLoop(const ControlLoopConfig& config)
    : config_((config.validate(), config)),
      estimator_(estimator_for(config)),
      compensator_(config.compensation, config.effects, config.period_s),
      kp_(config.kp) {
  estimator_.reset(0.0);
  // C·I and β̃·I against α: the model's breakpoint values 1/C_n1, 1/β̃_n1 (eqs. (40), (42)).
  const AlphaModel& m = config_.model;
  std::array<double, kMaxBreakpoints> c_i{};
  for (std::size_t n = 0; n < m.n_breakpoints; ++n) {
    c_i[n] = 1.0 / m.c_n1[n];
    damping_i_max_ = std::max(damping_i_max_, c_i[n]);
  }
  damping_line_ = HeldLine::through(m.alpha.data(), c_i.data(), m.n_breakpoints);
  const double b_i[2] = {1.0 / m.beta_n1[0], 1.0 / m.beta_n1[1]};
  beta_line_ = HeldLine::through(m.beta_alpha.data(), b_i, 2);
  beta_i_min_ = std::min(b_i[0], b_i[1]);
  set_reference(wave_, 0.0, false);  // the sine's constants
  delay_ticks_ = delay_ticks(config_);
}

std::size_t ControlLoop::delay_ticks(const ControlLoopConfig& config) noexcept {
  const double ticks = std::round(config.effects.delay_s / config.period_s);
  return static_cast<std::size_t>(std::min(ticks, static_cast<double>(kMaxDelayTicks)));
}

void ControlLoop::latch(Fault fault) noexcept {
  if (fault_ == Fault::kNone) fault_ = fault;
}

void ControlLoop::set_reference(const Waveform& wave, double t_start_s, bool relative) noexcept {
  wave_ = wave;
  if (relative) wave_.offset_rad += theta_;
  wave_start_s_ = t_start_s;
  omega_ = 2.0 * kPi * wave_.freq_hz;  // as Waveform::at evaluates it
  const double lead = omega_ * compensator_.lead_s();
  cos_lead_ = std::cos(lead);
  sin_lead_ = std::sin(lead);
  reference_phasor_.set_step(omega_ * config_.period_s);
}

void ControlLoop::update_inertia() noexcept {
  inertia_ = config_.inertia.inertia(gamma1_, gamma2_);
  inv_inertia_ = 1.0 / inertia_;
  inertia_gamma1_ = gamma1_;
  inertia_gamma2_ = gamma2_;
  have_inertia_ = true;
}

void ControlLoop::reference(double t_s, double lead_s, double raw, double& r, double& r_dot,
                            double& r_ddot) noexcept {
  r = raw;
  r_dot = r_ddot = 0.0;
  // Piecewise constant (hold, step, square): each jump followed along the fastest cycloid the
  // clamp allows (ReferenceTransition), from where the reference is now.
  if (!have_raw_target_ || raw != raw_target_) {
    double from = raw, unused_dot = 0.0, unused_ddot = 0.0;
    if (have_reference_) transition_.sample(t_s, from, unused_dot, unused_ddot);
    const double budget_v =
        config_.compensation.transition_command_fraction * config_.safety.max_command_v;
    transition_ = ReferenceTransition{
        from, raw, t_s,
        ReferenceTransition::fastest_duration_s(raw - from, damping_i_max_ * inv_inertia_,
                                                beta_i_min_ * inv_inertia_, budget_v)};
    raw_target_ = raw;
    have_raw_target_ = true;
    have_reference_ = true;
  }
  double unused_dot = 0.0, unused_ddot = 0.0;
  transition_.sample(t_s, r, unused_dot, unused_ddot);
  double unused_r = 0.0;
  transition_.sample(t_s + lead_s, unused_r, r_dot, r_ddot);
}

void ControlLoop::hold() noexcept {
  wave_ = Waveform{WaveKind::kHold, 0.0, 0.0, theta_};
  wave_start_s_ = 0.0;
  reference_phasor_.reset();
}

bool ControlLoop::set_kp(double kp) noexcept {
  if (!(kp >= 0.0 && kp <= config_.kp_max)) return false;
  kp_ = kp;
  return true;
}

device::OutputReport ControlLoop::safe_report() noexcept {
  device::OutputReport out;
  out.sequence = out_sequence_++;
  out.dac_counts = 0;
  out.enable = false;
  return out;
}

void ControlLoop::supervise(const device::ReadResult& input, bool deadline_missed) noexcept {
  const SafetyLimits& s = config_.safety;
  consecutive_misses_ = deadline_missed ? consecutive_misses_ + 1 : 0;
  if (consecutive_misses_ >= s.max_missed_deadlines) latch(Fault::kDeadlineMisses);
  switch (input.status) {
    case device::IoStatus::kDisconnected:
      latch(Fault::kDisconnected);
      return;
    case device::IoStatus::kCorrupt:
      latch(Fault::kCorruptReport);
      return;
    case device::IoStatus::kNoData:
      if (++ticks_without_report_ >= s.stall_periods) latch(Fault::kReadStall);
      return;
    case device::IoStatus::kOk:
      break;
  }
  ticks_without_report_ = 0;
  const device::InputReport& in = input.report;
  if (have_report_) {
    const auto advance = static_cast<std::uint16_t>(in.sequence - last_sequence_);
    if (advance == 0 || advance > s.max_sequence_gap) latch(Fault::kOutOfSequence);
  }
  last_sequence_ = in.sequence;
  const device::ReportScaling& sc = config_.scaling;
  const double theta = sc.angle_rad(0, in.encoder_counts[0]);
  if (have_report_ && std::abs(theta - theta_) > s.max_theta_step_rad) latch(Fault::kEncoderJump);
  if (!(std::abs(theta) <= s.theta_limit_rad)) latch(Fault::kAngleLimit);
  theta_ = theta;
  gamma1_ = sc.angle_rad(1, in.encoder_counts[1]);
  gamma2_ = sc.angle_rad(2, in.encoder_counts[2]);
  if (!have_report_) {
    have_report_ = true;
    if (wave_.kind == WaveKind::kHold) wave_.offset_rad = theta;
  }
}

TickRecord ControlLoop::tick(double t_s, const device::ReadResult& input, bool deadline_missed,
                             device::OutputReport& out_report) noexcept {
  const bool was_faulted = fault_ != Fault::kNone;
  if (!was_faulted) supervise(input, deadline_missed);
  const bool new_report = input.status == device::IoStatus::kOk && !was_faulted;

  TickRecord rec = blank_record_;  // not `TickRecord rec;`: see blank_record_
  rec.t_s = t_s;
  rec.theta_rad = theta_;
  rec.gamma1_rad = gamma1_;
  rec.gamma2_rad = gamma2_;
  rec.sequence = last_sequence_;
  rec.new_report = new_report;
  rec.deadline_missed = deadline_missed;
  rec.fault = fault_;
  const CompensationMode mode = config_.compensation.mode;
  const bool ff = feeds_forward(mode);
  const double t_wave = t_s - wave_start_s_;
  double sine_sin = 0.0, sine_cos = 0.0;
  if (wave_.kind == WaveKind::kSine) {  // Waveform::at (its sin to 1e-14), with cos(ωt) for ff
    reference_phasor_.sin_cos(omega_ * t_wave, sine_sin, sine_cos);
    rec.r_rad = wave_.offset_rad + wave_.amplitude_rad * sine_sin;
  } else {
    rec.r_rad = wave_.at(t_wave);
  }

  if (fault_ != Fault::kNone || !have_report_) {
    out_report = safe_report();
    compensator_.reset();
    v_prev_ = 0.0;
    have_raw_target_ = have_reference_ = false;
    rec.r_rad = fault_ != Fault::kNone ? rec.r_rad : theta_;
    return rec;
  }

  // P law, eq. (10) with ki = kd = 0, on the reference r (in the modes that feed forward, a jump
  // of the waveform followed along a cycloid the clamp allows), plus the compensation
  // (compensator.hpp), then the clamp and the slew limit.
  if (!(have_inertia_ && gamma1_ == inertia_gamma1_ && gamma2_ == inertia_gamma2_)) update_inertia();
  const double inertia = inertia_;
  compensator_.observe(theta_, new_report);
  double r = rec.r_rad, r_dot = 0.0, r_ddot = 0.0;
  if (ff) {  // (without the feedforward the reference is the waveform's own r: no call)
    if (wave_.kind != WaveKind::kSine) {
      reference(t_s, compensator_.lead_s(), rec.r_rad, r, r_dot, r_ddot);
    } else {
      // reference()'s sine case, inline (a call per tick for four stores): a later jump starts
      // from here.
      have_raw_target_ = false;
      have_reference_ = true;
      transition_ = ReferenceTransition{r, r, t_s, 0.0};
      // ṙ, r̈ at the tick's middle plus τ: (sin, cos)(ω(t + lead)) by rotating (sin, cos)(ωt).
      const double s_lead = sine_sin * cos_lead_ + sine_cos * sin_lead_;
      const double c_lead = sine_cos * cos_lead_ - sine_sin * sin_lead_;
      const double a_w = wave_.amplitude_rad * omega_;
      r_dot = a_w * c_lead;
      r_ddot = -a_w * omega_ * s_lead;
    }
  }
  const double v_p = kp_ * (r - theta_);
  double v = v_p;
  if (mode != CompensationMode::kNone) {
    double v_ff = 0.0;
    if (ff) {  // r̈ + C(α̂, I)·ṙ = β̃(α̂, I)·v_ff
      if (!(c_last_ > 0.0)) {  // the first tick: C, β̃ at the estimator's α̂ and this pose
        c_last_ = damping_line_.at(alpha_prev_) * inv_inertia_;
        beta_last_ = beta_line_.at(alpha_prev_) * inv_inertia_;
      }
      v_ff = feedforward_command(r_dot, r_ddot, c_last_, beta_last_);
    }
    // C/β̃ of the previous tick (the damping compensation; 0 before the first tick's C, β̃).
    const double damping_per_beta =
        config_.compensation.damping_fraction > 0.0 && beta_last_ > 0.0 ? c_last_ / beta_last_ : 0.0;
    v = compensator_.command(v_p, v_ff, r_dot, r - theta_, damping_per_beta);
  }
  rec.p_command_v = std::isfinite(v_p) ? v_p : 0.0;
  rec.comp_command_v = std::isfinite(v) ? v - rec.p_command_v : 0.0;
  const SafetyLimits& s = config_.safety;
  if (!std::isfinite(v)) v = 0.0;
  v = std::min(std::max(v, -s.max_command_v), s.max_command_v);
  const double max_step = s.max_slew_v_per_s * config_.period_s;
  v = std::min(std::max(v, v_prev_ - max_step), v_prev_ + max_step);
  out_report.sequence = out_sequence_++;
  out_report.dac_counts = config_.scaling.dac(v);
  out_report.enable = true;
  v = config_.scaling.command_v(out_report.dac_counts);  // what the device receives

  // The model's input: the command through its effects (delay, deadzone, saturation).
  v_head_ = (v_head_ + 1) % v_history_.size();
  v_history_[v_head_] = v;
  const double v_model = applied_command(
      config_.effects, v_history_[(v_head_ + v_history_.size() - delay_ticks_) % v_history_.size()]);

  // α̂ of the command history (eq. (33)), I (eq. (6)), C and β̃ (eqs. (38)-(42)).
  const double alpha = estimator_.update(v_model).alpha;
  alpha_prev_ = alpha;
  const double c = damping_line_.at(alpha) * inv_inertia_;
  const double beta = beta_line_.at(alpha) * inv_inertia_;
  c_last_ = c;
  beta_last_ = beta;

  v_prev_ = v;

  rec.command_v = v;
  rec.alpha = alpha;
  rec.damping = c;
  rec.beta_tilde = beta;
  rec.inertia = inertia;
  rec.dac_counts = out_report.dac_counts;
  rec.enable = true;
  return rec;
}

}  // namespace alphainv::rt
