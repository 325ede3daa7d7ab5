#include "alphainv/diagnose/effect_refinement.hpp"

#include <nlopt.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "alphainv/identify/gravity_search.hpp"
#include "common/format.hpp"

namespace alphainv {

namespace {

/// Σ‖θ_sim − θ‖² of the α-model over the runs the fit simulated, and how many.
double alpha_sse(const DatasetFit& fit, std::size_t* runs) {
  double sse = 0.0;
  std::size_t n = 0;
  for (const RunValidation& v : fit.validation) {
    if (!v.simulated || !v.alpha.simulated || !std::isfinite(v.alpha.abs.rms)) continue;
    sse += v.alpha.abs.rms * v.alpha.abs.rms * static_cast<double>(v.alpha.abs.n);
    ++n;
  }
  if (runs != nullptr) *runs = n;
  return n > 0 ? sse : std::numeric_limits<double>::infinity();
}

struct Objective {
  const Dataset* dataset = nullptr;
  const std::vector<RunData>* data = nullptr;
  FitPipelineOptions options;
  std::vector<EffectParameter> params;
  std::vector<double> scale;  ///< the search runs on x = value / scale
  double best = std::numeric_limits<double>::infinity();
  Effects best_effects;
  DatasetFit best_fit;  ///< the fit at best_effects (kept, not fitted again)
  int evaluations = 0;

  Effects effects_at(const double* x) const {
    Effects e = options.effects;
    for (std::size_t j = 0; j < params.size(); ++j) e.*(params[j].member) = x[j] * scale[j];
    return e;
  }

  double operator()(const double* x) {
    ++evaluations;
    FitPipelineOptions o = options;
    o.effects = effects_at(x);
    try {
      validate_effects(o.effects);
    } catch (const std::exception&) {
      return 1e300;  // outside the effect's range
    }
    o.progress = nullptr;
    DatasetFit fit = fit_dataset(*dataset, *data, o);
    if (!fit.alpha.ok) return 1e300;
    const double sse = alpha_sse(fit, nullptr);
    if (!std::isfinite(sse)) return 1e300;
    if (sse < best) {
      best = sse;
      best_effects = o.effects;
      best_fit = std::move(fit);
    }
    return sse;
  }
};

double objective(unsigned n, const double* x, double* grad, void* data) {
  (void)n;
  (void)grad;
  return (*static_cast<Objective*>(data))(x);
}

}  // namespace

DatasetFit refine_effects(const Dataset& dataset, const std::vector<RunData>& data,
                          const FitPipelineOptions& options, EffectRefinement* out,
                          int max_evaluations) {
  EffectRefinement local;
  EffectRefinement& r = out != nullptr ? *out : local;
  r = EffectRefinement{};
  r.start = r.refined = options.effects;
  FitPipelineOptions o = options;
  o.run_validation = true;
  DatasetFit start_fit = fit_dataset(dataset, data, o);
  r.evaluations = 1;
  r.sse_start = r.sse_refined = alpha_sse(start_fit, &r.runs_scored);
  if (!start_fit.alpha.ok || !std::isfinite(r.sse_start)) {
    r.message = "no α-model was fitted and simulated: nothing to score the effects on";
    return start_fit;
  }
  // Gravity: its phase searched globally first (gravity_search.hpp), the local search below then
  // starts from the best (g, θ0) when that fits better than the values given.
  bool moved = false;
  if (options.effects.gravity_v != 0.0) {
    const auto t0 = std::chrono::steady_clock::now();
    const TimeDomainGravityCost cost(dataset, data, options.effects, start_fit.simulation);
    std::vector<GravityPoint> starts{{options.effects.gravity_v, options.effects.gravity_theta0_rad, 0.0}};
    GravityPoint ee;
    if (cost.equation_error_start(ee)) starts.push_back(ee);
    GravitySearchOptions go;
    go.amplitudes = gravity_grid_amplitudes(cost.v_max());
    go.threads = options.threads;
    const GravitySearchResult gs = search_gravity(cost, go, starts);
    r.gravity_search = gs.ok ? common::format("gravity searched over θ0 ∈ (−π, π] and g (%zu grid "
                                              "points and starts, %d evaluations of the "
                                              "equation-error linear model, %.1f s): g = %.4g, "
                                              "θ0 = %.3f rad",
                                              gs.grid.size(), gs.evaluations,
                                              std::chrono::duration<double>(
                                                  std::chrono::steady_clock::now() - t0).count(),
                                              gs.best.g, gs.best.theta0)
                             : "gravity search failed: " + gs.message;
    const GravityPoint given = normal_gravity(options.effects.gravity_v,
                                              options.effects.gravity_theta0_rad);
    if (gs.ok && (std::abs(gs.best.g - given.g) > 1e-6 * given.g ||
                  std::abs(std::remainder(gs.best.theta0 - given.theta0, 6.283185307179586)) > 1e-6)) {
      FitPipelineOptions og = o;
      og.effects.gravity_v = gs.best.g;
      og.effects.gravity_theta0_rad = gs.best.theta0;
      DatasetFit searched = fit_dataset(dataset, data, og);
      ++r.evaluations;
      std::size_t runs = 0;
      const double sse = alpha_sse(searched, &runs);
      if (searched.alpha.ok && sse < r.sse_start) {
        o.effects = og.effects;
        start_fit = std::move(searched);
        r.sse_refined = sse;
        r.runs_scored = runs;
        moved = true;
        r.gravity_search += common::format(", whole fit Σ‖θ_sim − θ‖² %.4g (the values given: %.4g)",
                                           sse, r.sse_start);
      } else {
        r.gravity_search += ", not better than the values given in the whole fit";
      }
    }
  }
  Objective obj;
  obj.dataset = &dataset;
  obj.data = &data;
  obj.options = o;
  std::vector<double> x, step;
  for (EffectKind kind : active_effects(o.effects)) {
    for (const EffectParameter& p : effect_parameters(kind)) {
      const double v = o.effects.*(p.member);
      obj.params.push_back(p);
      // Searched relative to the start (x = 1), first steps of 20 %; a zero start (a phase)
      // is searched in its own unit with a step of 0.3.
      const double sc = std::abs(v) > 0.0 ? std::abs(v) : 1.0;
      obj.scale.push_back(sc);
      x.push_back(v / sc);
      step.push_back(std::abs(v) > 0.0 ? 0.2 : 0.3);
      r.parameters.push_back(p.name);
    }
  }
  if (obj.params.empty()) {
    r.message = "no active effect to refine";
    return start_fit;
  }
  obj.best = r.sse_refined;  // the start's: the values given, or the gravity search's
  obj.best_effects = o.effects;
  nlopt_opt opt = nlopt_create(NLOPT_LN_NELDERMEAD, static_cast<unsigned>(x.size()));
  if (opt == nullptr) {
    r.message = "NLopt could not create the optimiser";
    return start_fit;
  }
  nlopt_set_initial_step(opt, step.data());
  nlopt_set_min_objective(opt, objective, &obj);
  nlopt_set_xtol_rel(opt, 1e-3);
  nlopt_set_ftol_rel(opt, 1e-6);
  nlopt_set_maxeval(opt, std::max(1, max_evaluations - 1));
  double f = 0.0;
  (void)nlopt_optimize(opt, x.data(), &f);  // the best point seen is kept in obj
  nlopt_destroy(opt);
  r.evaluations += obj.evaluations;
  r.ok = true;
  if (!(obj.best < r.sse_refined)) {
    if (!moved) {
      r.message = "the values given were already the best found";
      return start_fit;
    }
    r.refined = o.effects;  // the gravity search's start, not improved on locally
    return start_fit;
  }
  r.refined = obj.best_effects;
  r.sse_refined = alpha_sse(obj.best_fit, &r.runs_scored);
  return std::move(obj.best_fit);
}

}  // namespace alphainv
