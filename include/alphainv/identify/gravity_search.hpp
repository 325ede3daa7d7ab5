#pragma once
/// \file gravity_search.hpp
/// A global search of the gravity term n = −g·sin(θ + θ0) (effects.hpp): the output-error cost of
/// (g, θ0) has a minimum per turn of θ0 and valleys that curve (a spring and an offset trade
/// against each other over a small range of θ), so a local search from θ0 = 0 ends wherever the
/// start sits (issue #15: at θ0 ≈ 1 rad, worse than no gravity, on a servo pendulum with θ0 ≈ 0).
/// Here: a grid over θ0 ∈ (−π, π] and g > 0 (the sign is in the phase: −g·sin(θ + θ0 + π) =
/// g·sin(θ + θ0)), plus any starts the caller knows (an equation-error regression), scored by the
/// caller's cost; then bounded Nelder-Mead (NLopt) from the best points. Used by
/// `omni_fit fit --refine-effects` (refine_effects(), with the time-domain score below) and by
/// `omni_fit diagnose`'s gravity candidate (its own simulation score). Offline; never throws.

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/model/effects.hpp"
#include "alphainv/simulate/simulate.hpp"

namespace alphainv {

/// One (g, θ0) and its cost.
struct GravityPoint {
  double g = 0.0;        ///< gravity_v [command unit], ≥ 0 after the search
  double theta0 = 0.0;   ///< gravity_theta0_rad, in (−π, π]
  double cost = 0.0;     ///< the caller's cost (+∞: the model failed)
};

/// Settings of search_gravity().
struct GravitySearchOptions {
  std::vector<double> amplitudes;  ///< the grid's g values (> 0) [command unit]; required
  std::size_t phases = 16;         ///< θ0 = −π + 2π·(k + 1)/phases, k = 0 … phases − 1
  std::size_t refine_from = 2;     ///< local searches from the best this many grid points
  int max_refine_evaluations = 40; ///< cost evaluations per local search
  unsigned threads = 1;            ///< grid points scored in parallel (the cost must allow it)
};

/// What search_gravity() found.
struct GravitySearchResult {
  bool ok = false;         ///< a finite cost was found
  std::string message;     ///< why not ok
  GravityPoint best;       ///< after the local refinement
  GravityPoint grid_best;  ///< the best grid point or start (before refinement)
  std::vector<GravityPoint> grid;  ///< every grid point and start, as scored
  int evaluations = 0;     ///< cost evaluations in all
};

/// The cost of gravity (g, θ0); must be callable from `threads` threads at once.
using GravityCost = std::function<double(double g, double theta0)>;

/// The grid (amplitudes × phases), the `starts` (scored too; g of either sign, θ0 any), then the
/// local refinements (file comment). The best point has g ≥ 0 and θ0 in (−π, π].
GravitySearchResult search_gravity(const GravityCost& cost, const GravitySearchOptions& options,
                                   const std::vector<GravityPoint>& starts = {});

/// (g, θ0) of `e` in the search's normal form: g ≥ 0, θ0 in (−π, π].
GravityPoint normal_gravity(double g, double theta0);

/// The time-domain cost of `omni_fit fit`'s gravity search: for a given (g, θ0), the linear model
/// θ̈ + C·θ̇ = β̃·u with u of plant_input.hpp (the other effects of `base` and gravity (g, θ0))
/// from an equation-error least squares over the runs (θ̇, θ̈ by local quadratic fits over ±10 ms;
/// closed form in C and β̃), then every run simulated with it under its own controller (the
/// run's known inputs applied) from its measured initial state: Σ‖θ − θ_sim‖² over the runs.
/// +∞ when the regression gives C ≤ 0 or β̃ ≤ 0 or a simulation fails. Thread-safe.
class TimeDomainGravityCost {
 public:
  /// `data[i]` is run `dataset.runs[i]` (kept by reference); runs without a controller or with
  /// fewer than 20 samples are left out.
  TimeDomainGravityCost(const Dataset& dataset, const std::vector<RunData>& data,
                        const Effects& base, const SimulationOptions& simulation);
  /// Σ‖θ − θ_sim‖² [position unit²] (file comment).
  double operator()(double g, double theta0) const;
  /// The equation-error start: u regressed with sin θ and cos θ as two more columns (C, β̃, and
  /// gravity in one linear least squares); ok false when the regression is singular.
  bool equation_error_start(GravityPoint& start) const;
  /// The runs scored.
  std::size_t runs() const noexcept { return runs_.size(); }
  /// The largest |v| over the runs [command unit] (the amplitudes' scale).
  double v_max() const noexcept { return v_max_; }

 private:
  struct Run {
    const RunData* data;
    Controller controller;
    std::vector<double> theta_dot, theta_ddot;
    std::vector<std::size_t> samples;  ///< the samples of the regression (interior, finite)
    /// The base's discovered memory terms along the record (discovered_memory_torque_along();
    /// empty without them): part of u that plant_input() has no state for.
    std::vector<double> memory_v;
    double memory_at(std::size_t k) const { return memory_v.empty() ? 0.0 : memory_v[k]; }
  };
  bool regress(double g, double theta0, double& c, double& beta_tilde) const;
  std::vector<Run> runs_;
  Effects base_;
  SimulationOptions simulation_;
  double v_max_ = 0.0;
};

/// The amplitudes of the grid for data whose commands reach `v_max`: v_max × {0.03, 0.07, 0.15,
/// 0.3, 0.6, 1.0} (gravity beyond the largest command could not be held).
std::vector<double> gravity_grid_amplitudes(double v_max);

}  // namespace alphainv
