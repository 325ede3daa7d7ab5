#pragma once
/// \file effect_refinement.hpp
/// The parameters of known effects (effects.hpp) refined on the whole dataset: each evaluation is
/// a whole identification fit_dataset() with the effects in the plant input of the local points
/// (effect_sine_point.hpp) and in the validation simulations, scored by the α-model's squared
/// position error Σ‖θ_sim − θ‖² over every run it simulates under its own controller. Used after
/// `omni_fit diagnose` has named an effect on a few runs, to settle its size on all of them
/// (the α-model's C(α) depends on it: Coulomb friction's describing function is damping).
/// Offline (allocates, minutes at most).

#include <string>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/model/effects.hpp"
#include "alphainv/identify/fit_pipeline.hpp"

namespace alphainv {

/// What refine_effects() did.
struct EffectRefinement {
  bool ok = false;
  std::string message;
  Effects start;     ///< the effects given (options.effects)
  Effects refined;   ///< the effects of the returned fit
  double sse_start = 0.0;  ///< Σ‖θ_sim − θ‖² of the α-model with `start` [position unit²]
  double sse_refined = 0.0;  ///< the same with `refined`
  std::size_t runs_scored = 0;  ///< runs in the sums
  int evaluations = 0;          ///< fit_dataset() calls
  std::vector<std::string> parameters;  ///< the parameters refined ("coulomb_v", …)
  /// With gravity among the effects: what its global search (gravity_search.hpp) found, one
  /// line; empty otherwise.
  std::string gravity_search;
};

/// Refines every fitted parameter (effect_parameters()) of the effects active in
/// options.effects, from their values there, by bounded Nelder-Mead (NLopt) on the score of the
/// file comment. Gravity's (g, θ0) is first searched globally (search_gravity() with the
/// TimeDomainGravityCost, a grid over θ0 ∈ (−π, π] and g from the data's command range, plus the
/// values given and an equation-error start); the local search starts from its best when a whole
/// fit there scores better than the values given (at most max_evaluations fits); the returned fit is the one at the best values
/// (options.run_validation is forced on). With no active effect, or no α-model, it returns the
/// plain fit and `out->ok` false with the reason.
DatasetFit refine_effects(const Dataset& dataset, const std::vector<RunData>& data,
                          const FitPipelineOptions& options, EffectRefinement* out = nullptr,
                          int max_evaluations = 40);

}  // namespace alphainv
