#pragma once
/// \file effects.hpp
/// The physical effects beyond the α-invariant model (the catalogue of `omni_fit diagnose`), as
/// terms added to eq. (11):
///     θ̈ + C(α, I)·θ̇ = β̃(α, I)·(S(Z(v(t − τ))) + n(θ, θ̇)),
///     n = −Fc·tanh(θ̇/ε)          coulomb_friction (smoothed)
///       + d0                      offset_torque
///       − g·sin(θ + θ0)           gravity
///       + a·sin(2π·θ/p + φ)       cogging, periodic in θ,
///       − σ(θ̇)·(Fc + (Fs − Fc)·exp(−(θ̇/v_s)²))        stribeck_friction
///       − σ(θ̇)·(Fc⁺·h⁺ + Fc⁻·h⁻) − (Δb/2)·θ̇·σ(θ̇)       asymmetric_friction
///       − σ(θ̇)·max(0, Fc0 + s·θ)                         position_dependent_friction
///     (+ d(t): a torque of time, not of the state, external_disturbance: per run, the run's
///      `disturbance_v` column, plant_input.hpp; the table entry carries its size)
///       + Σ_k c_k·φ_k(θ, θ̇)                               discovered (a fixed library φ,
///                                                           kDiscoveredLibrary; sparse c)
///     (+ c_f·tanh(f/ε_f) + c_z·z: the discovered term's memory terms, a lagged velocity f and a
///      Dahl state z with a state of their own, advanced once per tick where the tick is:
///      DiscoveredMemory, not effect_torque())
/// with σ(θ̇) = tanh(θ̇/ε) (each friction effect has its own smoothing ε, a modelling choice),
/// h⁺ = (1 + σ)/2, h⁻ = (1 − σ)/2 (the direction weights), and,
/// with τ the command delay (time_delay), Z the deadzone Z(v) = sign(v)·max(|v| − d, 0) (deadzone)
/// and S the clamp to ±v_max (saturation). Torques are in command units. Every effect is off at its
/// default. The virtual plant, the simulator and the 1 kHz online model all use these functions.
///
/// Everything else the code knows about an effect is its entry of the one table, kEffectCatalogue
/// (below): its name, its parameters with units, checks and search bounds, its modelling choices,
/// how it enters the equation, the search grid and starts `omni_fit diagnose` uses, and how
/// `omni_gen` and `omni_fit sweep` set and draw it. A new effect is a member of Effects, its term
/// in detail::effect_torque_sum() (a detail::TorqueTerm value, its on-test and arguments in
/// DividedArguments and TorqueEffects, torque_effects.hpp, and its bit in
/// TorqueEffects::terms_on()) or amplifier() (its physics), one table entry, and its tests
/// (docs/architecture.md).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <initializer_list>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "alphainv/error.hpp"
#include "alphainv/model/detail/field_checks.hpp"

namespace alphainv {

/// Effect parameters. Each effect is off at its default value (0, or infinity for the saturation).
struct Effects {
  double coulomb_v = 0.0;                 ///< Coulomb friction level Fc [command unit], ≥ 0
  double coulomb_smoothing_rad_s = 1e-3;  ///< tanh smoothing velocity ε [position unit/s], > 0
  double offset_v = 0.0;                  ///< constant offset torque d0 [command unit]
  double gravity_v = 0.0;                 ///< gravity torque amplitude g [command unit]
  double gravity_theta0_rad = 0.0;        ///< gravity phase θ0 [rad]: n = −g·sin(θ + θ0)
  double cogging_v = 0.0;                 ///< cogging amplitude a [command unit]
  double cogging_period_rad = 0.02;       ///< cogging period p in θ [position unit], > 0
  double cogging_phase_rad = 0.0;         ///< cogging phase φ [rad]
  double delay_s = 0.0;  ///< command transport delay τ [s], 0 ≤ τ ≤ kMaxDelayS
  double saturation_v = std::numeric_limits<double>::infinity();  ///< amplifier limit v_max > 0
  double deadzone_v = 0.0;  ///< amplifier deadzone half-width d [command unit], ≥ 0
  double stribeck_coulomb_v = 0.0;     ///< Stribeck: Coulomb (sliding) level Fc [command unit], ≥ 0
  double stribeck_breakaway_v = 0.0;   ///< Stribeck: breakaway level Fs at θ̇ → 0 [command unit], ≥ 0
  double stribeck_velocity_rad_s = 0.1;  ///< Stribeck velocity v_s [position unit/s], > 0
  double stribeck_smoothing_rad_s = 1e-3;  ///< its tanh smoothing ε [position unit/s], > 0
  double asymmetric_coulomb_pos_v = 0.0;  ///< Coulomb level moving forward Fc⁺ [command unit], ≥ 0
  double asymmetric_coulomb_neg_v = 0.0;  ///< Coulomb level moving backward Fc⁻ [command unit], ≥ 0
  /// Viscous level forward minus backward Δb = b⁺ − b⁻ [command unit/(position unit/s)]; their
  /// mean is the α-model's damping C (not identifiable apart from it)
  double asymmetric_viscous_diff_v_s = 0.0;
  double asymmetric_smoothing_rad_s = 1e-3;  ///< its tanh smoothing ε [position unit/s], > 0
  double position_coulomb_v = 0.0;  ///< Coulomb level at θ = 0, Fc0 [command unit]
  double position_slope_v_per_rad = 0.0;  ///< its slope along θ, s [command unit/position unit]
  double position_smoothing_rad_s = 1e-3;  ///< its tanh smoothing ε [position unit/s], > 0
  /// External disturbance: the RMS of the estimated d̂(t) over the runs it was located in
  /// [command unit] (the series itself is per run: the `disturbance_v` column of plant_input.hpp)
  double disturbance_rms_v = 0.0;
  double disturbance_window_s = 0.05;  ///< its windows [s], > 0 (external_disturbance.hpp)
  /// The discovered term (omni_fit diagnose's sparse regression, diagnose/discovered_term.hpp):
  /// coefficients c_k [command unit] of the fixed library φ_k (kDiscoveredLibrary, in that
  /// order), with σ = tanh(θ̇/ε), w = θ̇/v_r, x = (θ − θ_c)/θ_r; 0: the term is not used.
  double discovered_one_v = 0.0;          ///< c of 1
  double discovered_sign_v = 0.0;         ///< c of σ
  double discovered_vel_v = 0.0;          ///< c of w
  double discovered_abs_vel_v = 0.0;      ///< c of w·σ (≈ |w|)
  double discovered_vel_abs_vel_v = 0.0;  ///< c of w·|w|
  double discovered_vel_cubed_v = 0.0;    ///< c of w³
  double discovered_stribeck_fast_v = 0.0;  ///< c of σ·exp(−(w/0.05)²)
  double discovered_stribeck_mid_v = 0.0;   ///< c of σ·exp(−(w/0.15)²)
  double discovered_stribeck_slow_v = 0.0;  ///< c of σ·exp(−(w/0.5)²)
  double discovered_pos_v = 0.0;          ///< c of x
  double discovered_sign_pos_v = 0.0;     ///< c of σ·x
  double discovered_sin1_v = 0.0;         ///< c of sin(π·x)
  double discovered_cos1_v = 0.0;         ///< c of cos(π·x)
  double discovered_sin2_v = 0.0;         ///< c of sin(2π·x)
  double discovered_cos2_v = 0.0;         ///< c of cos(2π·x)
  double discovered_sin3_v = 0.0;         ///< c of sin(3π·x)
  double discovered_cos3_v = 0.0;         ///< c of cos(3π·x)
  double discovered_smoothing_rad_s = 1e-3;     ///< its σ's smoothing ε [position unit/s], > 0
  double discovered_velocity_scale_rad_s = 1.0; ///< v_r [position unit/s], > 0
  double discovered_position_center_rad = 0.0;  ///< θ_c [position unit]
  double discovered_position_scale_rad = 1.0;   ///< θ_r [position unit], > 0
  /// The discovered term's memory terms (DiscoveredMemory: a state advanced once per tick, so a
  /// model with them needs the digital loop; 0: off):
  double discovered_lag_sign_v = 0.0;  ///< c of tanh(f/ε), f = θ̇ through a first-order lag T_f
  double discovered_dahl_v = 0.0;      ///< c of z, a Dahl state: dz = (sign dθ − z)·|dθ|/δ
  double discovered_lag_s = 0.01;      ///< the lag's time constant T_f [s], > 0
  double discovered_lag_smoothing_rad_s = 1e-3;  ///< its tanh smoothing ε_f [position unit/s], > 0
  double discovered_dahl_rad = 1e-3;   ///< the Dahl state's displacement δ [position unit], > 0

  /// Longest delay accepted [s] (delay lines are sized from it).
  static constexpr double kMaxDelayS = 1.0;
};

/// One function φ_k of the discovered term's library.
struct DiscoveredFunction {
  double Effects::*coefficient;  ///< where its coefficient c_k lives
  const char* formula;           ///< e.g. "tanh(theta'/eps)" (sigma, w, x as in Effects)
};

/// The number of functions of the discovered term's library.
inline constexpr std::size_t kDiscoveredTerms = 17;

/// The discovered term's library, in the order of discovered_basis() (Effects' comments).
inline constexpr std::array<DiscoveredFunction, kDiscoveredTerms> kDiscoveredLibrary = {{
    {&Effects::discovered_one_v, "1"},
    {&Effects::discovered_sign_v, "sigma"},
    {&Effects::discovered_vel_v, "w"},
    {&Effects::discovered_abs_vel_v, "w sigma"},
    {&Effects::discovered_vel_abs_vel_v, "w |w|"},
    {&Effects::discovered_vel_cubed_v, "w^3"},
    {&Effects::discovered_stribeck_fast_v, "sigma exp(-(w/0.05)^2)"},
    {&Effects::discovered_stribeck_mid_v, "sigma exp(-(w/0.15)^2)"},
    {&Effects::discovered_stribeck_slow_v, "sigma exp(-(w/0.5)^2)"},
    {&Effects::discovered_pos_v, "x"},
    {&Effects::discovered_sign_pos_v, "sigma x"},
    {&Effects::discovered_sin1_v, "sin(pi x)"},
    {&Effects::discovered_cos1_v, "cos(pi x)"},
    {&Effects::discovered_sin2_v, "sin(2 pi x)"},
    {&Effects::discovered_cos2_v, "cos(2 pi x)"},
    {&Effects::discovered_sin3_v, "sin(3 pi x)"},
    {&Effects::discovered_cos3_v, "cos(3 pi x)"},
}};

/// The library's Stribeck velocities, as fractions of v_r (the three σ·exp(−(w/s)²) terms).
inline constexpr std::array<double, 3> kDiscoveredStribeckFractions = {0.05, 0.15, 0.5};

/// φ_k(θ, θ̇) of the library (kDiscoveredLibrary order) with the scales of `e` (ε, v_r, θ_c, θ_r).
/// Real-time safe.
inline void discovered_basis(const Effects& e, double theta, double theta_dot,
                             std::array<double, kDiscoveredTerms>& phi) noexcept {
  constexpr double kHalfTurn = 3.14159265358979323846;  // π
  const double sg = std::tanh(theta_dot / e.discovered_smoothing_rad_s);
  const double w = theta_dot / e.discovered_velocity_scale_rad_s;
  const double x = (theta - e.discovered_position_center_rad) / e.discovered_position_scale_rad;
  phi[0] = 1.0;
  phi[1] = sg;
  phi[2] = w;
  phi[3] = w * sg;
  phi[4] = w * std::abs(w);
  phi[5] = w * w * w;
  for (std::size_t j = 0; j < kDiscoveredStribeckFractions.size(); ++j) {
    const double z = w / kDiscoveredStribeckFractions[j];
    phi[6 + j] = sg * std::exp(-z * z);
  }
  phi[9] = x;
  phi[10] = sg * x;
  for (int m = 1; m <= 3; ++m) {
    phi[static_cast<std::size_t>(9 + 2 * m)] = std::sin(m * kHalfTurn * x);
    phi[static_cast<std::size_t>(10 + 2 * m)] = std::cos(m * kHalfTurn * x);
  }
}

/// Whether any coefficient of the discovered term's library (its terms without memory) is
/// non-zero.
inline bool discovered_active(const Effects& e) noexcept {
  for (const DiscoveredFunction& f : kDiscoveredLibrary) {
    if (e.*f.coefficient != 0.0) return true;
  }
  return false;
}

/// Whether the discovered term has a memory term (discovered_lag_sign_v or discovered_dahl_v
/// non-zero): a torque of the state's history, DiscoveredMemory. Real-time safe.
inline bool discovered_memory_active(const Effects& e) noexcept {
  return e.discovered_lag_sign_v != 0.0 || e.discovered_dahl_v != 0.0;
}

/// The state of the discovered term's memory terms and its advance once per tick (the
/// simulator's digital loop, the virtual plant, the 1 kHz compensation):
///     f ← θ̇ + (f − θ̇)·λ,  λ = exp(−T/T_f)                  (a first-order lag of θ̇, exact
///                                                             for θ̇ held over the tick)
///     z ← s − (s − z)·exp(−|Δθ|/δ),  s = sign Δθ             (Dahl: dz = (s − z)·|dθ|/δ, exact
///                                                             over the tick's displacement Δθ)
///     n_mem = c_f·tanh(f/ε_f) + c_z·z
/// with ε_f the lag's own smoothing. Both are a friction with memory: the lag's sign reverses T_f
/// after the velocity does (a frictional lag), z turns over a displacement δ after a reversal
/// (pre-sliding, a bristle state). Started with f = θ̇ and z = 0. Real-time safe.
struct DiscoveredMemory {
  double lag_velocity_rad_s = 0.0;  ///< f
  double dahl_state = 0.0;          ///< z, in [−1, 1]

  /// λ = exp(−period_s/T_f) for a tick of `period_s` [s].
  static double lag_decay(const Effects& e, double period_s) noexcept {
    return std::exp(-period_s / e.discovered_lag_s);
  }
  /// Starts the state at velocity `theta_dot` (f = θ̇, z = 0).
  void reset(double theta_dot) noexcept {
    lag_velocity_rad_s = theta_dot;
    dahl_state = 0.0;
  }
  /// Advances the state over one tick to velocity `theta_dot` with the displacement
  /// `delta_theta` over it and the lag's decay `lag_decay` (lag_decay()).
  void advance(const Effects& e, double lag_decay, double delta_theta, double theta_dot) noexcept {
    lag_velocity_rad_s = theta_dot + (lag_velocity_rad_s - theta_dot) * lag_decay;
    if (e.discovered_dahl_v != 0.0 && delta_theta != 0.0) {
      const double s = delta_theta > 0.0 ? 1.0 : -1.0;
      dahl_state = s - (s - dahl_state) * std::exp(-std::abs(delta_theta) / e.discovered_dahl_rad);
    }
  }
  /// n_mem [command unit] at the present state.
  double torque(const Effects& e) const noexcept {
    double n = 0.0;
    if (e.discovered_lag_sign_v != 0.0)
      n += e.discovered_lag_sign_v * std::tanh(lag_velocity_rad_s / e.discovered_lag_smoothing_rad_s);
    if (e.discovered_dahl_v != 0.0) n += e.discovered_dahl_v * dahl_state;
    return n;
  }
};

/// n_mem (DiscoveredMemory::torque()) at every sample of a measured record: `out[k]` for the n
/// samples of times `t_s` and velocities `theta_dot` (rad/s), in time order. The state starts at
/// the first sample (f = θ̇, z = 0) and again after a gap (a step not in (0, 0.05] s); each step
/// advances it with the lag's decay over the step and the displacement from θ̇ by the trapezoid
/// (a measured θ's noise would turn z over at rest). All zeros when the term has no memory term.
/// What a fit on measured data adds to effect_torque() (which has no state) wherever it uses the
/// plant input along a recorded run: the local sine points, the equation-error residuals. Offline
/// use; no allocation.
inline void discovered_memory_torque_along(const Effects& e, const double* t_s, const double* theta_dot,
                                           std::size_t n, double* out) noexcept {
  if (!discovered_memory_active(e)) {
    for (std::size_t k = 0; k < n; ++k) out[k] = 0.0;
    return;
  }
  DiscoveredMemory m;
  for (std::size_t k = 0; k < n; ++k) {
    const double dt = k > 0 ? t_s[k] - t_s[k - 1] : 0.0;
    if (k == 0 || !(dt > 0.0) || dt > 0.05 || !std::isfinite(theta_dot[k]) || !std::isfinite(theta_dot[k - 1])) {
      m.reset(std::isfinite(theta_dot[k]) ? theta_dot[k] : 0.0);
    } else {
      m.advance(e, DiscoveredMemory::lag_decay(e, dt), 0.5 * (theta_dot[k] + theta_dot[k - 1]) * dt, theta_dot[k]);
    }
    out[k] = m.torque(e);
  }
}

/// Σ_k c_k·φ_k(θ, θ̇) [command unit]: the discovered term. Real-time safe.
inline double discovered_torque(const Effects& e, double theta, double theta_dot) noexcept {
  std::array<double, kDiscoveredTerms> phi;
  discovered_basis(e, theta, theta_dot, phi);
  double n = 0.0;
  for (std::size_t k = 0; k < kDiscoveredTerms; ++k) n += e.*kDiscoveredLibrary[k].coefficient * phi[k];
  return n;
}

/// The discovered term as an equation with its non-zero terms and scales, e.g.
/// "n = -0.00412 sigma + 0.0021 sigma exp(-(w/0.15)^2); sigma = tanh(theta'/0.001),
/// w = theta'/0.21, x = (theta - 0)/0.07"; "n = 0" when off.
inline std::string discovered_equation(const Effects& e) {
  std::string eq;
  auto add = [&eq](double c, const char* formula) {  // " + 0.002 x", "-0.0041 sigma", "0.003"
    if (c == 0.0) return;
    char buf[48];
    std::snprintf(buf, sizeof buf, "%.4g", std::abs(c));
    eq += std::string(eq.empty() ? (c < 0 ? "-" : "") : (c < 0 ? " - " : " + ")) + buf +
          (std::string(formula) == "1" ? "" : std::string(" ") + formula);
  };
  for (const DiscoveredFunction& f : kDiscoveredLibrary) add(e.*f.coefficient, f.formula);
  add(e.discovered_lag_sign_v, "tanh(f/eps_f)");  // the memory terms
  add(e.discovered_dahl_v, "z");
  if (eq.empty()) return "n = 0";
  std::string out = "n = " + eq + "; sigma = tanh(theta'/" + detail::num(e.discovered_smoothing_rad_s) +
                    "), w = theta'/" + detail::num(e.discovered_velocity_scale_rad_s) +
                    ", x = (theta - " + detail::num(e.discovered_position_center_rad) + ")/" +
                    detail::num(e.discovered_position_scale_rad);
  if (e.discovered_lag_sign_v != 0.0)
    out += ", f = theta' through a lag of " + detail::num(e.discovered_lag_s) + " s, eps_f = " +
           detail::num(e.discovered_lag_smoothing_rad_s);
  if (e.discovered_dahl_v != 0.0)
    out += ", z a Dahl state (dz = (sign dtheta - z)|dtheta|/" + detail::num(e.discovered_dahl_rad) + ")";
  return out;
}

namespace detail {

/// The terms of n(θ, θ̇) after the offset (which starts the sum), in effect_torque_terms' order:
/// a Sum policy is told which term each addend is.
enum class TorqueTerm : unsigned {
  kCoulomb,
  kGravity,
  kCogging,
  kStribeck,
  kAsymmetric,
  kPosition,
  kDiscovered,
};
/// Bit of `term` in a mask of TorqueTerms.
constexpr unsigned torque_term_bit(TorqueTerm term) noexcept {
  return 1u << static_cast<unsigned>(term);
}

/// effect_torque_terms' sum: the offset, then each term added in order.
struct PlainTorqueSum {
  double n = 0.0;
  void start(double offset) noexcept { n = offset; }
  void add(TorqueTerm, double addend) noexcept { n += addend; }
};

/// The terms of n(θ, θ̇) (file comment): the one formula of effect_torque() and of TorqueEffects
/// (torque_effects.hpp), summed by `sum`: sum.start(offset), then sum.add(term, addend) for each
/// term on, in order (PlainTorqueSum adds them all; the compensator's sum splits them by whether
/// they depend on θ̇, so one pass gives both parts). An addend is the term with its sign, so
/// n + addend is n − term bit for bit. `a` says which terms are on, gives the arguments of their
/// tanh and sin and evaluates those (a.tanh(x), a.sin(x)): DividedArguments as written (θ̇/ε,
/// 2π·θ/p, the tests of the parameters each call, std::tanh and std::sin), TorqueEffects'
/// precomputed ones (θ̇·(1/ε), θ·(2π/p), flags) with detail::fast_tanh and fast_sin
/// (fast_math.hpp: a few ulp from std::). Real-time safe.
template <class Arguments, class Sum>
inline void effect_torque_sum(const Effects& e, const Arguments& a, double theta, double theta_dot,
                              Sum& sum) noexcept {
  sum.start(e.offset_v);
  if (a.coulomb_on()) sum.add(TorqueTerm::kCoulomb, -(e.coulomb_v * a.tanh(a.coulomb_x(theta_dot))));
  if (a.gravity_on()) {
    sum.add(TorqueTerm::kGravity, -(e.gravity_v * a.sin(theta + e.gravity_theta0_rad)));
  }
  if (a.cogging_on()) {
    sum.add(TorqueTerm::kCogging, e.cogging_v * a.sin(a.cogging_x(theta) + e.cogging_phase_rad));
  }
  if (a.stribeck_on()) {
    const double x = a.stribeck_w(theta_dot);
    sum.add(TorqueTerm::kStribeck,
            -(a.tanh(a.stribeck_x(theta_dot)) *
              (e.stribeck_coulomb_v +
               (e.stribeck_breakaway_v - e.stribeck_coulomb_v) * std::exp(-x * x))));
  }
  if (a.asymmetric_on()) {
    const double sg = a.tanh(a.asymmetric_x(theta_dot));
    sum.add(TorqueTerm::kAsymmetric, -(sg * (e.asymmetric_coulomb_pos_v * 0.5 * (1.0 + sg) +
                                             e.asymmetric_coulomb_neg_v * 0.5 * (1.0 - sg)) +
                                       0.5 * e.asymmetric_viscous_diff_v_s * theta_dot * sg));
  }
  if (a.position_on()) {
    const double level = std::max(0.0, e.position_coulomb_v + e.position_slope_v_per_rad * theta);
    sum.add(TorqueTerm::kPosition, -(a.tanh(a.position_x(theta_dot)) * level));
  }
  if (a.discovered_on()) sum.add(TorqueTerm::kDiscovered, discovered_torque(e, theta, theta_dot));
}

/// n(θ, θ̇): effect_torque_sum's plain sum. Real-time safe.
template <class Arguments>
inline double effect_torque_terms(const Effects& e, const Arguments& a, double theta,
                                  double theta_dot) noexcept {
  PlainTorqueSum sum;
  effect_torque_sum(e, a, theta, theta_dot, sum);
  return sum.n;
}

/// effect_torque_terms' arguments as the file comment writes them: each call tests the parameters
/// and divides by ε and p.
struct DividedArguments {
  static constexpr double kTwoPi = 6.283185307179586476925;
  const Effects& e;
  bool coulomb_on() const noexcept { return e.coulomb_v > 0.0; }
  bool gravity_on() const noexcept { return e.gravity_v != 0.0; }
  bool cogging_on() const noexcept { return e.cogging_v != 0.0; }
  bool stribeck_on() const noexcept {
    return e.stribeck_coulomb_v > 0.0 || e.stribeck_breakaway_v > 0.0;
  }
  bool asymmetric_on() const noexcept {
    return e.asymmetric_coulomb_pos_v > 0.0 || e.asymmetric_coulomb_neg_v > 0.0 ||
           e.asymmetric_viscous_diff_v_s != 0.0;
  }
  bool position_on() const noexcept {
    return e.position_coulomb_v != 0.0 || e.position_slope_v_per_rad != 0.0;
  }
  bool discovered_on() const noexcept { return discovered_active(e); }
  double coulomb_x(double theta_dot) const noexcept { return theta_dot / e.coulomb_smoothing_rad_s; }
  double cogging_x(double theta) const noexcept { return kTwoPi * theta / e.cogging_period_rad; }
  double stribeck_w(double theta_dot) const noexcept { return theta_dot / e.stribeck_velocity_rad_s; }
  double stribeck_x(double theta_dot) const noexcept { return theta_dot / e.stribeck_smoothing_rad_s; }
  double asymmetric_x(double theta_dot) const noexcept {
    return theta_dot / e.asymmetric_smoothing_rad_s;
  }
  double position_x(double theta_dot) const noexcept { return theta_dot / e.position_smoothing_rad_s; }
  static double tanh(double x) noexcept { return std::tanh(x); }
  static double sin(double x) noexcept { return std::sin(x); }
};

}  // namespace detail

/// n(θ, θ̇) [command unit]: the torque-like effects (file comment). Real-time safe. A loop that
/// evaluates one Effects every tick uses TorqueEffects (torque_effects.hpp): the same terms with
/// their constants precomputed.
inline double effect_torque(const Effects& e, double theta, double theta_dot) noexcept {
  return detail::effect_torque_terms(e, detail::DividedArguments{e}, theta, theta_dot);
}

/// Whether effect_torque() depends on θ or θ̇ for these effects: false when only constant terms
/// (the offset d0, the discovered term's constant c_1) are on, so that n is constant and the plant
/// between ticks is linear with a constant input (simulate: the exact segment of virtual_omni.hpp).
inline bool torque_depends_on_state(const Effects& e) noexcept {
  if (e.coulomb_v > 0.0 || e.gravity_v != 0.0 || e.cogging_v != 0.0) return true;
  if (e.stribeck_coulomb_v > 0.0 || e.stribeck_breakaway_v > 0.0) return true;
  if (e.asymmetric_coulomb_pos_v > 0.0 || e.asymmetric_coulomb_neg_v > 0.0 ||
      e.asymmetric_viscous_diff_v_s != 0.0)
    return true;
  if (e.position_coulomb_v != 0.0 || e.position_slope_v_per_rad != 0.0) return true;
  for (const DiscoveredFunction& f : kDiscoveredLibrary) {
    if (f.coefficient != &Effects::discovered_one_v && e.*f.coefficient != 0.0) return true;
  }
  return false;
}

/// Whether effect_torque() depends on θ̇ for these effects (the friction forms, and the discovered
/// term's terms in σ or w): the stiff part of the plant (β̃·Fc/ε at θ̇ = 0), which sets the RK4
/// step. Terms of θ alone (gravity, cogging, the discovered term's terms in x) are smooth.
inline bool torque_depends_on_velocity(const Effects& e) noexcept {
  if (e.coulomb_v > 0.0) return true;
  if (e.stribeck_coulomb_v > 0.0 || e.stribeck_breakaway_v > 0.0) return true;
  if (e.asymmetric_coulomb_pos_v > 0.0 || e.asymmetric_coulomb_neg_v > 0.0 ||
      e.asymmetric_viscous_diff_v_s != 0.0)
    return true;
  if (e.position_coulomb_v != 0.0 || e.position_slope_v_per_rad != 0.0) return true;
  for (std::size_t k = 1; k <= 10; ++k) {  // σ, w, w·σ, w|w|, w³, the three Stribeck terms, x, σ·x
    if (k == 9) continue;                    // x alone: a term of θ
    if (e.*kDiscoveredLibrary[k].coefficient != 0.0) return true;
  }
  return false;
}

/// S(Z(v)): the amplifier's deadzone, then its saturation [command unit]. Real-time safe.
inline double amplifier(const Effects& e, double v) noexcept {
  if (e.deadzone_v > 0.0) {  // Z(v) = sign(v)·max(|v| − d, 0)
    const double mag = std::abs(v) - e.deadzone_v;
    v = mag > 0.0 ? std::copysign(mag, v) : 0.0;
  }
  return std::clamp(v, -e.saturation_v, e.saturation_v);  // S(v)
}

/// The catalogue of `omni_fit diagnose`, in table order (kEffectCatalogue).
enum class EffectKind {
  kNone,
  kCoulombFriction,
  kOffsetTorque,
  kGravity,
  kCogging,
  kTimeDelay,
  kSaturation,
  kDeadzone,
  kStribeckFriction,
  kAsymmetricFriction,
  kPositionDependentFriction,
  kExternalDisturbance,
  kDiscovered,  ///< the discovered term: fitted after the named effects, not a candidate
  kCount,  ///< the number of kinds (not a kind): sizes the table
};

/// The number of effect kinds, kNone included.
inline constexpr std::size_t kEffectKindCount = static_cast<std::size_t>(EffectKind::kCount);

/// How an effect enters eq. (11) (file comment).
enum class EffectRole {
  kNone,      ///< no term (the catalogue's "none")
  kTorque,    ///< a term of n(θ, θ̇), effect_torque()
  kInputMap,  ///< a map of the command before the plant, amplifier()
  kDelay,     ///< the command delay τ: v(t − τ) (delay lines in the simulator and the plant)
  /// A torque d(t) of time, per run (external_disturbance): no term of effect_torque(); it enters
  /// plant_input() as the known disturbance d(t) of a run's `disturbance_v` column, which
  /// diagnose estimates (external_disturbance.hpp) and writes in that form
  kTimeSeries,
};

/// The data scales an effect's search is sized by (omni_fit diagnose).
struct EffectScales {
  double v_max = 1.0;      ///< largest |command| in the data [command unit]
  double kp = 1.0;         ///< the controller's proportional gain [command unit / position unit]
  double theta_min = 0.0;  ///< smallest measured θ [position unit]
  double theta_max = 0.0;  ///< largest measured θ [position unit]
  double theta_dot_rms = 1.0;  ///< RMS of the measured θ̇ [position unit/s]
};

/// The tanh smoothing ε of the friction terms diagnose fits (Coulomb, Stribeck, asymmetric and
/// position-dependent friction, the discovered term's σ), as a share of the data's RMS velocity:
/// a switch sharp on the data's scale. Generated plants switch 10-15× more sharply (ε = 0.001
/// rad/s): at 0.1 % a Stribeck case at 2e-4 rad was named right (at 1 %: Coulomb friction, a hump
/// as narrow as ε fitting the difference) and a Coulomb case's error after fell 44 % (verdict
/// explained), but the EMPS run named Stribeck friction and a saturation, its error 46 % down
/// instead of 70 %. Which ε a dataset needs is for the data to say (docs/diagnose.md, "Friction
/// smoothing"); until then 1 %.
inline constexpr double kFrictionSmoothingShareOfRmsVelocity = 0.01;

/// How validate_effects checks a parameter (the message names the field).
enum class ParameterCheck {
  kFinite,             ///< a finite number
  kNonNegative,        ///< finite, ≥ 0
  kPositiveIfActive,   ///< finite, > 0 when the effect is on
  kDelayRange,         ///< 0 ≤ τ ≤ Effects::kMaxDelayS
  kPositiveOrInfinity, ///< a limit > 0 (infinity: none)
};

/// The measured data an equation-error start regresses on (diagnose implements it): the implied
/// torque residual n̂ along the fit runs with the measured θ and θ̇ at the same samples.
class TorqueRegression {
 public:
  virtual ~TorqueRegression() = default;
  /// Number of samples.
  virtual std::size_t size() const = 0;
  /// θ [position unit] and θ̇ [position unit/s] at the samples.
  virtual const std::vector<double>& theta() const = 0;
  virtual const std::vector<double>& theta_dot() const = 0;
  /// Least-squares coefficients b of n̂ ≈ Σ b_j·columns[j]; *r2 (if given) the coefficient of
  /// determination (NaN when n̂ is constant).
  virtual std::vector<double> fit(const std::vector<std::vector<double>>& columns,
                                  double* r2) const = 0;
};

/// One named parameter of an effect, the Effects member that holds it, and what the code knows
/// about it.
struct EffectParameter {
  const char* name;         ///< model.json key and --effect PARAM, e.g. "coulomb_v"
  double Effects::*member;  ///< where it lives
  const char* unit;         ///< "command unit", "rad", "s", …
  const char* description;  ///< one line for --help, e.g. "Coulomb friction level Fc"
  ParameterCheck check;     ///< how validate_effects checks it
  /// A modelling choice (stored in model.json, needed by a simulation) rather than a fitted
  /// parameter, e.g. the smoothing ε of the Coulomb term.
  bool modelling_choice = false;
  /// diagnose: the search bounds [lo, hi] from the data scales and the start x.
  void (*search_bounds)(const EffectScales& scales, double x, double& lo, double& hi) = nullptr;
  /// diagnose: the Nelder-Mead step from the scales, the start x and the whole start vector of
  /// the effect's parameters (in search coordinates).
  double (*search_step)(const EffectScales& scales, double x, const std::vector<double>& start) = nullptr;
  /// sweep: the value when --vary does not draw it, and the range --vary draws it from,
  /// uniformly in [sweep_vary_lo, sweep_vary_lo + sweep_vary_span) (span 0: not drawn). Only for
  /// parameters after the first (the magnitude, which --vary scales by a factor).
  double sweep_fixed = 0.0;
  double sweep_vary_lo = 0.0, sweep_vary_span = 0.0;
  /// sweep: the value (fixed or drawn) is a factor on the hidden first parameter (a breakaway
  /// level 2.5× the Coulomb level) rather than the value itself.
  bool sweep_times_first = false;
};

/// The most parameters one effect has (modelling choices included): the discovered term's
/// library, its four scales, its two memory terms and their three scales.
inline constexpr std::size_t kMaxEffectParameters = kDiscoveredTerms + 9;

/// Everything the code knows about one effect of the catalogue.
struct EffectSpec {
  EffectKind kind;
  const char* name;         ///< catalogue name, e.g. "coulomb_friction"
  const char* description;  ///< one line, with its term of eq. (11)
  EffectRole role;          ///< how it enters eq. (11)
  std::array<EffectParameter, kMaxEffectParameters> parameters;  ///< the first parameter_count
  std::size_t parameter_count;
  /// Whether `e` has this effect switched on.
  bool (*active)(const Effects& e);

  // --- omni_fit diagnose (src/diagnose) ---------------------------------------------------------
  /// Equation-error start: sets the effect's parameters in `e` from a regression of n̂ (torque
  /// effects). nullptr: the effect's first parameter is started by a scan over search_grid.
  void (*equation_error_start)(const TorqueRegression& n_hat, const EffectScales& scales,
                               Effects& e) = nullptr;
  /// The coarse scan of the search with re-identification, in search coordinates, from the start
  /// vector (which it may keep as its first point).
  std::vector<std::vector<double>> (*search_grid)(const EffectScales& scales,
                                                  const std::vector<double>& start) = nullptr;
  /// Search coordinates other than the parameters (nullptr: the parameters themselves):
  /// to_search maps the start and sets the bounds, from_search sets the parameters from x.
  void (*to_search)(const EffectScales& scales, std::vector<double>& start,
                    std::vector<double>& lower, std::vector<double>& upper) = nullptr;
  void (*from_search)(const double* x, Effects& e) = nullptr;
  /// When > 0, the Nelder-Mead step of the first parameter is this fraction of the chosen start
  /// (no larger than the grid's spacing near it).
  double step_of_chosen_start = 0.0;
  /// Extra starts of the first parameter for the output-error fit when no search ran (cost
  /// functions with several minima).
  std::vector<double> (*extra_starts)(const EffectScales& scales) = nullptr;

  // --- omni_gen / omni_fit sweep ----------------------------------------------------------------
  /// Two magnitudes of the first parameter the sweep hides: clearly visible, and about half.
  std::array<double, 2> sweep_magnitudes{};
  /// The effect is stronger when its first parameter is smaller (a saturation's limit): the
  /// sweep's --vary factor divides instead of multiplying.
  bool stronger_when_smaller = false;
  /// A generalisation of another effect (e.g. Stribeck friction of Coulomb friction): diagnose
  /// tries it only when that one is among a round's two best candidates, and names it over that
  /// one only when it beats it in cross-validation (its extra parameters earn their place).
  EffectKind refines = EffectKind::kNone;
  /// A second effect it generalises (kNone: none): diagnose also tries it when that one is among
  /// the two best, and compares it with the better of the two. Asymmetric friction while moving
  /// is a Coulomb level (Fc+ + Fc−)/2 plus a constant (Fc+ − Fc−)/2: an offset torque is as much
  /// its trace as Coulomb friction (seed 41 of the sweep: gravity, offset, then Coulomb by
  /// training RMS, the generalisation never tried, gravity named for it).
  EffectKind also_refines = EffectKind::kNone;
  /// A candidate of `omni_fit diagnose` and a case of `omni_fit sweep`. false: the discovered
  /// term, which diagnose fits by sparse regression after the named effects
  /// (diagnose/discovered_term.hpp) instead of searching it.
  bool candidate = true;
  /// For a generalisation: the level `level_v` of the effect `parent` it generalises (that
  /// effect's first parameter, a Coulomb level) added into this effect's parameters in `e`: the
  /// same torque in this form (a Coulomb level c is Stribeck's Fc and Fs + c, asymmetric
  /// friction's Fc+ and Fc− + c, position-dependent friction's Fc0 + c). diagnose starts a
  /// refinement from its parent's fit so, and takes a parent named in an earlier round into the
  /// generalisation named after it. nullptr, or false returned: no such form for `parent` (an
  /// offset torque as asymmetric friction would need a negative level).
  bool (*take_in)(EffectKind parent, double level_v, Effects& e) = nullptr;

  /// Whether this effect generalises `other` (refines or also_refines; never kNone).
  bool generalises(EffectKind other) const noexcept {
    return other != EffectKind::kNone && (other == refines || other == also_refines);
  }

  /// The parameters, modelling choices included.
  const EffectParameter* begin() const noexcept { return parameters.data(); }
  const EffectParameter* end() const noexcept { return parameters.data() + parameter_count; }
};

namespace detail {
constexpr double kEffectTwoPi = 6.283185307179586476925;
inline std::vector<std::vector<double>> scaled_grid(double scale, std::initializer_list<double> f) {
  std::vector<std::vector<double>> g;
  for (double x : f) g.push_back({x * scale});
  return g;
}
inline double half_start(const EffectScales&, double x, const std::vector<double>&) {
  return 0.5 * std::abs(x);
}
/// A search grid of the start alone (the equation-error start is good; Nelder-Mead goes on).
inline std::vector<std::vector<double>> start_only_grid(const EffectScales&,
                                                        const std::vector<double>& start) {
  return {start};
}
inline void friction_level_bounds(const EffectScales& s, double, double& lo, double& hi) {
  lo = 0.0, hi = 2.0 * s.v_max;
}
inline double half_start_or_2pc_vmax(const EffectScales& s, double x, const std::vector<double>&) {
  return std::max(0.5 * std::abs(x), 0.02 * s.v_max);
}
inline void phase_bounds(const EffectScales&, double, double& lo, double& hi) {
  lo = -4 * kEffectTwoPi, hi = 4 * kEffectTwoPi;
}
inline void no_bounds(const EffectScales&, double, double& lo, double& hi) {
  lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity();
}
inline std::vector<double> column(std::size_t n, double value) { return std::vector<double>(n, value); }
inline void coefficient_bounds(const EffectScales& s, double, double& lo, double& hi) {
  lo = -2.0 * s.v_max, hi = 2.0 * s.v_max;
}
/// The discovered term's scales from the data: ε (kFrictionSmoothingShareOfRmsVelocity) and v_r
/// = 100 % of the RMS velocity, θ_c and θ_r the middle and half the range of θ.
inline void discovered_scales(const EffectScales& s, Effects& e) {
  const double v = s.theta_dot_rms > 0.0 && std::isfinite(s.theta_dot_rms) ? s.theta_dot_rms : 1.0;
  e.discovered_smoothing_rad_s = kFrictionSmoothingShareOfRmsVelocity * v;
  e.discovered_velocity_scale_rad_s = v;
  e.discovered_position_center_rad = 0.5 * (s.theta_min + s.theta_max);
  const double half = 0.5 * (s.theta_max - s.theta_min);
  e.discovered_position_scale_rad = half > 0.0 && std::isfinite(half) ? half : 1.0;
}
/// The discovered term's plain equation-error start: the data's scales and least squares of n̂
/// on the whole library (the sparse fit is diagnose's, discovered_term.hpp).
inline void discovered_least_squares_start(const TorqueRegression& r, const EffectScales& s,
                                           Effects& e) {
  discovered_scales(s, e);
  std::vector<std::vector<double>> cols(kDiscoveredTerms, std::vector<double>(r.size()));
  std::array<double, kDiscoveredTerms> phi{};
  for (std::size_t k = 0; k < r.size(); ++k) {
    discovered_basis(e, r.theta()[k], r.theta_dot()[k], phi);
    for (std::size_t j = 0; j < kDiscoveredTerms; ++j) cols[j][k] = phi[j];
  }
  const std::vector<double> b = r.fit(cols, nullptr);
  for (std::size_t j = 0; j < kDiscoveredTerms && j < b.size(); ++j) {
    e.*kDiscoveredLibrary[j].coefficient = std::isfinite(b[j]) ? std::clamp(b[j], -s.v_max, s.v_max) : 0.0;
  }
}
/// A parameter a spec or a text may leave out: a discovered coefficient that is 0.
inline bool omitted_when_zero(EffectKind kind, const EffectParameter& p) {
  return kind == EffectKind::kDiscovered && !p.modelling_choice;
}
}  // namespace detail

/// The one effect table, in EffectKind order ("none" first).
inline const std::array<EffectSpec, kEffectKindCount> kEffectCatalogue = {{
    {EffectKind::kNone, "none", "no effect beyond the alpha-invariant model", EffectRole::kNone,
     {}, 0, [](const Effects&) { return false; }},

    {EffectKind::kCoulombFriction, "coulomb_friction",
     "Coulomb friction, smoothed: n = -Fc tanh(theta'/eps)", EffectRole::kTorque,
     {{{"coulomb_v", &Effects::coulomb_v, "command unit", "Coulomb friction level Fc",
        ParameterCheck::kNonNegative, false,
        [](const EffectScales& s, double, double& lo, double& hi) { lo = 0.0, hi = 2.0 * s.v_max; },
        detail::half_start_or_2pc_vmax},
       {"coulomb_smoothing_rad_s", &Effects::coulomb_smoothing_rad_s, "position unit/s",
        "tanh smoothing velocity eps", ParameterCheck::kPositiveIfActive, true, detail::no_bounds,
        detail::half_start}}},
     2, [](const Effects& e) { return e.coulomb_v > 0.0; },
     [](const TorqueRegression& r, const EffectScales& s, Effects& e) {
       std::vector<double> sg(r.size());
       for (std::size_t k = 0; k < sg.size(); ++k)
         sg[k] = -std::tanh(r.theta_dot()[k] / e.coulomb_smoothing_rad_s);
       const std::vector<double> b = r.fit({sg, detail::column(r.size(), 1.0)}, nullptr);
       e.coulomb_v = std::clamp(b[0], 0.0, s.v_max);
     },
     [](const EffectScales& s, const std::vector<double>& start) {
       std::vector<std::vector<double>> g{start};
       for (double f : {0.005, 0.01, 0.02, 0.04, 0.08, 0.16, 0.3}) g.push_back({f * s.v_max});
       return g;
     },
     nullptr, nullptr, 0.0, nullptr, {0.02, 0.01}},

    {EffectKind::kOffsetTorque, "offset_torque", "constant offset torque: n = d0",
     EffectRole::kTorque,
     {{{"offset_v", &Effects::offset_v, "command unit", "offset torque d0", ParameterCheck::kFinite,
        false, [](const EffectScales& s, double, double& lo, double& hi) { lo = -s.v_max, hi = s.v_max; },
        detail::half_start_or_2pc_vmax}}},
     1, [](const Effects& e) { return e.offset_v != 0.0; },
     [](const TorqueRegression& r, const EffectScales& s, Effects& e) {
       const std::vector<double> b = r.fit({detail::column(r.size(), 1.0)}, nullptr);
       e.offset_v = std::clamp(b[0], -s.v_max, s.v_max);
     },
     [](const EffectScales&, const std::vector<double>& start) {
       return std::vector<std::vector<double>>{start, {0.0}};
     },
     nullptr, nullptr, 0.0, nullptr, {0.02, 0.01}},

    {EffectKind::kGravity, "gravity", "gravity: n = -g sin(theta + theta0)", EffectRole::kTorque,
     {{{"gravity_v", &Effects::gravity_v, "command unit", "gravity torque amplitude g",
        ParameterCheck::kFinite, false,
        [](const EffectScales& s, double, double& lo, double& hi) {
          lo = -2.0 * s.v_max, hi = 2.0 * s.v_max;
        },
        // searched as the spring k (to_search): steps of a tenth of the controller's stiffness
        [](const EffectScales& s, double, const std::vector<double>&) { return 0.1 * s.kp; }},
       {"gravity_theta0_rad", &Effects::gravity_theta0_rad, "rad", "gravity phase theta0",
        ParameterCheck::kFinite, false, detail::phase_bounds,
        // searched as the offset o (to_search)
        [](const EffectScales& s, double, const std::vector<double>& start) {
          return std::max(0.5 * std::abs(start[1]), 0.02 * s.v_max);
        },
        0.0, -0.5, 1.0}}},
     2, [](const Effects& e) { return e.gravity_v != 0.0; },
     [](const TorqueRegression& r, const EffectScales& s, Effects& e) {
       std::vector<double> sn(r.size()), cs(r.size());
       for (std::size_t k = 0; k < sn.size(); ++k) {
         sn[k] = std::sin(r.theta()[k]);
         cs[k] = std::cos(r.theta()[k]);
       }
       // −g·sin(θ + θ0) = −g·cos θ0·sin θ − g·sin θ0·cos θ
       const std::vector<double> b = r.fit({sn, cs}, nullptr);
       e.gravity_v = std::min(std::hypot(b[0], b[1]), 2.0 * s.v_max);
       e.gravity_theta0_rad = std::atan2(-b[1], -b[0]);
     },
     // A spring k of either sign, up to about the controller's stiffness kp, in ratios of about
     // 1.4 (a spring the model has absorbed has a narrow valley), with no offset (a pure spring)
     // and with the equation-error start's offset o (whose spring, from a model that absorbed
     // it, can have the wrong sign).
     [](const EffectScales& s, const std::vector<double>& start) {
       std::vector<std::vector<double>> g{start};
       const double o = start[1];
       for (double f : {-0.3, -0.1, 0.035, 0.05, 0.07, 0.1, 0.14, 0.2, 0.28, 0.4, 0.56}) {
         g.push_back({f * s.kp, 0.0});
         if (std::abs(o) > 0.005 * s.v_max) g.push_back({f * s.kp, o});
       }
       return g;
     },
     // x = (k, o), −g·sin(θ + θ0) = −k·sin θ − o·cos θ as a spring and an offset (k = g·cos θ0,
     // o = g·sin θ0): over a small range of θ the cost is nearly quadratic in (k, o) but a curved
     // valley in (g, θ0) when θ0 ≠ 0.
     [](const EffectScales& s, std::vector<double>& start, std::vector<double>& lower,
        std::vector<double>& upper) {
       const double g = start[0], th0 = start[1];
       start = {g * std::cos(th0), g * std::sin(th0)};
       lower = {-2.0 * s.v_max, -s.v_max};
       upper = {2.0 * s.v_max, s.v_max};
     },
     [](const double* x, Effects& e) {
       e.gravity_v = std::hypot(x[0], x[1]);
       e.gravity_theta0_rad = std::atan2(x[1], x[0]);
     },
     0.0, nullptr, {0.3, 0.15}},

    {EffectKind::kCogging, "cogging", "cogging, periodic in theta: n = a sin(2 pi theta/p + phi)",
     EffectRole::kTorque,
     {{{"cogging_v", &Effects::cogging_v, "command unit", "cogging amplitude a",
        ParameterCheck::kFinite, false,
        [](const EffectScales& s, double, double& lo, double& hi) { lo = -s.v_max, hi = s.v_max; },
        detail::half_start_or_2pc_vmax},
       {"cogging_period_rad", &Effects::cogging_period_rad, "position unit", "cogging period p",
        ParameterCheck::kPositiveIfActive, false,
        [](const EffectScales& s, double x, double& lo, double& hi) {
          lo = x / 1.3;
          hi = std::min(x * 1.3, (s.theta_max - s.theta_min) / 3.0);
          if (!(hi > lo)) hi = lo * 1.01;
        },
        [](const EffectScales&, double x, const std::vector<double>&) { return 0.02 * x; }, 0.02,
        0.012, 0.018},  // --vary: 0.012 … 0.03 rad, 5 … 12 periods over ±0.07 rad
       {"cogging_phase_rad", &Effects::cogging_phase_rad, "rad", "cogging phase phi",
        ParameterCheck::kFinite, false, detail::phase_bounds,
        [](const EffectScales&, double, const std::vector<double>&) { return 0.5; }, 0.5,
        -3.14159, 6.28318}}},
     3, [](const Effects& e) { return e.cogging_v != 0.0; },
     [](const TorqueRegression& r, const EffectScales& s, Effects& e) {
       // a·sin(2πθ/p + φ) = a cos φ·sin(2πθ/p) + a sin φ·cos(2πθ/p), best p on a log grid.
       const double range = std::max(s.theta_max - s.theta_min, 1e-9);
       double best_r2 = -std::numeric_limits<double>::infinity();
       // Periods from range/400 to range/3: a torque periodic in θ shows at least three periods
       // over the motion (a longer one is a spring or an offset, not cogging).
       for (int g = 0; g < 80; ++g) {
         const double p = range / 400.0 * std::pow(400.0 / 3.0, g / 79.0);
         std::vector<double> sn(r.size()), cs(r.size());
         for (std::size_t k = 0; k < sn.size(); ++k) {
           sn[k] = std::sin(detail::kEffectTwoPi * r.theta()[k] / p);
           cs[k] = std::cos(detail::kEffectTwoPi * r.theta()[k] / p);
         }
         double r2 = std::numeric_limits<double>::quiet_NaN();
         const std::vector<double> b = r.fit({sn, cs, detail::column(r.size(), 1.0)}, &r2);
         if (std::isfinite(r2) && r2 > best_r2) {
           best_r2 = r2;
           e.cogging_period_rad = p;
           e.cogging_v = std::min(std::hypot(b[0], b[1]), s.v_max);
           e.cogging_phase_rad = std::atan2(b[1], b[0]);
         }
       }
     },
     [](const EffectScales&, const std::vector<double>& start) {
       return std::vector<std::vector<double>>{start};
     },
     nullptr, nullptr, 0.0, nullptr, {0.02, 0.01}},

    {EffectKind::kTimeDelay, "time_delay", "command transport delay: v(t - tau)",
     EffectRole::kDelay,
     {{{"delay_s", &Effects::delay_s, "s", "command delay tau", ParameterCheck::kDelayRange, false,
        [](const EffectScales&, double, double& lo, double& hi) { lo = 0.0, hi = 0.2; },
        detail::half_start}}},
     1, [](const Effects& e) { return e.delay_s > 0.0; }, nullptr,
     [](const EffectScales&, const std::vector<double>&) {
       return detail::scaled_grid(1.0, {0.0005, 0.001, 0.002, 0.004, 0.008, 0.016, 0.032});
     },
     nullptr, nullptr, 0.4,
     [](const EffectScales&) { return std::vector<double>{0.001, 0.004, 0.012}; },
     {0.004, 0.002}},

    {EffectKind::kSaturation, "saturation", "amplifier limit: S(v) = clamp(v, -v_max, v_max)",
     EffectRole::kInputMap,
     {{{"saturation_v", &Effects::saturation_v, "command unit", "amplifier limit v_max (inf: none)",
        ParameterCheck::kPositiveOrInfinity, false,
        [](const EffectScales& s, double, double& lo, double& hi) {
          lo = 0.02 * s.v_max, hi = 3.0 * s.v_max;
        },
        [](const EffectScales& s, double, const std::vector<double>&) { return 0.1 * s.v_max; }}}},
     1, [](const Effects& e) { return std::isfinite(e.saturation_v); }, nullptr,
     [](const EffectScales& s, const std::vector<double>&) {
       return detail::scaled_grid(s.v_max, {0.95, 0.8, 0.6, 0.4, 0.25});
     },
     nullptr, nullptr, 0.0,
     [](const EffectScales& s) {
       return std::vector<double>{0.8 * s.v_max, 0.5 * s.v_max, 0.3 * s.v_max};
     },
     {0.12, 0.2}, true},

    {EffectKind::kDeadzone, "deadzone", "amplifier deadzone: Z(v) = sign(v) max(|v| - d, 0)",
     EffectRole::kInputMap,
     {{{"deadzone_v", &Effects::deadzone_v, "command unit", "amplifier deadzone half-width d",
        ParameterCheck::kNonNegative, false,
        [](const EffectScales& s, double, double& lo, double& hi) { lo = 0.0, hi = 0.5 * s.v_max; },
        detail::half_start}}},
     1, [](const Effects& e) { return e.deadzone_v > 0.0; }, nullptr,
     [](const EffectScales& s, const std::vector<double>&) {
       return detail::scaled_grid(s.v_max, {0.005, 0.01, 0.02, 0.05, 0.1, 0.2});
     },
     nullptr, nullptr, 0.4,
     [](const EffectScales& s) { return std::vector<double>{0.01 * s.v_max, 0.05 * s.v_max}; },
     {0.01, 0.005}},

    {EffectKind::kStribeckFriction, "stribeck_friction",
     "Stribeck friction: n = -tanh(theta'/eps) (Fc + (Fs - Fc) exp(-(theta'/v_s)^2))",
     EffectRole::kTorque,
     {{{"stribeck_coulomb_v", &Effects::stribeck_coulomb_v, "command unit",
        "Stribeck: Coulomb (sliding) level Fc", ParameterCheck::kNonNegative, false,
        detail::friction_level_bounds, detail::half_start_or_2pc_vmax},
       {"stribeck_breakaway_v", &Effects::stribeck_breakaway_v, "command unit",
        "Stribeck: breakaway level Fs", ParameterCheck::kNonNegative, false,
        detail::friction_level_bounds, detail::half_start_or_2pc_vmax, 2.5, 2.0, 1.5, true},
       {"stribeck_velocity_rad_s", &Effects::stribeck_velocity_rad_s, "position unit/s",
        "Stribeck velocity v_s", ParameterCheck::kPositiveIfActive, false,
        [](const EffectScales& s, double, double& lo, double& hi) {
          lo = 0.01 * s.theta_dot_rms, hi = 2.0 * s.theta_dot_rms;
        },
        detail::half_start, 0.15, 0.1, 0.2},
       {"stribeck_smoothing_rad_s", &Effects::stribeck_smoothing_rad_s, "position unit/s",
        "its tanh smoothing velocity eps", ParameterCheck::kPositiveIfActive, true,
        detail::no_bounds, detail::half_start}}},
     4, [](const Effects& e) { return e.stribeck_coulomb_v > 0.0 || e.stribeck_breakaway_v > 0.0; },
     [](const TorqueRegression& r, const EffectScales& s, Effects& e) {
       // For each v_s on a log grid: n̂ ≈ −σ·Fc − σ·exp(−(θ̇/v_s)²)·(Fs − Fc) + c; the best R².
       std::vector<double> sg(r.size()), st(r.size());
       for (std::size_t k = 0; k < sg.size(); ++k)
         sg[k] = -std::tanh(r.theta_dot()[k] / e.stribeck_smoothing_rad_s);
       double best_r2 = -std::numeric_limits<double>::infinity();
       for (int g = 0; g < 12; ++g) {
         const double vs = s.theta_dot_rms * 0.02 * std::pow(50.0, g / 11.0);
         for (std::size_t k = 0; k < st.size(); ++k) {
           const double x = r.theta_dot()[k] / vs;
           st[k] = sg[k] * std::exp(-x * x);
         }
         double r2 = std::numeric_limits<double>::quiet_NaN();
         const std::vector<double> b = r.fit({sg, st, detail::column(r.size(), 1.0)}, &r2);
         if (std::isfinite(r2) && r2 > best_r2) {
           best_r2 = r2;
           e.stribeck_coulomb_v = std::clamp(b[0], 0.0, s.v_max);
           e.stribeck_breakaway_v = std::clamp(b[0] + b[1], 0.0, 2.0 * s.v_max);
           e.stribeck_velocity_rad_s = vs;
         }
       }
     },
     detail::start_only_grid, nullptr, nullptr, 0.0, nullptr, {0.02, 0.01}, false,
     EffectKind::kCoulombFriction, EffectKind::kNone, true,
     [](EffectKind parent, double c, Effects& e) {
       if (parent != EffectKind::kCoulombFriction) return false;
       e.stribeck_coulomb_v += c;
       e.stribeck_breakaway_v += c;
       return true;
     }},

    {EffectKind::kAsymmetricFriction, "asymmetric_friction",
     "friction by direction: n = -s (Fc+ h+ + Fc- h-) - (db/2) theta' s, s = tanh(theta'/eps), "
     "h+- = (1 +- s)/2",
     EffectRole::kTorque,
     {{{"asymmetric_coulomb_pos_v", &Effects::asymmetric_coulomb_pos_v, "command unit",
        "Coulomb level moving forward Fc+", ParameterCheck::kNonNegative, false,
        detail::friction_level_bounds, detail::half_start_or_2pc_vmax},
       {"asymmetric_coulomb_neg_v", &Effects::asymmetric_coulomb_neg_v, "command unit",
        "Coulomb level moving backward Fc-", ParameterCheck::kNonNegative, false,
        detail::friction_level_bounds, detail::half_start_or_2pc_vmax, 0.5, 0.3, 0.4, true},
       {"asymmetric_viscous_diff_v_s", &Effects::asymmetric_viscous_diff_v_s,
        "command unit/(position unit/s)", "viscous level forward minus backward db",
        ParameterCheck::kFinite, false,
        [](const EffectScales& s, double, double& lo, double& hi) {
          hi = s.v_max / std::max(s.theta_dot_rms, 1e-12), lo = -hi;
        },
        [](const EffectScales& s, double x, const std::vector<double>&) {
          return std::max(0.5 * std::abs(x), 0.02 * s.v_max / std::max(s.theta_dot_rms, 1e-12));
        }},
       {"asymmetric_smoothing_rad_s", &Effects::asymmetric_smoothing_rad_s, "position unit/s",
        "its tanh smoothing velocity eps", ParameterCheck::kPositiveIfActive, true,
        detail::no_bounds, detail::half_start}}},
     4,
     [](const Effects& e) {
       return e.asymmetric_coulomb_pos_v > 0.0 || e.asymmetric_coulomb_neg_v > 0.0 ||
              e.asymmetric_viscous_diff_v_s != 0.0;
     },
     [](const TorqueRegression& r, const EffectScales& s, Effects& e) {
       // n̂ ≈ −σh⁺·Fc⁺ − σh⁻·Fc⁻ − (θ̇σ/2)·Δb + c
       std::vector<double> p(r.size()), m(r.size()), v(r.size());
       for (std::size_t k = 0; k < p.size(); ++k) {
         const double sg = std::tanh(r.theta_dot()[k] / e.asymmetric_smoothing_rad_s);
         p[k] = -sg * 0.5 * (1.0 + sg);
         m[k] = -sg * 0.5 * (1.0 - sg);
         v[k] = -0.5 * r.theta_dot()[k] * sg;
       }
       const std::vector<double> b = r.fit({p, m, v, detail::column(r.size(), 1.0)}, nullptr);
       e.asymmetric_coulomb_pos_v = std::clamp(b[0], 0.0, s.v_max);
       e.asymmetric_coulomb_neg_v = std::clamp(b[1], 0.0, s.v_max);
       const double vmax = s.v_max / std::max(s.theta_dot_rms, 1e-12);
       e.asymmetric_viscous_diff_v_s = std::clamp(b[2], -vmax, vmax);
     },
     detail::start_only_grid, nullptr, nullptr, 0.0, nullptr, {0.02, 0.01}, false,
     EffectKind::kCoulombFriction, EffectKind::kOffsetTorque, true,
     [](EffectKind parent, double c, Effects& e) {
       if (parent != EffectKind::kCoulombFriction) return false;
       e.asymmetric_coulomb_pos_v += c;
       e.asymmetric_coulomb_neg_v += c;
       return true;
     }},

    {EffectKind::kPositionDependentFriction, "position_dependent_friction",
     "Coulomb friction varying along theta: n = -tanh(theta'/eps) max(0, Fc0 + s theta)",
     EffectRole::kTorque,
     {{{"position_coulomb_v", &Effects::position_coulomb_v, "command unit",
        "Coulomb level at theta = 0, Fc0", ParameterCheck::kFinite, false,
        detail::friction_level_bounds, detail::half_start_or_2pc_vmax},
       {"position_slope_v_per_rad", &Effects::position_slope_v_per_rad,
        "command unit/position unit", "its slope along theta, s", ParameterCheck::kFinite, false,
        [](const EffectScales& s, double, double& lo, double& hi) {
          hi = 4.0 * s.v_max / std::max(s.theta_max - s.theta_min, 1e-12), lo = -hi;
        },
        [](const EffectScales& s, double x, const std::vector<double>&) {
          return std::max(0.5 * std::abs(x), 0.05 * s.v_max / std::max(s.theta_max - s.theta_min, 1e-12));
        },
        7.0, 4.0, 6.0, true},  // ±25 … ±70 % of Fc0 over ±0.07 rad
       {"position_smoothing_rad_s", &Effects::position_smoothing_rad_s, "position unit/s",
        "its tanh smoothing velocity eps", ParameterCheck::kPositiveIfActive, true,
        detail::no_bounds, detail::half_start}}},
     3, [](const Effects& e) { return e.position_coulomb_v != 0.0 || e.position_slope_v_per_rad != 0.0; },
     [](const TorqueRegression& r, const EffectScales& s, Effects& e) {
       // n̂ ≈ −σ·Fc0 − σθ·s + c
       std::vector<double> sg(r.size()), st(r.size());
       for (std::size_t k = 0; k < sg.size(); ++k) {
         sg[k] = -std::tanh(r.theta_dot()[k] / e.position_smoothing_rad_s);
         st[k] = sg[k] * r.theta()[k];
       }
       const std::vector<double> b = r.fit({sg, st, detail::column(r.size(), 1.0)}, nullptr);
       e.position_coulomb_v = std::clamp(b[0], 0.0, s.v_max);
       const double smax = 4.0 * s.v_max / std::max(s.theta_max - s.theta_min, 1e-12);
       e.position_slope_v_per_rad = std::clamp(b[1], -smax, smax);
     },
     detail::start_only_grid, nullptr, nullptr, 0.0, nullptr, {0.02, 0.01}, false,
     EffectKind::kCoulombFriction, EffectKind::kNone, true,
     [](EffectKind parent, double c, Effects& e) {
       // (exact where Fc0 + s θ ≥ 0, the level's clamp at zero aside)
       if (parent != EffectKind::kCoulombFriction) return false;
       e.position_coulomb_v += c;
       return true;
     }},

    {EffectKind::kExternalDisturbance, "external_disturbance",
     "a torque of time, not of the state (steps, pulses): n += d(t), per run, located in time "
     "windows; the series is the run's disturbance_v column",
     EffectRole::kTimeSeries,
     {{{"disturbance_rms_v", &Effects::disturbance_rms_v, "command unit",
        "RMS of the estimated d(t) over its runs", ParameterCheck::kNonNegative, false,
        detail::friction_level_bounds, detail::half_start_or_2pc_vmax},
       {"disturbance_window_s", &Effects::disturbance_window_s, "s",
        "window of its location in time", ParameterCheck::kPositiveIfActive, true,
        detail::no_bounds, detail::half_start}}},
     2, [](const Effects& e) { return e.disturbance_rms_v > 0.0; },
     // Not searched: located in time after the rounds (diagnose; external_disturbance.hpp). The
     // sweep hides it as omni_gen's --disturbance-pulses with the column left out.
     nullptr, detail::start_only_grid, nullptr, nullptr, 0.0, nullptr, {0.05, 0.025}},
    {EffectKind::kDiscovered, "discovered",
     "the discovered term: n = sum_k c_k phi_k(theta, theta') over a fixed library (sigma = "
     "tanh(theta'/eps), w = theta'/v_r, x = (theta - theta_c)/theta_r); fitted by sparse "
     "regression after the named effects",
     EffectRole::kTorque,
     {{
       {"discovered_one_v", &Effects::discovered_one_v, "command unit", "c of 1 (a constant)", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_sign_v", &Effects::discovered_sign_v, "command unit", "c of sigma = tanh(theta'/eps)", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_vel_v", &Effects::discovered_vel_v, "command unit", "c of w = theta'/v_r", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_abs_vel_v", &Effects::discovered_abs_vel_v, "command unit", "c of w sigma (about |w|)", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_vel_abs_vel_v", &Effects::discovered_vel_abs_vel_v, "command unit", "c of w |w|", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_vel_cubed_v", &Effects::discovered_vel_cubed_v, "command unit", "c of w^3", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_stribeck_fast_v", &Effects::discovered_stribeck_fast_v, "command unit", "c of sigma exp(-(w/0.05)^2)", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_stribeck_mid_v", &Effects::discovered_stribeck_mid_v, "command unit", "c of sigma exp(-(w/0.15)^2)", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_stribeck_slow_v", &Effects::discovered_stribeck_slow_v, "command unit", "c of sigma exp(-(w/0.5)^2)", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_pos_v", &Effects::discovered_pos_v, "command unit", "c of x = (theta - theta_c)/theta_r", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_sign_pos_v", &Effects::discovered_sign_pos_v, "command unit", "c of sigma x", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_sin1_v", &Effects::discovered_sin1_v, "command unit", "c of sin(pi x)", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_cos1_v", &Effects::discovered_cos1_v, "command unit", "c of cos(pi x)", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_sin2_v", &Effects::discovered_sin2_v, "command unit", "c of sin(2 pi x)", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_cos2_v", &Effects::discovered_cos2_v, "command unit", "c of cos(2 pi x)", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_sin3_v", &Effects::discovered_sin3_v, "command unit", "c of sin(3 pi x)", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_cos3_v", &Effects::discovered_cos3_v, "command unit", "c of cos(3 pi x)", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_smoothing_rad_s", &Effects::discovered_smoothing_rad_s, "position unit/s", "its sigma's tanh smoothing velocity eps", ParameterCheck::kPositiveIfActive, true,
        detail::no_bounds, detail::half_start},
       {"discovered_velocity_scale_rad_s", &Effects::discovered_velocity_scale_rad_s, "position unit/s", "velocity scale v_r", ParameterCheck::kPositiveIfActive, true,
        detail::no_bounds, detail::half_start},
       {"discovered_position_center_rad", &Effects::discovered_position_center_rad, "position unit", "position centre theta_c", ParameterCheck::kFinite, true,
        detail::no_bounds, detail::half_start},
       {"discovered_position_scale_rad", &Effects::discovered_position_scale_rad, "position unit", "position scale theta_r", ParameterCheck::kPositiveIfActive, true,
        detail::no_bounds, detail::half_start},
       {"discovered_lag_sign_v", &Effects::discovered_lag_sign_v, "command unit", "c of tanh(f/eps), f = theta' through a first-order lag (memory)", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_dahl_v", &Effects::discovered_dahl_v, "command unit", "c of z, a Dahl state (memory)", ParameterCheck::kFinite, false,
        detail::coefficient_bounds, detail::half_start_or_2pc_vmax},
       {"discovered_lag_s", &Effects::discovered_lag_s, "s", "the lag's time constant T_f", ParameterCheck::kPositiveIfActive, true,
        detail::no_bounds, detail::half_start},
       {"discovered_dahl_rad", &Effects::discovered_dahl_rad, "position unit", "the Dahl state's displacement delta", ParameterCheck::kPositiveIfActive, true,
        detail::no_bounds, detail::half_start},
       {"discovered_lag_smoothing_rad_s", &Effects::discovered_lag_smoothing_rad_s, "position unit/s", "the lag's tanh smoothing eps_f", ParameterCheck::kPositiveIfActive, true,
        detail::no_bounds, detail::half_start}}},
     kDiscoveredTerms + 9,
     [](const Effects& e) { return discovered_active(e) || discovered_memory_active(e); },
     detail::discovered_least_squares_start, detail::start_only_grid, nullptr, nullptr, 0.0,
     nullptr, {0.01, 0.005}, false, EffectKind::kNone, EffectKind::kNone, /*candidate=*/false},
}};

/// The table entry of `kind`.
inline const EffectSpec& effect_spec(EffectKind kind) noexcept {
  return kEffectCatalogue[static_cast<std::size_t>(kind)];
}

namespace detail {
constexpr std::array<EffectKind, kEffectKindCount> all_effect_kinds() {
  std::array<EffectKind, kEffectKindCount> out{};
  for (std::size_t k = 0; k < kEffectKindCount; ++k) out[k] = static_cast<EffectKind>(k);
  return out;
}
}  // namespace detail

/// Every kind, kNone first (table order).
inline constexpr std::array<EffectKind, kEffectKindCount> kAllEffectKinds = detail::all_effect_kinds();

/// The catalogue name: "none", "coulomb_friction", "offset_torque", "gravity", "cogging",
/// "time_delay", "saturation", "deadzone", "stribeck_friction", "asymmetric_friction",
/// "position_dependent_friction", "external_disturbance".
inline const char* effect_name(EffectKind kind) noexcept { return effect_spec(kind).name; }

/// The catalogue's names, comma-separated (for --help and messages); `with_none` adds "none".
inline std::string effect_names_text(bool with_none = false) {
  std::string known;
  for (const EffectSpec& s : kEffectCatalogue) {
    if (s.kind == EffectKind::kNone && !with_none) continue;
    known += std::string(known.empty() ? "" : ", ") + s.name;
  }
  return known;
}

/// The kind of a catalogue name; throws alphainv::Error naming the field `field` otherwise.
inline EffectKind effect_kind_from_name(std::string_view name, const std::string& field = "effect") {
  for (const EffectSpec& s : kEffectCatalogue) {
    if (name == s.name) return s.kind;
  }
  throw Error("unknown effect \"" + std::string(name) + "\"; expected one of " +
                  effect_names_text(true),
              {}, 0, field);
}

/// The parameters an effect of `kind` adds to the model (empty for kNone). Modelling choices
/// (e.g. the smoothing ε of the Coulomb term) are listed only with `with_modelling_choices`
/// (what a model file stores and a simulation needs).
inline std::vector<EffectParameter> effect_parameters(EffectKind kind,
                                                      bool with_modelling_choices = false) {
  std::vector<EffectParameter> out;
  for (const EffectParameter& p : effect_spec(kind)) {
    if (with_modelling_choices || !p.modelling_choice) out.push_back(p);
  }
  return out;
}

/// Whether `e` has the effect of `kind` switched on.
inline bool effect_active(const Effects& e, EffectKind kind) noexcept {
  return effect_spec(kind).active(e);
}

/// The kinds switched on in `e`, in catalogue order.
inline std::vector<EffectKind> active_effects(const Effects& e) {
  std::vector<EffectKind> out;
  for (const EffectSpec& s : kEffectCatalogue) {
    if (s.active(e)) out.push_back(s.kind);
  }
  return out;
}

/// The active effects with their parameters (modelling choices included), e.g.
/// "coulomb_friction (coulomb_v = 0.004, coulomb_smoothing_rad_s = 0.001)"; "none" when all are off.
inline std::string effects_text(const Effects& e) {
  std::string text;
  for (EffectKind kind : active_effects(e)) {
    std::string params;
    for (const EffectParameter& p : effect_spec(kind)) {
      if (detail::omitted_when_zero(kind, p) && e.*p.member == 0.0) continue;
      params += (params.empty() ? "" : ", ") + std::string(p.name) + " = " + detail::num(e.*p.member);
    }
    text += (text.empty() ? "" : "; ") + std::string(effect_name(kind)) + " (" + params + ")";
  }
  return text.empty() ? "none" : text;
}

/// Throws alphainv::Error naming the field (prefix + member, e.g. "effects.coulomb_v") when a value
/// is out of range.
inline void validate_effects(const Effects& e, const std::string& prefix = "effects.") {
  for (const EffectSpec& s : kEffectCatalogue) {
    for (const EffectParameter& p : s) {
      const std::string field = prefix + p.name;
      const double x = e.*p.member;
      switch (p.check) {
        case ParameterCheck::kFinite: detail::require_finite(field, x); break;
        case ParameterCheck::kNonNegative: detail::require_nonnegative(field, x); break;
        case ParameterCheck::kPositiveIfActive:
          if (s.active(e)) detail::require_positive(field, x);
          break;
        case ParameterCheck::kDelayRange:
          if (!std::isfinite(x) || x < 0.0 || x > Effects::kMaxDelayS) {
            detail::bad(field, "0 <= " + std::string(p.name) + " <= " + detail::num(Effects::kMaxDelayS) + " s", x);
          }
          break;
        case ParameterCheck::kPositiveOrInfinity:
          if (std::isnan(x) || !(x > 0.0)) detail::bad(field, "a limit > 0 (infinity: none)", x);
          break;
      }
    }
  }
}

/// Sets one effect from a command-line spec, the form `omni_fit fit --effect`, `omni_gen --effect`
/// and `omni_ctl --sim-effect` take: "NAME:PARAM=VALUE[,PARAM=VALUE]" (model.json's parameter
/// names, e.g. "coulomb_friction:coulomb_v=0.004"), or "NAME=VALUE" for the effect's first
/// parameter (e.g. "deadzone=0.01"). The effect's other parameters take their defaults; the values
/// are validated and must switch the effect on. Throws alphainv::Error naming `option` (default
/// "--effect SPEC").
inline void apply_effect_spec(const std::string& spec, Effects& effects, std::string option = {}) {
  if (option.empty()) option = "--effect " + spec;
  const std::size_t colon = spec.find(':');
  const std::size_t eq = spec.find('=');
  const bool short_form = colon == std::string::npos && eq != std::string::npos;
  if (colon == std::string::npos && !short_form) {
    throw Error("expected NAME:PARAM=VALUE[,PARAM=VALUE] or NAME=VALUE, e.g. "
                "coulomb_friction:coulomb_v=0.004",
                {}, 0, option);
  }
  const std::string name = spec.substr(0, short_form ? eq : colon);
  const EffectKind kind = effect_kind_from_name(name, option);
  const EffectSpec& es = effect_spec(kind);
  if (kind == EffectKind::kNone) throw Error("\"none\" is not an effect", {}, 0, option);
  std::string names;
  for (const EffectParameter& p : es) names += std::string(names.empty() ? "" : ", ") + p.name;
  Effects one;  // this effect's values on defaults: validate_effects can only object to them
  std::string items = short_form ? std::string(es.parameters[0].name) + spec.substr(eq)
                                 : spec.substr(colon + 1);
  std::size_t start = 0;
  bool any = false;
  while (start <= items.size()) {
    const std::size_t end = std::min(items.find(',', start), items.size());
    const std::string item = items.substr(start, end - start);
    const std::size_t item_eq = item.find('=');
    const std::string key = item.substr(0, item_eq);
    const EffectParameter* param = nullptr;
    for (const EffectParameter& p : es) {
      if (key == p.name) param = &p;
    }
    if (item_eq == std::string::npos || param == nullptr) {
      throw Error("expected PARAM=VALUE with PARAM one of " + names + ", found \"" + item + "\"",
                  {}, 0, option);
    }
    const std::string text = item.substr(item_eq + 1);
    char* rest = nullptr;
    const double x = std::strtod(text.c_str(), &rest);
    if (text.empty() || rest == nullptr || *rest != '\0') {
      throw Error("expected a number for " + key + ", found \"" + text + "\"", {}, 0, option);
    }
    one.*(param->member) = x;
    any = true;
    start = end + 1;
  }
  if (!any) throw Error("no parameter given", {}, 0, option);
  validate_effects(one, "--effect " + name + ":");
  if (!es.active(one)) {
    throw Error("these values leave " + std::string(es.name) + " off", {}, 0, option);
  }
  for (const EffectParameter& p : es) effects.*(p.member) = one.*(p.member);
}

/// The spec apply_effect_spec reads back to the effect of `kind` in `e` (its parameters, modelling
/// choices included, in the shortest form that reads back to the same double), e.g.
/// "offset_torque:offset_v=0.0264075".
inline std::string effect_spec_text(const Effects& e, EffectKind kind) {
  const EffectSpec& es = effect_spec(kind);
  std::string out = std::string(es.name) + ":";
  bool first = true;
  for (const EffectParameter& p : es) {
    char buf[40];
    const double x = e.*p.member;
    if (detail::omitted_when_zero(kind, p) && x == 0.0) continue;  // (reads back as 0)
    for (int digits = 6; digits <= 17; ++digits) {  // the shortest %g form that reads back
      std::snprintf(buf, sizeof buf, "%.*g", digits, x);
      if (std::strtod(buf, nullptr) == x) break;
    }
    out += std::string(first ? "" : ",") + p.name + "=" + buf;
    first = false;
  }
  return out;
}

}  // namespace alphainv
