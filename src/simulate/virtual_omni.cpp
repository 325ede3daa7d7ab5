#include "alphainv/simulate/virtual_omni.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "alphainv/error.hpp"
#include "alphainv/model/detail/field_checks.hpp"

namespace alphainv {

namespace {

constexpr double kTwoPi = 6.28318530717958647692;
/// RK4's stability interval on the negative real axis is (−2.785, 0); keep h·λ below this.
constexpr double kRk4StableHLambda = 2.5;
/// h·λ for which RK4 is accurate, not only stable (model_simulation_substeps).
constexpr double kRk4AccurateHLambda = 0.25;
/// Delay fractions below this (of a tick) count as whole ticks.
constexpr double kDelayFractionEps = 1e-9;

using detail::bad;
using detail::num;
using detail::require_finite;
using detail::require_nonnegative;
using detail::require_positive;

/// Largest C and β̃ of `m` at inertia I (their extremes are at breakpoints: the model is
/// piecewise linear and held outside).
void model_extremes(const AlphaModel& m, double inertia, double& c_max, double& bt_max) noexcept {
  c_max = 0.0;
  for (std::size_t n = 0; n < m.n_breakpoints; ++n)
    c_max = std::max(c_max, 1.0 / (m.c_n1[n] * inertia));
  bt_max = std::max(1.0 / (m.beta_n1[0] * inertia), 1.0 / (m.beta_n1[1] * inertia));
}

/// h·λ of the stiffest mode of one RK4 step (h = T/substeps): the velocity decay rate
/// C + β̃·Fc/ε (the Coulomb term's slope at θ̇ = 0) and the position stiffness
/// √(β̃·(|g| + 2π|a|/p)) of gravity and cogging.
double stiffest_h_lambda(const VirtualOmniParams& p, double inertia) noexcept {
  double c_max = 0.0, bt_max = 0.0;
  model_extremes(p.alpha_model, inertia, c_max, bt_max);
  const Effects& e = p.effects;
  const double h = p.tick_period_s / p.substeps;
  double velocity_rate = c_max;
  if (e.coulomb_v > 0.0) velocity_rate += bt_max * e.coulomb_v / e.coulomb_smoothing_rad_s;
  double position_stiffness = bt_max * std::abs(e.gravity_v);
  if (e.cogging_v != 0.0)
    position_stiffness += bt_max * kTwoPi * std::abs(e.cogging_v) / e.cogging_period_rad;
  return std::max(h * velocity_rate, h * std::sqrt(position_stiffness));
}

bool inertia_ok(double inertia) noexcept { return std::isfinite(inertia) && inertia > 0.0; }

}  // namespace

int model_simulation_substeps(const VirtualOmniParams& p) noexcept {
  const double i = p.inertia.inertia(deg_to_rad(p.gamma1_deg), deg_to_rad(p.gamma2_deg));
  if (!inertia_ok(i) || !(p.tick_period_s > 0.0)) return 0;
  VirtualOmniParams q = p;
  if (!torque_depends_on_velocity(p.effects)) {
    for (int n = 1; n <= 1000; n *= 2) {
      q.substeps = n;
      if (stiffest_h_lambda(q, i) <= kRk4AccurateHLambda) return n;
    }
  }
  for (int n : {4, 16, 64, 256, 1000}) {
    q.substeps = n;
    if (stiffest_h_lambda(q, i) <= kRk4StableHLambda) return n;
  }
  return 0;
}

AlphaModel constant_alpha_model(double c_n1, double beta_tilde_n1) {
  AlphaModel m;
  m.n_breakpoints = 2;
  m.alpha = {0.0, 1.0};
  m.c_n1 = {c_n1, c_n1};
  m.beta_alpha = {0.0, 1.0};
  m.beta_n1 = {beta_tilde_n1, beta_tilde_n1};
  return m;
}

void VirtualOmniParams::validate() const {
  require_finite("inertia.i_base", inertia.i_base);
  require_finite("inertia.i1", inertia.i1);
  require_finite("inertia.i2", inertia.i2);
  require_finite("inertia.i3", inertia.i3);
  require_finite("inertia.gamma_offs_rad", inertia.gamma_offs_rad);
  if (!alpha_model.valid()) {
    throw Error(
        "expected 2..8 strictly increasing breakpoints and positive C_n1, beta_n1, "
        "beta_alpha[0] < beta_alpha[1]",
        {}, 0, "alpha_model");
  }
  for (std::size_t n = 0; n < alpha_model.n_breakpoints; ++n) {
    require_finite("alpha_model.alpha[" + std::to_string(n) + "]", alpha_model.alpha[n]);
    require_finite("alpha_model.c_n1[" + std::to_string(n) + "]", alpha_model.c_n1[n]);
  }
  require_finite("alpha_model.beta_n1[0]", alpha_model.beta_n1[0]);
  require_finite("alpha_model.beta_n1[1]", alpha_model.beta_n1[1]);
  require_finite("gamma1_deg", gamma1_deg);
  require_finite("gamma2_deg", gamma2_deg);
  const double i = inertia.inertia(deg_to_rad(gamma1_deg), deg_to_rad(gamma2_deg));
  if (!inertia_ok(i)) {
    throw Error("expected a positive inertia I(gamma1, gamma2) at the pose (" + num(gamma1_deg) +
                    ", " + num(gamma2_deg) + ") deg, got " + num(i),
                {}, 0, "inertia");
  }
  require_positive("tick_period_s", tick_period_s);
  if (substeps < 1 || substeps > 1000) bad("substeps", "an integer in 1..1000", substeps);
  if (!(std::abs(alpha_filter.sample_period_s - tick_period_s) <= 1e-12 * tick_period_s)) {
    throw Error("expected the tick period " + num(tick_period_s) + " s, got " +
                    num(alpha_filter.sample_period_s) + " s",
                {}, 0, "alpha_filter.sample_period_s");
  }
  if (!(alpha_filter.cutoff_hz > 0.0) || !(alpha_filter.cutoff_hz < 0.25 / tick_period_s)) {
    bad("alpha_filter.cutoff_hz", "0 < cutoff_hz < " + num(0.25 / tick_period_s) + " Hz",
        alpha_filter.cutoff_hz);
  }
  require_finite("initial_theta_rad", initial_theta_rad);
  require_finite("initial_theta_dot_rad_s", initial_theta_dot_rad_s);
  require_finite("initial_command_v", initial_command_v);

  const Effects& e = effects;
  validate_effects(e, "effects.");
  require_nonnegative("measurement.quantisation_rad", measurement.quantisation_rad);
  require_nonnegative("measurement.noise_std_rad", measurement.noise_std_rad);

  const double h_lambda = stiffest_h_lambda(*this, i);
  if (!(h_lambda <= kRk4StableHLambda)) {
    const double need = std::ceil(substeps * h_lambda / kRk4StableHLambda);
    const bool coulomb = e.coulomb_v > 0.0;
    throw Error("RK4 would be unstable: h*lambda = " + num(h_lambda) + " > " +
                    num(kRk4StableHLambda) + " at " + std::to_string(substeps) +
                    " substeps; use at least " + num(need) + " substeps" +
                    (coulomb ? " or a larger coulomb_smoothing_rad_s" : ""),
                {}, 0, coulomb ? "effects.coulomb_smoothing_rad_s" : "substeps");
  }
}

VirtualOmni::VirtualOmni(const VirtualOmniParams& params)
    : params_(params), estimator_((params.validate(), params.alpha_filter)) {
  inertia_ =
      params_.inertia.inertia(deg_to_rad(params_.gamma1_deg), deg_to_rad(params_.gamma2_deg));
  alpha_at_pose_ = params_.alpha_model.at_inertia(inertia_);
  const double ticks = params_.effects.delay_s / params_.tick_period_s;
  delay_ticks_ = static_cast<std::size_t>(std::floor(ticks + kDelayFractionEps));
  delay_fraction_ = ticks - static_cast<double>(delay_ticks_);
  if (delay_fraction_ < kDelayFractionEps) delay_fraction_ = 0.0;
  delay_line_.assign(delay_ticks_ + 2, params_.initial_command_v);  // v_k … v_{k−m−1}
  exact_segments_ = params_.exact_constant_segments && !torque_depends_on_state(params_.effects);
  torque_ = TorqueEffects(params_.effects);
  memory_on_ = discovered_memory_active(params_.effects);
  memory_lag_decay_ = DiscoveredMemory::lag_decay(params_.effects, params_.tick_period_s);
  reset();
}

void VirtualOmni::reset() noexcept {
  theta_ = params_.initial_theta_rad;
  theta_dot_ = params_.initial_theta_dot_rad_s;
  std::fill(delay_line_.begin(), delay_line_.end(), params_.initial_command_v);
  delay_head_ = 0;
  estimator_.reset(applied_command(params_.effects, params_.initial_command_v));
  rng_.seed(params_.measurement.seed);
  has_spare_gaussian_ = false;
  spare_gaussian_ = 0.0;
  alpha_ = 0.0;
  damping_ = alpha_at_pose_.damping(alpha_);
  beta_tilde_ = alpha_at_pose_.beta_tilde(alpha_);
  v_eff_mean_ = v_eff_peak_ = applied_command(params_.effects, params_.initial_command_v);
  time_s_ = 0.0;
  ticks_ = 0;
  memory_.reset(theta_dot_);
  memory_theta_prev_ = theta_;
  theta_measured_ = measure(theta_);
}

bool VirtualOmni::set_pose(double gamma1_deg, double gamma2_deg) noexcept {
  if (!std::isfinite(gamma1_deg) || !std::isfinite(gamma2_deg)) return false;
  const double i = params_.inertia.inertia(deg_to_rad(gamma1_deg), deg_to_rad(gamma2_deg));
  if (!inertia_ok(i) || !(stiffest_h_lambda(params_, i) <= kRk4StableHLambda)) return false;
  params_.gamma1_deg = gamma1_deg;
  params_.gamma2_deg = gamma2_deg;
  inertia_ = i;
  alpha_at_pose_ = params_.alpha_model.at_inertia(inertia_);
  return true;
}

double VirtualOmni::effect_torque(double theta_rad, double theta_dot_rad_s) const noexcept {
  if (params_.precomputed_torque) return torque_.torque(theta_rad, theta_dot_rad_s);
  return alphainv::effect_torque(params_.effects, theta_rad, theta_dot_rad_s);
}

void VirtualOmni::integrate(double t0_s, double duration_s, double input_v,
                            const KnownInputs& known) noexcept {
  // θ̇ = Φ, Φ̇ = −C Φ + β̃ (u + n(θ, Φ, t) + d), eq. (11) with plant_input.hpp; C, β̃, the applied
  // command u and d constant over the segment.
  if (exact_segments_) {
    integrate_exact(duration_s, input_v, known);
    return;
  }
  if (params_.precomputed_torque) {
    integrate_rk4(torque_, t0_s, duration_s, input_v, known);
  } else {
    integrate_rk4(params_.effects, t0_s, duration_s, input_v, known);
  }
}

/// `substeps` RK4 steps of eq. (11) over the segment, n(θ, θ̇) from `torque` (the Effects or its
/// TorqueEffects: plant_torque() of either).
template <class Torque>
void VirtualOmni::integrate_rk4(const Torque& torque, double t0_s, double duration_s,
                                double input_v, const KnownInputs& known) noexcept {
  const double c = damping_, bt = beta_tilde_;
  auto accel = [&](double t, double th, double om) noexcept {
    return -c * om + bt * (input_v + plant_torque(torque, t, th, om, known));
  };
  const int n = params_.substeps;
  const double h = duration_s / n;
  double th = theta_, om = theta_dot_;
  for (int s = 0; s < n; ++s) {
    const double ts = t0_s + s * h;
    const double k1t = om, k1o = accel(ts, th, om);
    const double k2t = om + 0.5 * h * k1o, k2o = accel(ts + 0.5 * h, th + 0.5 * h * k1t, k2t);
    const double k3t = om + 0.5 * h * k2o, k3o = accel(ts + 0.5 * h, th + 0.5 * h * k2t, k3t);
    const double k4t = om + h * k3o, k4o = accel(ts + h, th + h * k3t, k4t);
    th += h / 6.0 * (k1t + 2.0 * k2t + 2.0 * k3t + k4t);
    om += h / 6.0 * (k1o + 2.0 * k2o + 2.0 * k3o + k4o);
  }
  theta_ = th;
  theta_dot_ = om;
}

void VirtualOmni::integrate_exact(double duration_s, double input_v,
                                  const KnownInputs& known) noexcept {
  // The closed form of the file comment: Φ̇ = −C·Φ + a with a = β̃·(u + n + d) constant.
  const double c = damping_, h = duration_s;
  const double a = beta_tilde_ * (input_v + plant_torque(torque_, 0.0, theta_, theta_dot_, known));
  const double ch = c * h;
  if (!(ch > 1e-12)) {  // C·h at rounding level: constant acceleration
    theta_ += h * theta_dot_ + 0.5 * a * h * h;
    theta_dot_ += a * h;
    return;
  }
  // rest = C·h − (1 − e^(−Ch)) = Σ_{k≥2} (−C·h)^k/k!: by its series where the difference would
  // cancel (C·h < 1/4: the 14th term is below 1e-20 of the first; the sum stops once the next
  // term is below 1e-17 of it, which bounds what the alternating tail adds), and then
  // 1 − e^(−Ch) = C·h − rest (rest ≤ C·h/8: no cancellation, no expm1 per tick); else
  // 1 − e^(−Ch) by expm1 and rest directly.
  double decayed = 0.0, rest = 0.0;
  if (ch < 0.25) {
    double term = 0.5 * ch * ch;
    for (int k = 3; k <= 14; ++k) {
      rest += term;
      term *= -ch / k;
      if (std::abs(term) < 1e-17 * rest) break;
    }
    decayed = ch - rest;
  } else {
    decayed = -std::expm1(-ch);
    rest = ch - decayed;
  }
  const double v_inf = a / c;  // the velocity the segment tends to
  // θ(h) − θ0 = (u/C)·h + (θ̇0 − u/C)·(1 − e^(−Ch))/C = (θ̇0·(1 − e^(−Ch)) + (u/C)·rest)/C
  theta_ += (theta_dot_ * decayed + v_inf * rest) / c;
  theta_dot_ += (v_inf - theta_dot_) * decayed;
}

double VirtualOmni::gaussian() noexcept {
  // Box-Muller on 53-bit uniforms: portable, unlike std::normal_distribution.
  if (has_spare_gaussian_) {
    has_spare_gaussian_ = false;
    return spare_gaussian_;
  }
  constexpr double k2m53 = 1.0 / 9007199254740992.0;
  const double u1 = (static_cast<double>(rng_() >> 11) + 1.0) * k2m53;  // (0, 1]
  const double u2 = static_cast<double>(rng_() >> 11) * k2m53;          // [0, 1)
  const double r = std::sqrt(-2.0 * std::log(u1));
  spare_gaussian_ = r * std::sin(kTwoPi * u2);
  has_spare_gaussian_ = true;
  return r * std::cos(kTwoPi * u2);
}

double VirtualOmni::measure(double theta_rad) noexcept {
  const MeasurementEffects& m = params_.measurement;
  double y = theta_rad;
  if (m.noise_std_rad > 0.0) y += m.noise_std_rad * gaussian();
  if (m.quantisation_rad > 0.0) y = m.quantisation_rad * std::round(y / m.quantisation_rad);
  return y + 0.0;  // −0 (a negative value rounded to count 0) reads as 0
}

void VirtualOmni::command_path(double command_v, const KnownInputs& known, double& u_early,
                               double& u_late) noexcept {
  // Command path: the delay line holds v_k … v_{k−m−1}; v(t − τ) is v_{k−m−1} for the first
  // fraction φ = τ/T − m of the tick and v_{k−m} after it.
  const std::size_t len = delay_line_.size();
  delay_head_ = (delay_head_ + 1) % len;
  delay_line_[delay_head_] = command_v;
  const double v_late = delay_line_[(delay_head_ + len - delay_ticks_) % len];       // v_{k−m}
  const double v_early = delay_line_[(delay_head_ + len - delay_ticks_ - 1) % len];  // v_{k−m−1}
  u_late = applied_command(params_.effects, v_late, known);
  u_early = applied_command(params_.effects, v_early, known);
  const double phi = delay_fraction_;
  v_eff_mean_ = phi * u_early + (1.0 - phi) * u_late;
  v_eff_peak_ = phi > 0.0 ? std::max(std::abs(u_early), std::abs(u_late)) : std::abs(u_late);

  // α of the received command, then C(α, I) and β̃(α, I) for this tick (eqs. (33), (38)-(42)).
  alpha_ = estimator_.update(v_eff_mean_).alpha;
  damping_ = alpha_at_pose_.damping(alpha_);
  beta_tilde_ = alpha_at_pose_.beta_tilde(alpha_);
}

void VirtualOmni::prime_commands(const double* commands_v, std::size_t n) noexcept {
  double u_early = 0.0, u_late = 0.0;
  for (std::size_t k = 0; k < n; ++k) command_path(commands_v[k], KnownInputs{}, u_early, u_late);
}

double VirtualOmni::step(double command_v, const KnownInputs& known_in) noexcept {
  KnownInputs known = known_in;
  if (memory_on_) {  // the memory terms' torque of this tick, from the state at its start
    memory_.advance(params_.effects, memory_lag_decay_, theta_ - memory_theta_prev_, theta_dot_);
    memory_theta_prev_ = theta_;
    known.disturbance_v += memory_.torque(params_.effects);
  }
  double u_early = 0.0, u_late = 0.0;
  command_path(command_v, known, u_early, u_late);
  const double phi = delay_fraction_;
  const double T = params_.tick_period_s;
  if (phi > 0.0) {
    integrate(time_s_, phi * T, u_early, known);
    integrate(time_s_ + phi * T, (1.0 - phi) * T, u_late, known);
  } else {
    integrate(time_s_, T, u_late, known);
  }
  ++ticks_;
  time_s_ = static_cast<double>(ticks_) * T;
  theta_measured_ = measure(theta_);
  return theta_measured_;
}

RunData run_closed_loop(VirtualOmni& omni, const Controller& controller, const Reference& reference,
                        double duration_s, const ClosedLoopOptions& options) {
  const double T = omni.params().tick_period_s;
  if (!std::isfinite(duration_s) || !(duration_s > 0.0)) {
    throw Error("expected a positive, finite duration [s], got " + num(duration_s), {}, 0,
                "duration_s");
  }
  const double ticks = std::round(duration_s / T);
  if (ticks > 1e9)
    throw Error("expected at most 1e9 ticks, got " + num(ticks), {}, 0, "duration_s");
  const std::size_t n = static_cast<std::size_t>(ticks) + 1;

  RunData out;
  out.t.resize(n);
  out.r.resize(n);
  out.theta.resize(n);
  out.v.resize(n);
  std::vector<double>* theta_true = nullptr;
  std::vector<double>* theta_dot_true = nullptr;
  std::vector<double>* v_eff = nullptr;
  std::vector<double>* alpha_true = nullptr;
  std::vector<double>* c_true = nullptr;
  std::vector<double>* bt_true = nullptr;
  std::vector<double>* dist = nullptr;
  if (options.record_truth) {
    theta_true = &out.extra_columns["theta_true"];
    theta_dot_true = &out.extra_columns["theta_dot_true"];
    v_eff = &out.extra_columns["v_eff"];
    alpha_true = &out.extra_columns["alpha_true"];
    c_true = &out.extra_columns["c_true"];
    bt_true = &out.extra_columns["beta_tilde_true"];
    for (auto* col : {theta_true, theta_dot_true, v_eff, alpha_true, c_true, bt_true})
      col->resize(n);
  }
  if (options.disturbance_v) {
    dist = &out.extra_columns["disturbance_v"];
    dist->resize(n);
  }
  std::vector<double>* enable = nullptr;
  if (options.torque_enable) {
    enable = &out.extra_columns["torque_enable"];
    enable->resize(n);
  }
  std::vector<double>* comp = nullptr;
  if (options.command_offset_v) {
    comp = &out.extra_columns["v_comp"];
    comp->resize(n);
  }

  double integral = 0.0, e_prev = 0.0, theta_prev = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * T;
    const double r = reference.at(t).r;
    const double theta = omni.theta_measured();
    const double e = r - theta;  // eq. (9)
    integral += T * e;
    double d = 0.0;
    if (k > 0) {
      d = controller.derivative_on == DerivativeOn::kError ? (e - e_prev) / T
                                                           : -(theta - theta_prev) / T;
    }
    double pid = controller.kp * e + controller.ki * integral + controller.kd * d;  // eq. (10)
    if (comp != nullptr) {  // + a compensation (not added when there is none: bit for bit)
      (*comp)[k] = options.command_offset_v(t, theta);
      pid += (*comp)[k];
    }
    const double v = controller.clamp(pid);
    e_prev = e;
    theta_prev = theta;
    out.t[k] = t;
    out.r[k] = r;
    out.theta[k] = theta;
    out.v[k] = v;
    KnownInputs known;
    if (dist != nullptr) {
      known.disturbance_v = options.disturbance_v(t);
      (*dist)[k] = known.disturbance_v;
    }
    if (enable != nullptr) {
      known.torque_enabled = options.torque_enable(t);
      (*enable)[k] = known.torque_enabled ? 1.0 : 0.0;
    }
    if (theta_true != nullptr) {
      (*theta_true)[k] = omni.theta();
      (*theta_dot_true)[k] = omni.theta_dot();
    }
    if (options.hidden_torque_v) {  // not recorded: no model is told about it
      known.disturbance_v += options.hidden_torque_v(t, omni.theta(), omni.theta_dot());
    }
    (void)omni.step(v, known);
    if (theta_true != nullptr) {
      (*v_eff)[k] = omni.command_effective();
      (*alpha_true)[k] = omni.alpha();
      (*c_true)[k] = omni.damping();
      (*bt_true)[k] = omni.beta_tilde();
    }
  }
  return out;
}

}  // namespace alphainv
