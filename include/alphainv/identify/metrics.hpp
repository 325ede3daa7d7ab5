#pragma once
/// \file metrics.hpp
/// Model-versus-measurement error metrics: the fundamental's magnitude and phase errors of sine runs
/// (Table 8 style) and absolute angle errors of step responses (Table 11 style). Not real-time.

#include <cstddef>
#include <vector>

namespace alphainv {

/// p-th percentile (0..100) with linear interpolation between order statistics; NaN when empty.
double percentile(std::vector<double> values, double p);
/// Median (50th percentile).
double median(std::vector<double> values);

/// Comparison of the fundamental of a simulated and a measured sine response.
struct FundamentalError {
  double gain_measured = 0.0;   ///< A0/Ar of the measurement [1]
  double gain_simulated = 0.0;  ///< A0/Ar of the simulation [1]
  double phase_measured_deg = 0.0;   ///< φ of the measurement relative to r [deg]
  double phase_simulated_deg = 0.0;  ///< φ of the simulation [deg]
  double magnitude_abs_error = 0.0;  ///< |gain_sim − gain_meas| [1]
  double phase_abs_error_deg = 0.0;  ///< |φ_sim − φ_meas| wrapped to [0, 180] [deg]
  bool valid = false;
};

/// Fits the fundamental (eq. (15)) of r, θ_meas and θ_sim over samples [begin, end) and compares
/// gains A0/Ar and phases (relative to the reference's own fitted phase, so r need not be a pure
/// sin ωt).
FundamentalError fundamental_error(const std::vector<double>& t_s, const std::vector<double>& r,
                                   const std::vector<double>& theta_measured,
                                   const std::vector<double>& theta_simulated, double freq_hz,
                                   std::size_t begin, std::size_t end);

/// Median and 90th percentile of |θ_sim − θ_meas| over samples [begin, end) (Table 11 style).
struct AbsErrorStats {
  double median = 0.0;
  double p90 = 0.0;
  double rms = 0.0;
  std::size_t n = 0;
};
AbsErrorStats abs_error_stats(const std::vector<double>& theta_measured,
                              const std::vector<double>& theta_simulated, std::size_t begin,
                              std::size_t end);

}  // namespace alphainv
