#pragma once
/// \file device/one_step_predictor.hpp
/// The model's one-step prediction of θ (eq. (37) over one tick with the command held), made from
/// the tick records off the real-time thread.
///
/// The prediction is a monitoring quantity (the recording's `theta_pred`, the daemon's state):
/// the command does not use it. So the 1 kHz tick (control_loop.hpp) does not compute it; whoever
/// consumes the records in tick order (LoopRunner's writer thread, a test, a replay) passes each
/// one through add(), which fills TickRecord::theta_pred_rad exactly as the tick did before this
/// split (same operations in the same order: bit-identical, the golden test of test_control_loop).
///
/// From each record it takes the command sent (command_v), C and β̃ of that tick (damping,
/// beta_tilde), θ and whether a new report arrived; the model's effects (delay, deadzone,
/// saturation, torque n(θ, θ̇)) come from the loop's configuration.

#include <cstddef>
#include <vector>

#include "alphainv/device/control_loop.hpp"
#include "alphainv/model/effects.hpp"
#include "alphainv/model/torque_effects.hpp"

namespace alphainv::rt {

/// See the file comment. Not thread-safe: one consumer thread.
class OneStepPredictor {
 public:
  /// Allocates the command history of the model's delay (config.effects.delay_s in whole ticks,
  /// at most ControlLoop's kMaxDelayTicks). `config` is the loop's, already validated.
  explicit OneStepPredictor(const ControlLoopConfig& config);

  /// Fills rec.theta_pred_rad, the prediction of rec's θ made from the records before it (rec's
  /// own θ when there is none: the first tick, after a fault, a tick without a new report), and
  /// makes the prediction of the next record's θ. Records must come one per tick, in order; after
  /// a gap (records dropped) call reset() first. Allocates nothing.
  void add(TickRecord& rec) noexcept;
  /// Forgets the history: the state of a new predictor (the delay's command history zeroed).
  void reset() noexcept;

 private:
  Effects effects_;
  TorqueEffects torque_effects_;
  double period_s_ = 0.0;
  std::size_t delay_ticks_ = 0;    ///< ControlLoop::delay_ticks(), as the tick
  std::vector<double> v_history_;  ///< commands sent, a ring of delay_ticks_ + 1
  std::size_t v_head_ = 0;
  // The previous tick's model quantities (see ControlLoop::tick() before the split).
  bool have_prev_tick_ = false, have_pred_ = false;
  double theta_prev_ = 0.0;      ///< the previous record's θ [rad]
  /// The discovered term's memory terms (effects.hpp DiscoveredMemory), advanced with each
  /// prediction's θ and θ̇ (their torque joins u).
  bool memory_on_ = false;
  bool memory_started_ = false;
  double memory_lag_decay_ = 0.0;
  DiscoveredMemory memory_;
  double c_prev_ = 0.0;          ///< its C [1/s]
  double gain_prev_ = 0.0;       ///< its β̃/C
  double u_prev_ = 0.0;          ///< its model input u (the command through the effects + n)
  /// exp(−C_prev·T), a = (1 − e)/C_prev and 1/a of the previous tick (reused when C is unchanged).
  double e_prev_ = 1.0, a_prev_ = 0.0, inv_a_prev_ = 0.0;
  double theta_pred_next_ = 0.0;
};

}  // namespace alphainv::rt
