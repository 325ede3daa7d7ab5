#pragma once
/// \file device/sim_push.hpp
/// An external torque the virtual device applies to the joint, as a hand pushing it would
/// (omni_ctl --device sim --sim-push PROFILE): d_ext(t) [command unit], added to the effects' torque
/// n in eq. (11), θ̈ + C·θ̇ = β̃·(S(Z(v(t − τ))) + n(θ, θ̇) + d_ext(t)) (VirtualOmni::step's
/// disturbance). t is the device's time [s] (ticks stepped × T), which omni_ctl's first run shares
/// to within a tick or two. Used to measure transparency: the push needed to move the joint at a
/// given speed, with and without compensation (docs/compensation.md). Three profiles:
///   ramp      d = rate·(t − start), clipped to ±max: the push that breaks the joint free;
///   constant  d = V from start on;
///   hand      a hand moving at `speed` from where the joint is at `start`, holding it through a
///             spring-damper: d = K·(θ_h(t) − θ) + B·(speed − θ̇), θ_h = θ(start) + speed·(t − start);
///             in steady motion the mean push is K·(θ_h − θ), the torque needed at that speed.

#include <cmath>
#include <limits>
#include <string>

namespace alphainv::device {

/// A push profile (see the file comment).
struct SimPush {
  enum class Kind { kNone, kRamp, kConstant, kHand };
  Kind kind = Kind::kNone;
  /// kRamp: rate [command unit/s]; kConstant: the torque [command unit]; kHand: speed [rad/s].
  double level_v = 0.0;
  double stiffness_v_per_rad = 2.0;  ///< kHand: K [command unit/rad]
  double damping_v_s_per_rad = 0.05; ///< kHand: B [command unit·s/rad]
  double start_s = 0.0;    ///< device time the push starts [s] (0 before)
  /// |d_ext| never exceeds this [command unit] (a ramp levels off there).
  double max_v = std::numeric_limits<double>::infinity();

  /// d_ext [command unit] at device time t_s [s] and the joint's state θ [rad], θ̇ [rad/s]: 0 before
  /// start_s, then the profile (file comment), clipped to ±max_v. The hand takes hold at the first
  /// call at or after start_s. Real-time safe.
  double next(double t_s, double theta_rad, double theta_dot_rad_s) noexcept {
    if (kind == Kind::kNone || t_s < start_s) return 0.0;
    double d = level_v;
    if (kind == Kind::kRamp) d = level_v * (t_s - start_s);
    if (kind == Kind::kHand) {
      if (!holding_) hand_start_rad_ = theta_rad, holding_ = true;
      const double hand_rad = hand_start_rad_ + level_v * (t_s - start_s);
      d = stiffness_v_per_rad * (hand_rad - theta_rad) +
          damping_v_s_per_rad * (level_v - theta_dot_rad_s);
    }
    return std::fmax(std::fmin(d, max_v), -max_v);
  }

 private:
  bool holding_ = false;
  double hand_start_rad_ = 0.0;
};

/// Parses "ramp:RATE[,start=S][,max=V]" (RATE [command unit/s], either sign),
/// "hand:SPEED[,stiffness=K][,damping=B][,start=S][,max=V]" (SPEED [rad/s], K > 0, B ≥ 0) or
/// "constant:V[,start=S]" (V ≠ 0, either sign; S [s] ≥ 0, an optional trailing "s"). Throws alphainv::Error
/// naming `field` and the text.
SimPush parse_sim_push(const std::string& text, const std::string& field = "--sim-push");

}  // namespace alphainv::device
