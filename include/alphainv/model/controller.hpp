#pragma once
/// \file controller.hpp
/// The PID law of eq. (10) as the interchange format states it (`controller` object of
/// alphainv-dataset/1): e = r − θ, derivative on the error or on −θ, command clipped to ±v_limit.

#include <cmath>
#include <limits>

namespace alphainv {

/// Which signal the derivative term differentiates.
enum class DerivativeOn { kError, kMeasurement };

/// PID gains and command limit. Units: kp [command unit / position unit], ki [… / s], kd [… · s].
struct Controller {
  double kp = 2.0;
  double ki = 0.0;
  double kd = 0.0;
  DerivativeOn derivative_on = DerivativeOn::kError;
  double v_limit = std::numeric_limits<double>::infinity();  ///< |v| ≤ v_limit [command unit]

  /// Clamp a command to ±v_limit. Real-time safe.
  double clamp(double v) const noexcept {
    if (v > v_limit) return v_limit;
    if (v < -v_limit) return -v_limit;
    return v;
  }
  bool has_limit() const noexcept { return std::isfinite(v_limit); }
};

}  // namespace alphainv
