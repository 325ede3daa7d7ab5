#pragma once
/// \file separability.hpp
/// Which candidate effects the data cannot tell from the named ones: a candidate's torque, at its
/// fitted parameters, that lies within the span of the named effects' parameter sensitivities
/// over the states the fit runs visit can be taken up by refitting the named effects, so "named"
/// and "named + candidate" fit these data alike. Over a stroke of ±0.07 rad gravity's
/// −g·sin(θ + θ0) has the sensitivity −g·cos(θ + θ0) to θ0, a constant to 1 part in 10⁴: a
/// constant offset torque is not separable from gravity's θ0 there, whichever was named; a
/// wider stroke would separate them (its curvature g·sin(θ0)·θ²/2 grows with θ²).
/// Only effects of the state (EffectRole::kTorque) are checked: a command-path effect (delay,
/// saturation, deadzone) has no torque of θ and θ̇. The α-model's coefficient factors are not
/// among the columns (a viscous-like torque they absorb is not said here). Offline.

#include <limits>
#include <string>
#include <vector>

#include "alphainv/model/effects.hpp"

namespace alphainv {

/// The share of a candidate's torque (uncentred R²) the named effects' sensitivities span, above
/// which it is said to be not separable from them.
inline constexpr double kNotSeparableShare = 0.999;

/// One candidate the data cannot tell from the named effects.
struct NotSeparable {
  EffectKind effect = EffectKind::kNone;  ///< the candidate, not named
  std::vector<EffectKind> from;           ///< the named effects whose sensitivities span its torque
  /// Share of its torque's energy over the samples that they span (uncentred R², ≤ 1).
  double share = std::numeric_limits<double>::quiet_NaN();
  std::string message;  ///< in words, for the report
};

/// Uncentred R² of the least-squares fit of y by the columns xs (1 − |y − X·b|²/|y|²); NaN when y
/// is zero or there are no columns or samples.
double spanned_share(const std::vector<double>& y, const std::vector<std::vector<double>>& xs);

/// The candidates (kind and its fitted effects, e.g. a round's CandidateScore::effects) whose own
/// torque over the states (θ, θ̇) is spanned to at least `share` by the sensitivities ∂n/∂p of the
/// named effects' fitted parameters at `model` (central differences). A candidate fitted to no
/// torque (its level taken up by the named effects) is checked in its form at unit magnitude
/// (its first parameter 1, its shape as fitted). Candidates that are named or not torques of the
/// state are skipped, and so is one spanned by a named effect it is nested with alone
/// (EffectSpec::generalises, either way: an asymmetric friction fitted symmetric is the Coulomb
/// friction named, not a confusion with it). A generalisation spanned only by its nested named
/// effect and others together is said (an asymmetric friction Fc⁺ ≠ Fc⁻ is a Coulomb friction
/// plus a constant while moving, which gravity's θ0 takes up over a small stroke).
std::vector<NotSeparable> not_separable(const Effects& model, const std::vector<EffectKind>& named,
                                        const std::vector<std::pair<EffectKind, Effects>>& candidates,
                                        const std::vector<double>& theta, const std::vector<double>& theta_dot,
                                        double share = kNotSeparableShare);

}  // namespace alphainv
