#include "alphainv/identify/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "alphainv/identify/local_linear.hpp"

namespace alphainv {

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const double pos = std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(values.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, values.size() - 1);
  const double w = pos - static_cast<double>(lo);
  return values[lo] + w * (values[hi] - values[lo]);
}

double median(std::vector<double> values) { return percentile(std::move(values), 50.0); }

FundamentalError fundamental_error(const std::vector<double>& t_s, const std::vector<double>& r,
                                   const std::vector<double>& theta_measured,
                                   const std::vector<double>& theta_simulated, double freq_hz,
                                   std::size_t begin, std::size_t end) {
  FundamentalError out;
  end = std::min({end, t_s.size(), r.size(), theta_measured.size(), theta_simulated.size()});
  if (end <= begin + 4) return out;
  const double w = 2.0 * 3.14159265358979323846 * freq_hz;
  const std::size_t n = end - begin;
  const SineFit fr = fit_sine(t_s.data() + begin, r.data() + begin, n, w);
  const SineFit fm = fit_sine(t_s.data() + begin, theta_measured.data() + begin, n, w);
  const SineFit fs = fit_sine(t_s.data() + begin, theta_simulated.data() + begin, n, w);
  if (!fr.valid || !fm.valid || !fs.valid || !(fr.amplitude() > 0.0)) return out;
  out.gain_measured = fm.amplitude() / fr.amplitude();
  out.gain_simulated = fs.amplitude() / fr.amplitude();
  auto wrap_deg = [](double a) {
    a = std::remainder(a, 2.0 * 3.14159265358979323846);
    return a * 180.0 / 3.14159265358979323846;
  };
  out.phase_measured_deg = wrap_deg(fm.phase_rad() - fr.phase_rad());
  out.phase_simulated_deg = wrap_deg(fs.phase_rad() - fr.phase_rad());
  out.magnitude_abs_error = std::abs(out.gain_simulated - out.gain_measured);
  out.phase_abs_error_deg = std::abs(wrap_deg(fs.phase_rad() - fm.phase_rad()));
  out.valid = true;
  return out;
}

AbsErrorStats abs_error_stats(const std::vector<double>& theta_measured,
                              const std::vector<double>& theta_simulated, std::size_t begin,
                              std::size_t end) {
  AbsErrorStats s;
  end = std::min({end, theta_measured.size(), theta_simulated.size()});
  if (end <= begin) return s;
  std::vector<double> e;
  e.reserve(end - begin);
  double ss = 0.0;
  for (std::size_t k = begin; k < end; ++k) {
    const double d = theta_simulated[k] - theta_measured[k];
    e.push_back(std::abs(d));
    ss += d * d;
  }
  s.n = e.size();
  s.rms = std::sqrt(ss / static_cast<double>(s.n));
  s.median = percentile(e, 50.0);
  s.p90 = percentile(std::move(e), 90.0);
  return s;
}

}  // namespace alphainv
