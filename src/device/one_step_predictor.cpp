#include "alphainv/device/one_step_predictor.hpp"

#include <algorithm>
#include <cmath>

#include "alphainv/model/plant_input.hpp"

namespace alphainv::rt {

OneStepPredictor::OneStepPredictor(const ControlLoopConfig& config)
    : effects_(config.effects),
      torque_effects_(config.effects),
      period_s_(config.period_s),
      delay_ticks_(ControlLoop::delay_ticks(config)) {
  v_history_.assign(delay_ticks_ + 1, 0.0);
  memory_on_ = discovered_memory_active(config.effects);
  memory_lag_decay_ = DiscoveredMemory::lag_decay(config.effects, config.period_s);
}

void OneStepPredictor::reset() noexcept {
  std::fill(v_history_.begin(), v_history_.end(), 0.0);
  v_head_ = 0;
  have_prev_tick_ = have_pred_ = false;
  theta_prev_ = c_prev_ = gain_prev_ = u_prev_ = 0.0;
  e_prev_ = 1.0;
  a_prev_ = inv_a_prev_ = 0.0;
  theta_pred_next_ = 0.0;
  memory_started_ = false;
  memory_.reset(0.0);
}

void OneStepPredictor::add(TickRecord& rec) noexcept {
  const double theta = rec.theta_rad;
  const double theta_prev = theta_prev_;
  theta_prev_ = theta;
  rec.theta_pred_rad = have_pred_ && rec.new_report ? theta_pred_next_ : theta;
  if (!rec.enable) {  // a fault, or no report yet: the tick sent 0, disabled, and reset its model
    u_prev_ = 0.0;
    have_prev_tick_ = false;
    have_pred_ = false;
    return;
  }
  // The model's input: the command sent through its effects (delay, deadzone, saturation).
  v_head_ = (v_head_ + 1) % v_history_.size();
  v_history_[v_head_] = rec.command_v;
  const double v_model = applied_command(
      effects_, v_history_[(v_head_ + v_history_.size() - delay_ticks_) % v_history_.size()]);
  const double c = rec.damping;
  const double beta = rec.beta_tilde;

  // One-step prediction from eq. (37), θ̈ + C θ̇ = β̃ v, exact over a tick with C, β̃, v held:
  //   θ(T) = θ0 + θ̇0·a + (β̃v/C)(T − a),  θ̇(T) = θ̇0·e + (β̃v/C)(1 − e),  e = exp(−CT),
  //   a = (1 − e)/C.
  // θ̇_k comes from the last two measurements and the previous tick's command and model; e and a
  // of the previous tick's C are reused when C did not change.
  const double T = period_s_;
  double e = e_prev_, a = a_prev_, inv_a = inv_a_prev_;
  if (c > 0.0 && !(c == c_prev_ && c_prev_ > 0.0)) {
    e = std::exp(-c * T);
    a = (1.0 - e) / c;
    inv_a = 1.0 / a;
  }
  const double gain = beta / c;  // β̃/C: u·β̃/C is the steady velocity
  if (rec.new_report && have_prev_tick_ && c > 0.0 && c_prev_ > 0.0) {
    const double g_prev = gain_prev_ * u_prev_;
    const double theta_dot_prev = (theta - theta_prev - g_prev * (T - a_prev_)) * inv_a_prev_;
    const double theta_dot = theta_dot_prev * e_prev_ + g_prev * (1.0 - e_prev_);
    // u: the command through the effects plus their torque n(θ, θ̇), held over the tick.
    double u = v_model + (torque_effects_.any()
                              ? plant_torque(torque_effects_, rec.t_s, theta, theta_dot)
                              : 0.0);
    if (memory_on_) {
      if (memory_started_) memory_.advance(effects_, memory_lag_decay_, theta - theta_prev, theta_dot);
      else memory_.reset(theta_dot);
      memory_started_ = true;
      u += memory_.torque(effects_);
    }
    theta_pred_next_ = theta + theta_dot * a + (gain * u) * (T - a);
    u_prev_ = u;
    have_pred_ = true;
  } else {
    have_pred_ = false;
    u_prev_ = v_model +
              (torque_effects_.any() ? plant_torque(torque_effects_, rec.t_s, theta, 0.0) : 0.0);
  }
  have_prev_tick_ = rec.new_report;
  c_prev_ = c;
  gain_prev_ = gain;
  e_prev_ = c > 0.0 ? e : 1.0;  // those of c_prev_ whenever c_prev_ > 0
  a_prev_ = c > 0.0 ? a : 0.0;
  inv_a_prev_ = c > 0.0 ? inv_a : 0.0;
}

}  // namespace alphainv::rt
