#pragma once
/// \file discovered_term.hpp
/// A discovered term for what no named effect explains (issue #15, item 2): after the named
/// effects, the torque the model still leaves is regressed sparsely on a fixed library of
/// functions of θ and θ̇ (effects.hpp's kDiscoveredLibrary), refined by output error, read
/// against the named forms and kept when it cuts the error over all runs.
///
/// 1. Equation error. Along the fit runs the model's own equation (11),
///        θ̈ + C(α, I)·θ̇ = β̃(α, I)·(S(Z(v(t − τ))) + n(θ, θ̇) + d),
///    solved for the torque it leaves: n̂ = (θ̈ + C·θ̇)/β̃ − u, with θ̇, θ̈ from local quadratic fits
///    of the measured θ and u the plant input of the named effects (plant_input.hpp).
/// 2. Sparse regression (sequentially thresholded least squares, as SINDy does): the library's
///    columns scaled to unit RMS; for each threshold λ of a geometric path, least squares on the
///    active terms, terms with |ξ| < λ dropped, repeated until the support stops changing. Each
///    support of the path, and the supports of the named forms (Coulomb {σ}, offset {1},
///    Stribeck {σ, σ·exp(−(w/s)²)}, position-dependent friction {σ, σ·x}, a spring {x}), is
///    scored by K-fold cross-validation over the runs (whole runs held out; time blocks when there
///    are fewer than K runs). Parsimony, the one-standard-error rule: among the supports whose
///    cross-validated RMS is within one standard error (over the folds) of the best, the one with
///    fewest terms (then the lowest RMS). A named form thus wins when it explains as much with
///    fewer parameters. The empty support is a contender too: nothing is discovered then.
///    Beside the library, two columns are in every fit: C·θ̇/β̃ and u, what factors on C and β̃
///    change in n̂ (the output-error fit frees those factors too).
///    With a re-identification (DiscoveredBase::reidentify) the α-model is identified again with
///    the term in the plant input and the regression repeated on what that model leaves (twice).
///    Memory terms (digital loop only; effects.hpp DiscoveredMemory): the library with the two
///    columns tanh(f/ε_f) and z, computed along each run's samples in time order, is regressed
///    at each of a grid of scales (T_f 2-50 ms, δ 0.1-10 % of θ_r, ε_f σ's ε); the
///    scales whose chosen support has a memory term with the lowest cross-validated RMS are a
///    second contender, whatever the library's own choice scored (under θ̈'s noise in n̂ a
///    memory term and its memoryless neighbours score alike). Both contenders go through output
///    error (T_f, δ and ε_f refined there too, within a factor 3, 3 and 10), the better over
///    all runs wins.
/// 3. Output error (output_error.hpp): the chosen terms' coefficients refined together with the
///    model's coefficient factors (C_n, β̃ ends) on the fit runs, from the regression's values.
/// 4. Kept when the RMS of θ − θ_sim over all runs is at most (1 − significance/2) times the
///    model's without it (as a named effect's), or when what the verdict judges (verdict.hpp
///    structure_rms(): the sine runs without their part at the fundamental) is at most
///    (1 − significance) times and that RMS is not larger. Reported as an equation with coefficients and
///    standard errors (output error's, from (JᵀJ)⁻¹σ²; the regression's beside them), its reading
///    where a named form matches ("this is coulomb_friction Fc = 0.004"), and the gap it closes
///    (against the noise floor, verdict.hpp).
/// Offline; never throws on what the data cannot support: the result says.

#include <cstddef>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "alphainv/diagnose/diagnose.hpp"
#include "alphainv/diagnose/verdict.hpp"
#include "alphainv/model/effects.hpp"

namespace alphainv {

/// Settings of sparse_regression().
struct SparseRegressionOptions {
  std::size_t folds = 5;        ///< cross-validation folds (over runs)
  std::size_t thresholds = 40;  ///< thresholds λ of the path, geometric
  std::size_t max_terms = 6;    ///< supports with more terms are not scored
  int max_sweeps = 10;          ///< threshold-and-refit sweeps per λ
  /// The last this many columns are in every fit (nuisance terms, e.g. what a factor on the
  /// model's coefficients changes): not thresholded, not counted as terms, not in a support.
  std::size_t fixed_columns = 0;

  /// Throws alphainv::Error naming the field when folds < 2, thresholds < 2, max_terms < 1 or
  /// max_sweeps < 1.
  void validate() const;
};

/// One support scored by cross-validation.
struct ScoredSupport {
  std::vector<std::size_t> terms;  ///< column indices, increasing
  double cv_rms = std::numeric_limits<double>::infinity();  ///< RMS over all held-out samples
  double cv_rms_se = 0.0;       ///< standard error of the fold RMS values' mean
  std::string named_form;       ///< the named form it is (empty: from the threshold path)
};

/// What sparse_regression() found.
struct SparseRegressionResult {
  bool ok = false;       ///< usable: the columns and samples allowed a fit
  std::string message;   ///< why not usable
  /// Coefficients of the chosen support and the fixed columns on the unscaled columns (0
  /// elsewhere), fitted on all samples, and their standard errors from σ²(XᵀX)⁻¹ (NaN elsewhere).
  std::vector<double> coefficients, standard_errors;
  ScoredSupport chosen;                 ///< the support chosen (file comment, step 2)
  ScoredSupport best;                   ///< the lowest cross-validated RMS
  std::vector<ScoredSupport> supports;  ///< every support scored (the empty one first)
};

/// Sparse regression of y on `columns` (each of y's length) with cross-validation over `groups`
/// (one id per sample, e.g. the run) and the extra supports `named_forms` (column indices with a
/// name) scored beside the threshold path (file comment, step 2).
SparseRegressionResult sparse_regression(
    const std::vector<std::vector<double>>& columns, const std::vector<double>& y,
    const std::vector<std::size_t>& groups,
    const std::vector<std::pair<std::string, std::vector<std::size_t>>>& named_forms = {},
    const SparseRegressionOptions& options = {});

/// The named forms of the library (kDiscoveredLibrary indices), for sparse_regression().
std::vector<std::pair<std::string, std::vector<std::size_t>>> discovered_named_forms();

/// Whether a contender with a named torque of the state outside the friction family taken out
/// (discover_term(), step 5) takes that effect's place from the best contender so far: over all
/// runs its RMS at most the best's and the structure the verdict judges at most
/// (1 − significance) × the best's (the named form wins a tie; NaN: no).
bool taken_out_contender_wins(double open_rms, double open_structure, double best_rms,
                              double best_structure, double significance);

/// Whether the memory terms of the discovered term in `term` (c_f of the lagged friction, c_z of
/// the Dahl state; a friction's coefficient is negative) carry at least half the friction that
/// `named` has beyond `without` (that friction taken out), compared at θ̇ = ±`theta_dot_rms`
/// and θ = 0: a contender that takes a named friction's place must (discover_term(), step 4).
bool memory_carries_friction(const Effects& named, const Effects& without, const Effects& term,
                             double theta_dot_rms);

/// The reading of a discovered term `e` (its non-zero coefficients and scales): the named
/// effect it is, with its parameters, when a named form matches ("coulomb_friction: Fc = 0.004"),
/// else what its terms are like; "nothing" when it is off.
std::string discovered_reading(const Effects& e);

/// One term of the discovered equation.
struct DiscoveredTermEntry {
  /// into kDiscoveredLibrary, or kDiscoveredTerms (the lag's sign) and kDiscoveredTerms + 1 (the
  /// Dahl state z), the memory terms
  std::size_t index = 0;
  std::string name;       ///< its coefficient's model.json name, e.g. "discovered_sign_v"
  std::string formula;    ///< e.g. "sigma"
  double coefficient = 0.0;  ///< after output error [command unit]
  double standard_error = std::numeric_limits<double>::quiet_NaN();  ///< output error's
  double regression_coefficient = 0.0;  ///< the sparse regression's (equation error)
  double regression_standard_error = std::numeric_limits<double>::quiet_NaN();
};

/// Settings of discover_term().
struct DiscoveredTermOptions {
  SparseRegressionOptions regression;
  double significance = 0.10;  ///< kept when the RMS over all runs drops by significance/2
  unsigned threads = 0;        ///< simulations in parallel; 0: all cores
  SimulationOptions simulation;
  std::size_t max_residuals_per_run = 800;  ///< output-error residual samples per run
  /// Try the memory terms (effects.hpp DiscoveredMemory) over their grid of scales; only with
  /// the digital loop (simulation.loop_period_s > 0), which advances their state once per tick.
  bool memory = true;
  int max_iterations = 10;                  ///< output-error iterations

  /// Throws alphainv::Error naming the field ("regression.folds", "significance", …).
  void validate() const;
};

/// What discover_term() found. Like Ceres' Summary: usable or why not, then the term.
struct DiscoveredTermResult {
  bool ok = false;      ///< usable: the regression and the output-error fit ran
  std::string message;  ///< why not usable, or why nothing was kept
  /// The term cuts the RMS over all runs to at most (1 − significance/2) of before.
  bool kept = false;
  SparseRegressionResult regression;
  std::vector<DiscoveredTermEntry> terms;  ///< the chosen terms (empty: nothing discovered)
  /// The model's effects with the term (the term's scales ε, v_r, θ_c, θ_r from the data), its
  /// coefficient factors, and the α-model it was fitted with (as the base's).
  Effects effects;
  ModelScales scales;
  std::optional<AlphaModel> alpha;
  /// The term as fitted, kept or not (its coefficients and scales; `effects` holds it only when
  /// kept).
  Effects term_effects;
  std::string equation;  ///< discovered_equation()
  std::string reading;   ///< discovered_reading()
  /// RMS of θ − θ_sim over all runs [position unit] without and with the term.
  double error_before = std::numeric_limits<double>::quiet_NaN();
  double error_after = std::numeric_limits<double>::quiet_NaN();
  /// The memory terms' contender's RMS over all runs (NaN: none was a contender: no scale of
  /// the grid had a memory term in its chosen support, or not the digital loop).
  double memory_error_after = std::numeric_limits<double>::quiet_NaN();
  /// The named friction the term took the place of (Coulomb friction or a form that generalises
  /// it: its levels are 0 in `effects`, diagnose() drops its name), or kNone. A friction with
  /// memory is first named by its nearest memoryless form; with each named friction taken out in
  /// turn, the memory terms are tried again (a contender of each form, the lagged sign and the
  /// Dahl state, with the α-model identified again with it), and such a contender wins when it cuts the best
  /// one's RMS over all runs by significance/2. So too a named torque of the state outside the
  /// friction family (cogging, gravity, an offset): taken out, the library's and the memory terms'
  /// regressions on what the model then leaves; such a contender wins when it does no worse over
  /// all runs and cuts the judged structure (structure_after) by significance (the named form wins
  /// a tie). took_in_tried: the named effect of the tried contender with the lowest RMS over all
  /// runs, took_in_error_after (kNone, NaN: none tried).
  EffectKind took_in = EffectKind::kNone;
  EffectKind took_in_tried = EffectKind::kNone;
  double took_in_error_after = std::numeric_limits<double>::quiet_NaN();
  /// … and that contender's judged structure over all runs (structure_after's measure; NaN: none).
  double took_in_structure_after = std::numeric_limits<double>::quiet_NaN();
  /// The noise floor given, and the part of the gap to it the term closes,
  /// (error_before − error_after)/(error_before − floor) (NaN without a floor below before).
  double noise_floor = std::numeric_limits<double>::quiet_NaN();
  double gap_closed = std::numeric_limits<double>::quiet_NaN();
  /// The same on what the verdict judges (verdict.hpp structure_rms(): the sine runs without
  /// their part at the fundamental, which the α-model represents): before, after, and the part of
  /// the gap to the floor closed. The whole RMS's floor is not the noise floor: on effect-free
  /// data the α-model alone leaves a whole RMS many times it (verdict.hpp).
  double structure_before = std::numeric_limits<double>::quiet_NaN();
  double structure_after = std::numeric_limits<double>::quiet_NaN();
  double structure_gap_closed = std::numeric_limits<double>::quiet_NaN();
  /// Set by diagnose(): with the term kept, the final verdict is "explained to the noise floor".
  bool carries_remainder = false;
  double seconds = 0.0;

  /// One line, e.g. "discovered (kept): n = -0.0041 sigma; closes 92 % of the gap; this is
  /// coulomb_friction: Fc = 0.0041".
  std::string brief_report() const;
  /// Several lines: the equation with each coefficient ± SE (output error and regression), the
  /// reading, the supports scored, the error before and after.
  std::string full_report() const;
};

/// What the verdict says of a kept term: "the discovered term carries the remainder: explained
/// to the noise floor", or "structure remains after the discovered term (it closes 64 % of the
/// gap to the noise floor)".
std::string discovered_verdict_text(const DiscoveredTermResult& d);

/// The model a discovered term is added to.
struct DiscoveredBase {
  Effects effects;                  ///< the named effects so far
  ModelScales scales;               ///< their coefficient factors
  std::optional<AlphaModel> alpha;  ///< the α-model in use; nullopt: the runs' own
  /// The α-model identified again with effects `e` in the plant input (diagnose passes its
  /// re-identification from the sine runs' local points; nullopt: it failed). An α-model
  /// identified without the term has absorbed part of it (friction as damping): with this, the
  /// regression is repeated on the torque the re-identified model leaves (unit factors), twice,
  /// and the output-error fit starts there. Empty: the base's α-model throughout.
  std::function<std::optional<AlphaModel>(const Effects& e)> reidentify;
};

/// Discovers a term (file comment) for the model `base`: regression and output error on
/// `fit_runs` (e.g. diagnose's fit windows: the steady state, where n̂ is cleanest) and output
/// error on `output_error_runs` (diagnose's whole fit runs; empty: `fit_runs`), the error before
/// and after over `all_runs`. `noise_floor` [position unit] for gap_closed (NaN: none). Never
/// throws.
DiscoveredTermResult discover_term(const std::vector<DiagnoseRun>& fit_runs,
                                   const std::vector<DiagnoseRun>& all_runs,
                                   const DiscoveredBase& base,
                                   const DiscoveredTermOptions& options = {},
                                   double noise_floor = std::numeric_limits<double>::quiet_NaN(),
                                   const std::vector<DiagnoseRun>& output_error_runs = {});

}  // namespace alphainv
