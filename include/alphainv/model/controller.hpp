#pragma once
/// \file controller.hpp
/// The PID law of eq. (10), the one type for it everywhere: the `controller` object of
/// alphainv-dataset/1 and alphainv-model/1, the simulator's law, the pipeline's and the daemon's.
/// e = r − θ, v = kp e + ki ∫e dt + kd de/dt (or −kd dθ/dt), clipped to ±v_limit.

#include <cmath>
#include <limits>

namespace alphainv {

/// Which signal the derivative term differentiates.
enum class DerivativeOn {
  kError,        ///< d(r − θ)/dt (JSON "error", the default)
  kMeasurement,  ///< −dθ/dt (JSON "measurement")
};

/// PID gains and command limit. The defaults are the virtual Omni's P law (kp = 2); a dataset
/// that states no law reads as kp = 0 (dataset.hpp, kUnstatedController).
struct Controller {
  double kp = 2.0;  ///< proportional gain [command unit / position unit]
  double ki = 0.0;  ///< integral gain [command unit / (position unit · s)]
  double kd = 0.0;  ///< derivative gain [command unit · s / position unit]
  DerivativeOn derivative_on = DerivativeOn::kError;  ///< see DerivativeOn
  /// Command saturation |v| ≤ v_limit [command unit], > 0; infinity: no limit (the formats write
  /// null, or leave the key out, for it).
  double v_limit = std::numeric_limits<double>::infinity();

  /// Clamp a command to ±v_limit. Real-time safe.
  double clamp(double v) const noexcept {
    if (v > v_limit) return v_limit;
    if (v < -v_limit) return -v_limit;
    return v;
  }
  /// True when the command is limited (v_limit finite).
  bool has_limit() const noexcept { return std::isfinite(v_limit); }

  /// Every field equal (so a NaN gain compares unequal).
  friend bool operator==(const Controller& a, const Controller& b) noexcept {
    return a.kp == b.kp && a.ki == b.ki && a.kd == b.kd && a.derivative_on == b.derivative_on &&
           a.v_limit == b.v_limit;
  }
  friend bool operator!=(const Controller& a, const Controller& b) noexcept { return !(a == b); }
};

}  // namespace alphainv
