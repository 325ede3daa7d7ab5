#pragma once
/// \file device/sim_push.hpp
/// An external torque the virtual device applies to the joint, as a hand pushing it would
/// (omni_ctl --device sim --sim-push PROFILE): d_ext(t) [command unit], added to the effects' torque
/// n in eq. (11), θ̈ + C·θ̇ = β̃·(S(Z(v(t − τ))) + n(θ, θ̇) + d_ext(t)) (VirtualOmni::step's
/// disturbance). t is the device's time [s] (ticks stepped × T), which omni_ctl's first run shares
/// to within a tick or two. Used to measure transparency: the push needed to move the joint at a
/// given speed, with and without compensation (docs/compensation.md).

#include <cmath>
#include <limits>
#include <string>

namespace alphainv::device {

/// A push profile (see the file comment).
struct SimPush {
  enum class Kind { kNone, kRamp, kConstant };
  Kind kind = Kind::kNone;
  double level_v = 0.0;    ///< kRamp: rate [command unit/s]; kConstant: the torque [command unit]
  double start_s = 0.0;    ///< device time the push starts [s] (0 before)
  /// |d_ext| never exceeds this [command unit] (a ramp levels off there).
  double max_v = std::numeric_limits<double>::infinity();

  /// d_ext(t_s) [command unit]: 0 before start_s; ramp level·(t − start); constant level; clipped
  /// to ±max_v. Real-time safe.
  double at(double t_s) const noexcept {
    if (kind == Kind::kNone || t_s < start_s) return 0.0;
    const double d = kind == Kind::kRamp ? level_v * (t_s - start_s) : level_v;
    return std::fmax(std::fmin(d, max_v), -max_v);
  }
};

/// Parses "ramp:RATE[,start=S][,max=V]" (RATE [command unit/s], either sign) or
/// "constant:V[,start=S]" (V ≠ 0, either sign; S [s] ≥ 0, an optional trailing "s"). Throws alphainv::Error
/// naming `field` and the text.
SimPush parse_sim_push(const std::string& text, const std::string& field = "--sim-push");

}  // namespace alphainv::device
