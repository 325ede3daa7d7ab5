#pragma once
/// \file fit_pipeline.hpp
/// The paper's whole identification on a dataset (sections 2.2 to 2.3.5) and its validation by
/// simulation (section 2.4): local linear points per sine run, the global linear model per pose,
/// the inertia model across poses, the α-invariant model, and Table 8 / Table 11 style errors of the
/// linear and the α-model. Offline; never throws on what the data cannot support: it says so in
/// `notes` and leaves the affected parts empty (DatasetFit::usable(), `message`). Throws
/// alphainv::Error only for options out of range (FitPipelineOptions::validate()). The stages
/// one by one: fit_stages.hpp; report.md: fit_report.hpp.

#include <cstddef>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "alphainv/identify/alpha_fit.hpp"
#include "alphainv/model/controller.hpp"
#include "alphainv/data/dataset.hpp"
#include "alphainv/model/effects.hpp"
#include "alphainv/identify/local_linear.hpp"
#include "alphainv/identify/inertia_fit.hpp"
#include "alphainv/identify/metrics.hpp"
#include "alphainv/simulate/simulate.hpp"

namespace alphainv {

/// Settings of fit_dataset().
struct FitPipelineOptions {
  double settle_fraction = 0.5;   ///< sine runs: the first fraction of the run is transient
  std::size_t n_breakpoints = 4;  ///< N of the α-model
  unsigned threads = 0;           ///< validation simulations in parallel; 0: all cores
  bool run_validation = true;     ///< simulate every run with both models (section 2.4)
  /// Poses without sine runs get their linear model (and the dataset its α-model, when no sine run
  /// gave one) by time-domain output error (time_domain_fit.hpp) on their runs.
  bool time_domain = true;
  /// Progress of the stages ("local fits", "inertia fit", "alpha breakpoint search",
  /// "validation simulations"): items done of total. Calls never overlap (a mutex serialises
  /// them) but may come from a validation worker thread. Empty: no calls.
  std::function<void(std::string_view stage, std::size_t done, std::size_t total)> progress;
  /// Digital-loop correction of the local points (local_linear_point()): the controller tick T [s].
  /// NaN (default): T = 1/sample_rate_hz when the dataset gives a rate (a digital loop: the command
  /// of each row held until the next), else a continuous loop; 0: off, the paper's (19)-(20);
  /// > 0: this T.
  double loop_period_s = std::numeric_limits<double>::quiet_NaN();
  bool refine_breakpoints = true;  ///< AlphaFitOptions::refine (NLopt search off the grid)
  /// Re-identify the inertia model so that it is consistent with the α-model (see fit_dataset's
  /// notes); false: the paper's inertia model from the global linear fits alone.
  bool alpha_consistent_inertia = true;
  /// Known effects of the plant beyond the model (effects.hpp; e.g. from `omni_fit diagnose`),
  /// all off by default. When any is on, the local point of each sine run is read against the
  /// plant input through them (sine_point_with_effects(), effect_sine_point.hpp) instead of the
  /// command, over the same steady-state window, and every simulation (validation, time-domain
  /// fit) includes them. All off: the fit is the one without this option, bit for bit. Limit:
  /// the correction is a describing function of the effects' input; harmonics they put into the
  /// command also make the plant's α̂ swing within a period, which biases points on a steep
  /// stretch of C(α) (tests/test_parameter_recovery.cpp).
  Effects effects;
  /// Passes of remove_known_disturbance_response() (fit_stages.hpp), at most: the response of the
  /// first-pass model to a sine run's known disturbance (its `disturbance_v` column) simulated and
  /// taken out of the run, the sine stages refitted, until the points move < 0.1 %. It runs only
  /// when some sine run has a nonzero disturbance_v; 0: off (the points read θ against the plant
  /// input with d(t) in it, effect_sine_point.hpp, and nothing more).
  int disturbance_passes = 3;

  /// Throws alphainv::Error naming the first setting out of range ("FitPipelineOptions::…"):
  /// settle_fraction in [0, 1), n_breakpoints in [2, kMaxBreakpoints], loop_period_s NaN, 0 or a
  /// finite period > 0, disturbance_passes in [0, 100], and the effects (validate_effects()).
  /// fit_dataset() calls it.
  void validate() const;
};

/// One sine run's local identification.
struct SineRunPoint {
  std::size_t run = 0;           ///< index into dataset.runs
  std::size_t pose = 0;          ///< index into DatasetFit::poses
  LocalLinearPoint point;        ///< C_data, β_data, α_data; `physical`
  double gain = 0.0;             ///< measured A0/Ar
  double phase_deg = 0.0;        ///< measured phase of θ relative to r [deg]
};

/// How well one model (linear or α) reproduces a set of runs: Table 8 (fundamental magnitude and
/// phase, 90th percentile over a sweep) and Table 11 (|θ_sim − θ| of square/step runs, median and
/// 90th percentile). NaN where the runs of that kind are absent. The names are those of
/// `omni_fit fit --json`.
struct ModelErrors {
  double magnitude_p90 = std::numeric_limits<double>::quiet_NaN();        ///< [1]
  double phase_p90_deg = std::numeric_limits<double>::quiet_NaN();        ///< [deg]
  double step_median_abs_err = std::numeric_limits<double>::quiet_NaN(); ///< [position unit]
  double step_p90_abs_err = std::numeric_limits<double>::quiet_NaN();     ///< [position unit]
  /// Median over the runs of ‖θ_sim − θ‖/‖θ‖ (every simulated run, any kind) [1].
  double rel_position_error_median = std::numeric_limits<double>::quiet_NaN();
};

/// What remove_known_disturbance_response() (fit_stages.hpp) did: the known disturbance response
/// simulated and taken out of the sine runs before their points were refitted.
struct KnownDisturbanceCorrection {
  std::size_t runs_with_disturbance = 0;  ///< sine runs with a nonzero disturbance_v column
  std::size_t runs_corrected = 0;         ///< of those, the runs corrected (both simulations ran)
  int passes = 0;  ///< refits of the sine stages done (0: the stage did not run)
  /// Largest relative change of a physical point's C_data or β_data in the last pass [1]; NaN
  /// when no pass ran.
  double last_point_change = std::numeric_limits<double>::quiet_NaN();
  /// The pass whose model was kept (0: the first pass, uncorrected): the one whose simulation of
  /// the disturbed runs, with their columns, is closest to the measured θ.
  int chosen_pass = 0;
  /// RMS of θ_sim − θ over the disturbed runs [rad]: the first pass's model, the kept one's.
  double first_pass_rms_rad = std::numeric_limits<double>::quiet_NaN();
  double chosen_rms_rad = std::numeric_limits<double>::quiet_NaN();
};

/// One pose (set of runs with the same γ1, γ2).
struct PoseFit {
  std::optional<double> gamma1_deg, gamma2_deg;  ///< measured pose, if the runs give it
  std::vector<std::size_t> runs;                 ///< indices into dataset.runs
  GlobalLinearFit linear;                        ///< eq. (22) on `band_hz`
  double band_lo_hz = 0.0, band_hi_hz = 0.0;     ///< frequency band used for (22)
  double inertia = 1.0;                          ///< I from the inertia model, or 1 without one
  /// How `linear` was identified: "sine (22)" or "time domain (output error)"; empty: not at all.
  std::string linear_source;
  ModelErrors linear_errors, alpha_errors;        ///< validation over this pose's runs
};

/// How one model's simulation of one run compares with the measurement.
struct RunErrors {
  bool simulated = false;
  FundamentalError fundamental;          ///< sine runs, over the steady-state window
  AbsErrorStats abs;                     ///< |θ_sim − θ| over the whole run
  double rel_position_error = std::numeric_limits<double>::quiet_NaN();  ///< ‖θ_sim − θ‖/‖θ‖ [1]
};

/// Validation of one run.
struct RunValidation {
  std::size_t run = 0;
  bool simulated = false;  ///< the linear simulation ran (the α one too when the α-model exists)
  std::string message;
  RunErrors linear, alpha;
};

/// Everything fit_dataset() finds. Like the other results of identify: usable(), `message`, a
/// one-line brief_report() and a full_report().
struct DatasetFit {
  std::vector<SineRunPoint> sine_points;
  std::vector<PoseFit> poses;
  bool has_inertia_model = false;
  InertiaFitSummary inertia;   ///< valid when has_inertia_model
  double kp = 0.0;             ///< the P gain used to turn β into β̃ (runs must agree)
  double loop_period_s = 0.0;  ///< T the digital-loop correction used [s]; 0: continuous (19)-(20)
  AlphaFitResult alpha;        ///< alpha.ok when the α-model was fitted
  /// How `alpha` was identified: "sine (2.3.5)" or "time domain (output error)".
  std::string alpha_source;
  /// The simulation the validation (and a time-domain fit) used: the continuous law (43), or the
  /// digital loop at the dataset's sample period (loop_period_s > 0).
  SimulationOptions simulation;
  /// The known effects the fit assumed (FitPipelineOptions::effects); model_for_pose() carries
  /// them into the simulations.
  Effects effects;
  /// The known disturbance response taken out of the sine points (stage 6a, fit_stages.hpp).
  KnownDisturbanceCorrection disturbance_correction;
  std::vector<RunValidation> validation;
  std::vector<std::string> notes;  ///< what could not be done, and why; choices made
  ModelErrors linear_errors, alpha_errors;  ///< medians over poses of the per-pose figures
  /// What was identified, or that nothing could be (the notes say why); set last by
  /// fit_dataset() (describe_fit(), fit_stages.hpp).
  std::string message;

  /// The model at a run's pose, for simulation (linear and α parts, and `effects`).
  JointModelAtPose model_for_pose(std::size_t pose) const;
  /// True when a model was identified: a linear model at some pose, or the α-model.
  bool usable() const;
  /// One line: usable or not, runs, poses, what was identified, the step errors of both models.
  std::string brief_report() const;
  /// Several lines: brief_report(), `message`, each stage's outcome (local points, linear models,
  /// the inertia model's brief report, the α-model, the validation figures), then the notes.
  std::string full_report() const;
};

/// Runs the identification and validation on `dataset` with its run data (`data[i]` of
/// `dataset.runs[i]`).
DatasetFit fit_dataset(const Dataset& dataset, const std::vector<RunData>& data,
                       const FitPipelineOptions& options = {});

}  // namespace alphainv
