#include "alphainv/identify/effect_sine_point.hpp"

#include <cmath>
#include <vector>

#include "alphainv/model/plant_input.hpp"
#include "alphainv/rt/alpha_estimator.hpp"
#include "alphainv/simulate/known_inputs.hpp"
#include "alphainv/identify/time_domain_fit.hpp"

namespace alphainv {

namespace {

constexpr double kTwoPi = 6.283185307179586476925;

std::complex<double> phasor(const SineFit& f) { return {f.a2, f.a1}; }

/// Mean over `window` of α̂ (the streaming estimator, rt/alpha_estimator.hpp) of the deadzone's
/// output Z(v) over the mean of α̂ of v itself; the estimator starts up to 0.5 s before the window.
/// 1 without a deadzone or when a mean is not positive. (A saturation is left out: measured on
/// the virtual plant, scaling α by its clipped peaks moved the points' β̃ away from the plant's,
/// 0.6 % → 2.6 % at 7 Hz, while a deadzone's scaling brings C closer, 8.8 % → 1.9 % at 2 Hz.)
double deadzone_alpha_ratio(const RunData& run, IndexRange window, double sample_period_s,
                            const Effects& fx) {
  if (!(fx.deadzone_v > 0.0)) return 1.0;
  Effects e;
  e.deadzone_v = fx.deadzone_v;
  double T = sample_period_s;
  if (!(T > 0.0) && window.size() > 1) {
    T = (run.t[window.end - 1] - run.t[window.begin]) / static_cast<double>(window.size() - 1);
  }
  rt::AlphaEstimatorConfig cfg;
  cfg.sample_period_s = T;
  if (!(T > 0.0) || !(cfg.cutoff_hz < 0.25 / T)) return 1.0;
  rt::AlphaEstimator ev(cfg), eu(cfg);
  std::size_t k0 = window.begin;
  while (k0 > 0 && run.t[window.begin] - run.t[k0 - 1] <= 0.5) --k0;
  ev.reset(run.v[k0]);
  eu.reset(amplifier(e, run.v[k0]));
  double sv = 0.0, su = 0.0;
  for (std::size_t k = k0; k < window.end; ++k) {
    const double av = ev.update(run.v[k]).alpha;
    const double au = eu.update(amplifier(e, run.v[k])).alpha;
    if (k >= window.begin) sv += av, su += au;
  }
  const double ratio = su / sv;
  return sv > 0.0 && su > 0.0 && std::isfinite(ratio) ? ratio : 1.0;
}

/// The plant input has a torque term n(θ, θ̇) + d(t) (which needs θ̇): any term of
/// effect_torque() on (TorqueEffects::any(): every friction form, the discovered term, the
/// offset), or a known disturbance. (A hand-kept list here once missed Stribeck, asymmetric and
/// position-dependent friction: a model holding one had its α-model re-identified as though its
/// friction were not in the plant input, and absorbed it twice.)
/// A discovered term's memory terms (a lagged friction, a Dahl state: DiscoveredMemory) are a
/// torque of the state's history, which effect_torque() leaves out: they are added from their
/// state run along the measured record (discovered_memory_torque_along()). Left out until
/// 2026-12-07, a model with them had its α-model identified as though they were not in the plant
/// input (the α-model took in the friction they carry, and the simulation had it twice).
bool has_torque(const Effects& effects, const KnownInputSeries& known) {
  return TorqueEffects(effects).any() || discovered_memory_active(effects) || known.has_disturbance();
}

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

std::vector<double> sine_point_theta_dot(const RunData& run) {
  std::vector<double> dth, ddth;
  local_quadratic_derivatives(run.t, run.theta, 0.01, dth, ddth);
  return dth;
}

LocalLinearPoint sine_point_with_effects(const RunData& run, IndexRange window, double freq_hz,
                                         double kp, double sample_period_s, const Effects& effects) {
  return sine_point_with_effects(
      run, window, freq_hz, kp, sample_period_s, effects,
      has_torque(effects, KnownInputSeries::of_run(run)) ? sine_point_theta_dot(run)
                                                          : std::vector<double>{});
}

LocalLinearPoint sine_point_with_effects(const RunData& run, IndexRange window, double freq_hz,
                                         double kp, double sample_period_s, const Effects& effects,
                                         const std::vector<double>& theta_dot) {
  LocalLinearPoint bad;
  bad.freq_hz = freq_hz;
  bad.omega_rad_s = kTwoPi * freq_hz;
  if (window.end > run.size() || window.size() < 8 || !(freq_hz > 0.0)) return bad;
  const double w = kTwoPi * freq_hz;
  const double* t = run.t.data() + window.begin;
  const std::size_t n = window.size();
  const SineFit ft = fit_sine(t, run.theta.data() + window.begin, n, w);
  const SineFit fv = fit_sine(t, run.v.data() + window.begin, n, w);
  const KnownInputSeries known = KnownInputSeries::of_run(run);
  std::vector<double> amp(n);  // e(t)·S(Z(v)) of plant_input.hpp (the delay below)
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = window.begin + k;
    amp[k] = applied_command(effects, run.v[i], known.at_sample(i));
  }
  const SineFit fa = fit_sine(t, amp.data(), n, w);
  if (!ft.valid || !fv.valid || !fa.valid) return bad;
  // The delay shifts the amplifier's output: a phase −ωτ on its fundamental.
  std::complex<double> u = phasor(fa) * std::polar(1.0, -w * effects.delay_s);
  if (has_torque(effects, known)) {
    const std::vector<double>& dth = theta_dot;
    if (dth.size() != run.size()) return bad;
    std::vector<double> nt(n);
    std::vector<double> memory(discovered_memory_active(effects) ? window.end : 0);  // from the run's start
    discovered_memory_torque_along(effects, run.t.data(), dth.data(), memory.size(), memory.data());
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t i = window.begin + k;
      nt[k] = plant_torque(effects, run.t[i], run.theta[i], dth[i], known.at_sample(i)) +
              (memory.empty() ? 0.0 : memory[i]);
    }
    const SineFit fn = fit_sine(t, nt.data(), n, w);
    if (!fn.valid) return bad;
    u += phasor(fn);
  }
  if (!(std::abs(u) > 0.0)) return bad;
  LocalLinearPoint p =
      local_linear_point_from_input(freq_hz, phasor(ft), u, phasor(fv), kp, sample_period_s);
  // The plant's α is that of its input (a deadzone flattens the sine near zero): eq. (36)'s
  // ω²·|v|² scaled by the ratio of the mean α̂ of Z(v) to that of v.
  p.alpha_data *= deadzone_alpha_ratio(run, window, sample_period_s, effects);
  return p;
}

}  // namespace alphainv
