#pragma once
/// \file fit_stages.hpp
/// The stages of fit_dataset() (fit_pipeline.hpp), one per section of the paper, in the order
/// fit_dataset() runs them:
///   1. group_runs_by_pose()         the poses: runs with the same measured (γ1, γ2)
///   2. fit_local_linear_points()    a local point (14)-(20), (36) per sine run (section 2.2.4)
///   3. fit_global_linear_models()   the global linear model (22) per pose (section 2.2.5)
///   4. fit_inertia_across_poses()   the inertia model (6), (27)-(29) (section 2.2.6)
///   5. fit_alpha_invariant_model()  the α-invariant model (38)-(42) (section 2.3.5)
///   6. choose_model_simulation()    how the models are simulated: (43) or the digital loop
///  6a. remove_known_disturbance_response()  the sine runs' known disturbance response taken out,
///                                  stages 1-6 again on the corrected runs (only with pulses)
///   7. fit_time_domain_poses()      output error for poses without sine runs (time_domain_fit.hpp)
///   8. simulate_validation_runs()   every run simulated with both models (section 2.4)
///   9. summarise_validation()       Table 8 and Table 11 figures from those simulations
///  10. describe_fit()               DatasetFit::message: what was identified
/// Each stage reads what the stages before it left in `fit` and adds its own part and its notes;
/// run in this order on the same options they give fit_dataset()'s result bit for bit. They are
/// API so that one section can be run, tested or replaced alone (e.g. section 2.2 without an
/// α-model, or the α stage again with other options on the same points).
///
/// Offline (allocates; stage 8 runs threads): none is real-time safe. None throws on what the
/// data cannot support: it says so in `fit.notes` and leaves its part empty.

#include <cstddef>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/identify/fit_pipeline.hpp"
#include "alphainv/identify/local_linear.hpp"

namespace alphainv {

/// Stage 1. Groups the runs by their measured pose (γ1, γ2), rounded to 0.01°, in the order the
/// poses first appear; runs without both angles form one pose without angles. Appends to
/// `fit.poses` (angles and run indices only).
void group_runs_by_pose(const Dataset& dataset, DatasetFit& fit);

/// Index into `fit.poses` of every run (stage 1's grouping), `n_runs` entries.
std::vector<std::size_t> pose_of_runs(const DatasetFit& fit, std::size_t n_runs);

/// `fit.sine_points`' local points by pose: entry p holds pose p's points in run order.
std::vector<std::vector<LocalLinearPoint>> points_by_pose(const DatasetFit& fit);

/// Stage 2, eqs. (14)-(20) and (36). Sets `fit.loop_period_s` (the digital-loop correction:
/// options.loop_period_s, or 1/sample_rate_hz when NaN) and `fit.effects` (options.effects), then
/// for every sine run with freq_hz under a pure P law (kp > 0, ki = kd = 0): the sine fits (15) of
/// r and θ over the steady-state window (options.settle_fraction), θ in the frame of r (14), and
/// the local point C_data, β_data, α_data (local_linear_point(), or sine_point_with_effects() when
/// known effects are on). `fit.kp` is the first such run's kp. Appends to `fit.sine_points` and
/// notes what was skipped and why. Needs stage 1.
void fit_local_linear_points(const Dataset& dataset, const std::vector<RunData>& data,
                             const FitPipelineOptions& options, DatasetFit& fit);

/// Stage 3, eq. (22): per pose with local points, the global linear fit (global_linear_fit()) on
/// the band [f_res/1.3, 1.3 f_res] around the frequency f_res of largest measured gain (the
/// paper's 3-4.5 Hz around 3.4 Hz), on every physical point when fewer than two fall in it. Sets
/// each PoseFit's `linear`, `band_lo_hz`, `band_hi_hz` and `linear_source` ("sine (22)"); a fit
/// with C_linear or β_linear ≤ 0 is not valid. Needs stage 2.
void fit_global_linear_models(DatasetFit& fit);

/// Stage 4, eqs. (6), (27)-(29): the inertia model fitted (fit_inertia_model()) to the global
/// linear models of the poses with angles, when there are 6 or more; sets `fit.inertia`,
/// `fit.has_inertia_model` (the fit converged) and every pose's `inertia` (I from the model, or 1
/// without one). Needs stage 3.
void fit_inertia_across_poses(const FitPipelineOptions& options, DatasetFit& fit);

/// Stage 5, eqs. (38)-(42): the α-invariant model fitted (fit_alpha_model(), N =
/// options.n_breakpoints) to every pose's local points at the pose's inertia; with an inertia model
/// and options.alpha_consistent_inertia, the inertia model is then re-identified consistently
/// with the α-model (eq. (42) makes β̃ = 1/(β̃_n1(α)·I), so β̃_linear = 1/I holds at one α only).
/// Sets `fit.alpha` and `fit.alpha_source` ("sine (2.3.5)") and notes what the data pin down.
/// Needs stage 4.
void fit_alpha_invariant_model(const FitPipelineOptions& options, DatasetFit& fit);

/// Stage 6: how the models are simulated (validation, time-domain fit). With a digital loop
/// (fit.loop_period_s > 0) and every run sampled uniformly at that period: the loop itself, the
/// command held over each tick (`fit.simulation.loop_period_s`); otherwise the continuous law
/// (43), with RK4 steps as long as the median sample interval (≥ 1 ms) when the time-domain fit
/// must do without sine runs. Needs stage 2.
void choose_model_simulation(const std::vector<RunData>& data, const FitPipelineOptions& options,
                             DatasetFit& fit);

/// Stage 6a: the response to a known disturbance taken out of the sine points. A sine run with a
/// nonzero `disturbance_v` column d(t) holds, besides its sine response, the loop's response to
/// d; the points of stage 2 read θ against the plant input with d in it (effect_sine_point.hpp),
/// but a pulse transient inside the steady-state window leaks into the windowed sine fits (15)
/// (seed 7, pose 2, ±0.1 V pulses: C_data off by up to 23 % against the same runs without pulses).
/// So, per pass: every such run simulated (simulate_recorded_run(), fit.simulation) with the model
/// of its pose (DatasetFit::model_for_pose(): the α-model when there is one), once with and once
/// without its disturbance_v column; the difference (θ and v) subtracted from the measured run,
/// the column dropped; stages 1-6 run again on the corrected runs. Repeated until no physical
/// point's C_data or β_data moves by 0.1 % or more, or options.disturbance_passes passes; each
/// pass simulates with the previous pass's model, always on the measured runs. Of the first pass
/// and the refits, the one whose models simulate the measured disturbed runs (columns in) closest
/// to θ (RMS) is kept: the α-model's breakpoint search can make the refits cycle instead of
/// settle. Replaces what stages 1-6 left in `fit` by the kept pass's result (the runs stages 7-9
/// take stay the measured ones, with their columns) and sets `fit.disturbance_correction` and a
/// note. Does nothing when no sine run has a nonzero disturbance; only counts them (and notes it)
/// when options.disturbance_passes is 0 or stage 5 left no model. Needs stages 1-6; run before
/// stage 7.
void remove_known_disturbance_response(const Dataset& dataset, const std::vector<RunData>& data,
                                       const FitPipelineOptions& options, DatasetFit& fit);

/// Stages 1-6 in order on `data` (what stage 6a refits on the corrected runs), as fit_dataset()
/// runs them.
DatasetFit fit_sine_stages(const Dataset& dataset, const std::vector<RunData>& data,
                           const FitPipelineOptions& options);

/// Stage 7 (time_domain_fit.hpp): the linear model of every pose that has none yet (no sine runs,
/// and no inertia model to predict it) by output error on the pose's runs under their own
/// controllers, and the α-model of a single-pose dataset when stage 5 gave none, with the runs'
/// known inputs (disturbance_v, torque_enable: plant_input.hpp). Runs with no kp > 0 are left out.
/// Needs stages 1-6.
void fit_time_domain_poses(const Dataset& dataset, const std::vector<RunData>& data,
                           const FitPipelineOptions& options, DatasetFit& fit);

/// Stage 8, section 2.4: every run simulated under its own controller from its measured initial
/// state, with the linear model and (when there is one) the α-model of its pose
/// (DatasetFit::model_for_pose()), in options.threads threads. Fills `fit.validation` (one entry
/// per run: fundamental errors of sine runs, |θ_sim − θ| statistics, ‖θ_sim − θ‖/‖θ‖). Needs
/// stages 1-7.
void simulate_validation_runs(const Dataset& dataset, const std::vector<RunData>& data,
                              const FitPipelineOptions& options, DatasetFit& fit);

/// Stage 9: per pose, Table 8 (90th percentile over the pose's sweep of the fundamental's
/// magnitude and phase errors) and Table 11 (median and 90th percentile of |θ_sim − θ| of square
/// and step runs, medians over the pose's runs); the medians of these over the poses, and the
/// median relative position error over all simulated runs. Sets the ModelErrors of every pose and
/// of `fit`, and notes when the models clearly miss an effect. Needs stage 8.
void summarise_validation(const Dataset& dataset, DatasetFit& fit);

/// Stage 10: `fit.message`, one line on what was identified (the poses with a linear model and
/// how, the inertia model, the α-model and how), or that nothing could be.
void describe_fit(DatasetFit& fit);

}  // namespace alphainv
