#pragma once
/// \file torque_effects.hpp
/// The torque effects n(θ, θ̇) of effects.hpp prepared once for a loop that evaluates them every
/// tick (the 1 kHz compensator and the online model's prediction, device/): the same terms as
/// effect_torque() (one formula, detail::effect_torque_terms), with what effect_torque()
/// recomputes each call precomputed at configuration time:
///   - 1/ε of every tanh smoothing (θ̇·(1/ε) for θ̇/ε) and 1/v_s of the Stribeck velocity,
///   - 2π/p of the cogging (θ·(2π/p) for 2π·θ/p),
///   - which terms are on, the discovered term's included (its 17 coefficients are not tested
///     again: the tick skips the library when it is off),
/// and tanh and sin by detail::fast_tanh and fast_sin (fast_math.hpp: inline, within 3 and 2 ulp
/// of std::tanh and std::sin). A product by the reciprocal differs from the quotient by at most an
/// ulp or so of the argument, so torque() equals effect_torque() to rounding, not bit for bit.

#include "alphainv/model/detail/fast_math.hpp"
#include "alphainv/model/effects.hpp"

namespace alphainv {

/// An Effects' torque terms with their constants precomputed (file comment). Built once, outside
/// the tick (not real-time: it copies the Effects); torque() is real-time safe.
class TorqueEffects {
 public:
  /// No effect: torque() is 0.
  TorqueEffects() noexcept : TorqueEffects(Effects{}) {}
  /// The torque effects of `effects` (validated by the caller: ε, p, v_s > 0 where on).
  explicit TorqueEffects(const Effects& effects) noexcept
      : effects_(effects), arguments_(effects) {}

  /// n(θ, θ̇) [command unit] at `theta` [position unit], `theta_dot` [position unit/s]: equal to
  /// effect_torque(effects(), θ, θ̇) to rounding. Real-time safe.
  double torque(double theta, double theta_dot) const noexcept {
    return detail::effect_torque_terms(effects_, arguments_, theta, theta_dot);
  }
  /// The same terms summed by `sum` (effects.hpp's detail::effect_torque_sum: sum.start(offset),
  /// then sum.add(term, addend) for each term on, in order). Real-time safe.
  template <class Sum>
  void sum_terms(double theta, double theta_dot, Sum& sum) const noexcept {
    detail::effect_torque_sum(effects_, arguments_, theta, theta_dot, sum);
  }
  /// The terms on, as a mask of detail::torque_term_bit() (the offset, which starts the sum, is
  /// not a term). Real-time safe.
  unsigned terms_on() const noexcept {
    using detail::TorqueTerm;
    using detail::torque_term_bit;
    const Arguments& a = arguments_;
    return (a.coulomb ? torque_term_bit(TorqueTerm::kCoulomb) : 0u) |
           (a.gravity ? torque_term_bit(TorqueTerm::kGravity) : 0u) |
           (a.cogging ? torque_term_bit(TorqueTerm::kCogging) : 0u) |
           (a.stribeck ? torque_term_bit(TorqueTerm::kStribeck) : 0u) |
           (a.asymmetric ? torque_term_bit(TorqueTerm::kAsymmetric) : 0u) |
           (a.position ? torque_term_bit(TorqueTerm::kPosition) : 0u) |
           (a.discovered ? torque_term_bit(TorqueTerm::kDiscovered) : 0u);
  }
  /// Whether any torque term is on (else torque() is 0 everywhere). Real-time safe.
  bool any() const noexcept { return arguments_.any; }
  /// Whether torque(θ, 0) = 0 for every θ by construction: each term on carries the factor
  /// tanh(θ̇/ε) (Coulomb, Stribeck, asymmetric, position-dependent friction; no offset, gravity,
  /// cogging or discovered term), so an evaluation at rest can be skipped. Real-time safe.
  bool zero_at_rest() const noexcept { return arguments_.zero_at_rest; }
  /// The effects it was built from.
  const Effects& effects() const noexcept { return effects_; }

 private:
  /// effect_torque_terms' arguments from the precomputed constants (file comment).
  struct Arguments {
    explicit Arguments(const Effects& e) noexcept
        : coulomb(e.coulomb_v > 0.0),
          gravity(e.gravity_v != 0.0),
          cogging(e.cogging_v != 0.0),
          stribeck(e.stribeck_coulomb_v > 0.0 || e.stribeck_breakaway_v > 0.0),
          asymmetric(e.asymmetric_coulomb_pos_v > 0.0 || e.asymmetric_coulomb_neg_v > 0.0 ||
                     e.asymmetric_viscous_diff_v_s != 0.0),
          position(e.position_coulomb_v != 0.0 || e.position_slope_v_per_rad != 0.0),
          discovered(discovered_active(e)),
          any(e.offset_v != 0.0 || coulomb || gravity || cogging || stribeck || asymmetric ||
              position || discovered),
          zero_at_rest(e.offset_v == 0.0 && !gravity && !cogging && !discovered),
          inv_coulomb_smoothing(1.0 / e.coulomb_smoothing_rad_s),
          cogging_wavenumber(detail::DividedArguments::kTwoPi / e.cogging_period_rad),
          inv_stribeck_velocity(1.0 / e.stribeck_velocity_rad_s),
          inv_stribeck_smoothing(1.0 / e.stribeck_smoothing_rad_s),
          inv_asymmetric_smoothing(1.0 / e.asymmetric_smoothing_rad_s),
          inv_position_smoothing(1.0 / e.position_smoothing_rad_s) {}
    bool coulomb_on() const noexcept { return coulomb; }
    bool gravity_on() const noexcept { return gravity; }
    bool cogging_on() const noexcept { return cogging; }
    bool stribeck_on() const noexcept { return stribeck; }
    bool asymmetric_on() const noexcept { return asymmetric; }
    bool position_on() const noexcept { return position; }
    bool discovered_on() const noexcept { return discovered; }
    double coulomb_x(double theta_dot) const noexcept { return theta_dot * inv_coulomb_smoothing; }
    double cogging_x(double theta) const noexcept { return theta * cogging_wavenumber; }
    double stribeck_w(double theta_dot) const noexcept { return theta_dot * inv_stribeck_velocity; }
    double stribeck_x(double theta_dot) const noexcept { return theta_dot * inv_stribeck_smoothing; }
    double asymmetric_x(double theta_dot) const noexcept {
      return theta_dot * inv_asymmetric_smoothing;
    }
    double position_x(double theta_dot) const noexcept { return theta_dot * inv_position_smoothing; }
    static double tanh(double x) noexcept { return detail::fast_tanh(x); }
    static double sin(double x) noexcept { return detail::fast_sin(x); }

    bool coulomb, gravity, cogging, stribeck, asymmetric, position, discovered;
    bool any;  ///< any term on, the offset included
    bool zero_at_rest;  ///< zero_at_rest()
    double inv_coulomb_smoothing;     ///< 1/ε [s/position unit]
    double cogging_wavenumber;        ///< 2π/p [rad/position unit]
    double inv_stribeck_velocity;     ///< 1/v_s [s/position unit]
    double inv_stribeck_smoothing;    ///< 1/ε [s/position unit]
    double inv_asymmetric_smoothing;  ///< 1/ε [s/position unit]
    double inv_position_smoothing;    ///< 1/ε [s/position unit]
  };

  Effects effects_;
  Arguments arguments_;
};

}  // namespace alphainv
