#pragma once
/// \file effect_sine_point.hpp
/// The local linear point of a sine run (section 2.2.4) when the plant's input is not the command
/// itself but u = S(Z(v(t − τ))) + n(θ, θ̇) (effects.hpp): the plant θ̈ + C·θ̇ = β̃·u is identified
/// from the fundamental of θ against the fundamental of u (the describing function of the
/// nonlinear terms), instead of against v = kp·(r − θ) as eqs. (19)-(20) do. With no effect the
/// two agree; with one, the point is freed of what the effect would otherwise put into C and β̃
/// (a spring shifts both with ω², a delay adds phase, friction adds damping that falls with
/// amplitude·ω). α_data is that of the command, eq. (36), scaled for a deadzone to the plant
/// input's α (the mean streaming estimate, rt/alpha_estimator.hpp, of Z(v) over that of v), as
/// the virtual plant and the digital-loop simulation compute α from what the amplifier passes.
/// Offline (allocates).

#include <complex>
#include <cstddef>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/model/effects.hpp"
#include "alphainv/identify/local_linear.hpp"

namespace alphainv {

/// The point from phasors at ω (a fitted sine y = A1 cos ωt + A2 sin ωt has phasor A2 + j·A1):
/// θ, the plant input u and the command v. The loop gain kp·θ/u stands where θ/(r − θ) stands in
/// eqs. (19)-(20) (continuous loop) or in the exact sampled-data inversion (sample_period_s > 0,
/// see local_linear_point()); α_data = ω²·|v|² (eq. (36)). The point's (a1, a2, ar) are those of
/// the equivalent effect-free closed loop with the measured |θ|.
LocalLinearPoint local_linear_point_from_input(double freq_hz, std::complex<double> theta,
                                               std::complex<double> input,
                                               std::complex<double> command, double kp,
                                               double sample_period_s = 0.0);

/// The point of a sine run at freq_hz over the steady-state samples `window` of `run` (t, θ, v),
/// with the plant input built from the measured command and state through `effects`: the
/// amplifier S(Z(v)) delayed by τ (a phase e^{−jωτ} on its fundamental) plus n(θ, θ̇), θ̇ from
/// local quadratic fits over ±10 ms; α_data scaled as the file comment says. `valid` false (in
/// `physical`) when a fit fails.
LocalLinearPoint sine_point_with_effects(const RunData& run, IndexRange window, double freq_hz,
                                         double kp, double sample_period_s, const Effects& effects);

/// The same with θ̇ of the whole run given (sine_point_theta_dot(run), which does not depend on
/// the effects): for callers that take the point of one run with many trial effects. `theta_dot`
/// is read only when a torque-like effect or a disturbance is on (the point is not `physical`
/// when it is then not of the run's length).
LocalLinearPoint sine_point_with_effects(const RunData& run, IndexRange window, double freq_hz,
                                         double kp, double sample_period_s, const Effects& effects,
                                         const std::vector<double>& theta_dot);

/// θ̇ of `run` as sine_point_with_effects() takes it: local quadratic fits over ±10 ms.
std::vector<double> sine_point_theta_dot(const RunData& run);

}  // namespace alphainv
