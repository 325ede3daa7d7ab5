#include "alphainv/effect_sine_point.hpp"

#include <cmath>
#include <vector>

#include "alphainv/time_domain_fit.hpp"

namespace alphainv {

namespace {

constexpr double kTwoPi = 6.283185307179586476925;

std::complex<double> phasor(const SineFit& f) { return {f.a2, f.a1}; }

}  // namespace

LocalLinearPoint local_linear_point_from_input(double freq_hz, std::complex<double> theta,
                                               std::complex<double> input,
                                               std::complex<double> command, double kp,
                                               double sample_period_s) {
  const double w = kTwoPi * freq_hz;
  // Loop gain L = β·g (local_linear_point()): θ = β̃·g·u, β = kp·β̃ → L = kp·θ/u. Without effects
  // u = v = kp·(r − θ) and L = θ/(r − θ) = H/(1 − H), the closed-loop form (19)-(20) invert.
  const std::complex<double> l = kp * theta / input;
  const std::complex<double> h = l / (1.0 + l);  // the equivalent closed loop θ/r
  const double ar = std::abs(h) > 0.0 ? std::abs(theta) / std::abs(h) : 0.0;
  const std::complex<double> th = h * ar;  // = A2 + j·A1 with |θ| as measured
  LocalLinearPoint p = local_linear_point(freq_hz, th.imag(), th.real(), ar, kp, sample_period_s);
  p.alpha_data = w * w * std::norm(command);  // eq. (36): α = ω²·|v|² for v sinusoidal
  if (!std::isfinite(p.c_data) || !std::isfinite(p.beta_data) || !(ar > 0.0)) p.physical = false;
  return p;
}

LocalLinearPoint sine_point_with_effects(const RunData& run, IndexRange window, double freq_hz,
                                         double kp, double sample_period_s, const Effects& effects) {
  LocalLinearPoint bad;
  bad.freq_hz = freq_hz;
  bad.omega_rad_s = kTwoPi * freq_hz;
  if (window.end > run.size() || window.size() < 8 || !(freq_hz > 0.0)) return bad;
  const double w = kTwoPi * freq_hz;
  const double* t = run.t.data() + window.begin;
  const std::size_t n = window.size();
  const SineFit ft = fit_sine(t, run.theta.data() + window.begin, n, w);
  const SineFit fv = fit_sine(t, run.v.data() + window.begin, n, w);
  std::vector<double> amp(n);
  for (std::size_t k = 0; k < n; ++k) amp[k] = amplifier(effects, run.v[window.begin + k]);
  const SineFit fa = fit_sine(t, amp.data(), n, w);
  if (!ft.valid || !fv.valid || !fa.valid) return bad;
  // The delay shifts the amplifier's output: a phase −ωτ on its fundamental.
  std::complex<double> u = phasor(fa) * std::polar(1.0, -w * effects.delay_s);
  const bool torque = effects.coulomb_v > 0.0 || effects.offset_v != 0.0 ||
                      effects.gravity_v != 0.0 || effects.cogging_v != 0.0;
  if (torque) {
    std::vector<double> dth, ddth;
    local_quadratic_derivatives(run.t, run.theta, 0.01, dth, ddth);
    std::vector<double> nt(n);
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t i = window.begin + k;
      nt[k] = effect_torque(effects, run.theta[i], dth[i]);
    }
    const SineFit fn = fit_sine(t, nt.data(), n, w);
    if (!fn.valid) return bad;
    u += phasor(fn);
  }
  if (!(std::abs(u) > 0.0)) return bad;
  return local_linear_point_from_input(freq_hz, phasor(ft), u, phasor(fv), kp, sample_period_s);
}

}  // namespace alphainv
