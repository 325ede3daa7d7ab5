#pragma once
/// \file diagnose_stages.hpp
/// Internal (not API): the stages of diagnose() (diagnose.hpp's file comment), each a function,
/// so that each can be read and tested alone. One round runs
///
///   prepare_runs()  fit windows, data scales, the two time folds (once, before the rounds)
///   locate()        where the residual of a model concentrates (before the rounds and after)
///   start_round()   the round's error over all runs, torque residual and `none`'s α-model
///   search_candidate()   a candidate's starts (equation error or scan) and its search with the
///                        α-model re-identified at every trial (Reidentifier)
///   CandidateFitter::fit(), fit_searched()   the output-error fits (with the prune ratio)
///   cross_validate_lowest()   2-fold cross-validation of the two lowest training RMS
///   choose_winner()  the winner, parsimony (the simpler refitted at the winner's breakpoints)
///                    and the guards (a delay below one tick, beats `none` in both folds and at
///                    the winner's breakpoints)
///   settle_winner(), improves_all_runs()   the winner settled on the whole fit runs, then the
///                                          error over all runs
///
/// in that order (diagnose_round()). Not installed; tests/diagnose/test_diagnose_stages.cpp
/// includes it. The namespace is not alphainv::detail, whose helpers (detail::num of
/// field_checks.hpp) would hide this file's own.

#include <chrono>
#include <array>
#include <cstddef>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "alphainv/diagnose/diagnose.hpp"
#include "alphainv/identify/alpha_fit.hpp"
#include "alphainv/identify/local_linear.hpp"
#include "alphainv/model/effects.hpp"

namespace alphainv::diagnose_detail {

/// Scales of the data, for starts and bounds.
struct DataScales {
  double v_max = 1.0;          ///< largest |v| [command unit]
  double theta_dot_rms = 1.0;  ///< RMS of the measured θ̇ [position unit/s]
  double theta_min = 0.0, theta_max = 0.0;  ///< measured θ range [position unit]
  double kp = 1.0;  ///< the first run's proportional gain [command unit / position unit]

  /// What the effect table's search rules are sized by (EffectSpec).
  EffectScales effect() const { return {v_max, kp, theta_min, theta_max, theta_dot_rms}; }
};

/// One effect kind's parameters as an output-error parameter block: names, starts, bounds.
struct ParamBlock {
  EffectKind kind;
  std::vector<EffectParameter> params;
  std::vector<double> start, lower, upper;
};

/// The implied torque residual n̂ = (θ̈ + C·θ̇)/β̃ − u along each fit run (inverse dynamics with the
/// current model), with the measured θ, θ̇ at the same samples.
struct TorqueResidual {
  std::vector<double> n_hat, theta, theta_dot;
  std::vector<std::size_t> run;  ///< the run (index into the runs given) of each sample
  std::vector<double> t;         ///< its time [s] (a run's samples are in time order)
  /// C·θ̇/β̃ and u at the samples: n̂ changes by (g − 1)·C·θ̇/β̃ with a factor g on C, and by
  /// (1/f − 1)·(n̂ + u) ≈ (1/f − 1)·u with a factor f on β̃ (the discovered term's regression
  /// fits them beside its library, discovered_term.hpp).
  std::vector<double> damping_torque, plant_input;
};

/// `run` simulated with its model changed by diagnosed_model() (effects `e`, factors `scales`,
/// the α-model `alpha` or the run's own), from its measured start with its command history.
SimulationResult simulate_diagnosed_run(const DiagnoseRun& run, const Effects& e,
                                        const ModelScales& scales,
                                        const std::optional<AlphaModel>& alpha,
                                        const SimulationOptions& simulation);

/// The residuals θ − θ_sim of `sims` (one per run; empty for a failed run: left out) as the
/// verdict reads them.
std::vector<ResidualSeries> residual_series(const std::vector<DiagnoseRun>& runs,
                                            const std::vector<std::vector<double>>& sims);

/// Measured states (θ and θ̇ from a local quadratic fit over 10 ms) along the runs `which` of
/// `runs`, every k-th sample so that there are about `at_most`; non-finite ones left out.
struct MeasuredStates {
  std::vector<double> theta, theta_dot;
};
MeasuredStates measured_states(const std::vector<DiagnoseRun>& runs,
                               const std::vector<std::size_t>& which, std::size_t at_most);

/// The states separability.hpp judges over (about; a few k samples suffice for a share of 99.9 %).
inline constexpr std::size_t kSeparabilityStates = 20000;

/// n̂ along `fit_runs` of `runs` from the current model's simulations `sims` (one per run; a
/// failed one is skipped) with the effects `current` in the plant input; the first and last
/// 20 ms of each run are left out (one-sided derivative fits).
TorqueResidual torque_residual(const std::vector<DiagnoseRun>& runs,
                               const std::vector<std::size_t>& fit_runs,
                               const std::vector<SimulationResult>& sims, const Effects& current);

/// What prepare_runs() makes of the runs: the fit runs cut to their windows and the two folds,
/// as runs the simulations and fits take. Not copyable: `runs` points into `window_data` and
/// `half_data` (moving keeps the storage).
struct PreparedRuns {
  PreparedRuns() = default;
  PreparedRuns(const PreparedRuns&) = delete;
  PreparedRuns& operator=(const PreparedRuns&) = delete;
  PreparedRuns(PreparedRuns&&) = default;
  PreparedRuns& operator=(PreparedRuns&&) = default;

  /// The runs given, the fit runs cut to their last fit_window_s (started from the measured state
  /// there, with 0.3 s of command history), then the folds' halves appended.
  std::vector<DiagnoseRun> runs;
  std::vector<std::size_t> fit_runs;  ///< indices of the fit runs (into runs and the runs given)
  /// Indices into `runs` of the first (0) and second (1) half in time of every fit window.
  std::array<std::vector<std::size_t>, 2> folds;
  std::vector<std::size_t> all;  ///< 0 … (number of runs given) − 1
  DataScales scales;             ///< of the fit windows
  ModelScales unit_scales;       ///< factors 1, shaped like the first run's model
  bool can_cross_validate = false;  ///< both folds have runs

  std::vector<RunData> window_data;  ///< the fit windows (storage)
  std::vector<RunData> half_data;    ///< the folds' halves (storage)
};

/// Prepare: chooses the fit runs (at most options.max_fit_runs, spread over kinds and
/// frequencies), cuts them to their last options.fit_window_s, measures the data scales on them
/// and splits every window into two halves in time (the folds). `runs_in` must outlive the result.
PreparedRuns prepare_runs(const std::vector<DiagnoseRun>& runs_in, const DiagnoseOptions& options);

/// The model a round adds a candidate to.
struct RoundModel {
  Effects effects;                  ///< the effects so far
  ModelScales scales;               ///< the coefficient factors so far
  std::optional<AlphaModel> alpha;  ///< the re-identified α-model in use; nullopt: the runs' own
  std::vector<EffectKind> named;    ///< the active effects (refitted with every candidate)
};

/// Backward elimination after the rounds (named work): while two or more of `eligible` (effects
/// the rounds named, in model.named; a torque of time and the model given's effects are not
/// eligible) are in the model, the named effects are refitted with the coefficient factors and
/// cross-validated as they are and without each eligible one in turn; the one whose removal
/// costs least is dropped when the model with it does not beat the model without it by the
/// significance in both folds (beats(), the test that named it) and, the model without it
/// settled on the whole fit runs (settle_winner()), the model with it is not lower over all
/// runs by significance/2 (improves_all_runs()). `model` becomes the settled fit without it.
/// Returns the effects dropped, in order.
std::vector<DroppedEffect> drop_redundant_effects(const std::vector<DiagnoseRun>& runs_in,
                                                  const PreparedRuns& prepared, RoundModel& model,
                                                  const std::vector<EffectKind>& eligible,
                                                  const DiagnoseOptions& opt);

/// `e` without the effect `kind`: its parameters (modelling choices too) at their defaults.
Effects without_effect(const Effects& e, EffectKind kind);

/// The first round's model: the first run's effects (all runs share them), with the Coulomb
/// smoothing ε at kFrictionSmoothingShareOfRmsVelocity of the RMS velocity when no Coulomb
/// term is on; unit factors.
RoundModel initial_model(const std::vector<DiagnoseRun>& runs_in, const PreparedRuns& prepared);

/// A friction form's tanh smoothing ε (a modelling choice: EffectParameter::modelling_choice),
/// the member of `kind`'s; nullptr for the other effects.
double Effects::*friction_smoothing(EffectKind kind);

/// A friction form's fit is tried again with its ε times this (CandidateFitter::fit_joint()) …
inline constexpr double kSharperFrictionSmoothing = 0.1;
/// … and that one kept when its training RMS is at least this share lower.
inline constexpr double kSharperSmoothingGain = 0.02;
/// A candidate's second α-model (CandidateFitter::fit()'s `second_alpha`) is taken when its
/// training RMS is this share lower than with the first.
inline constexpr double kSecondAlphaGain = 0.02;
/// The start of a candidate's note when it was (CandidateScore::message).
inline constexpr const char* kSharperSmoothingNote = "friction smoothing ε taken ";

/// `base` with the friction smoothings ε of `chosen` (a candidate's effects, whose fit may have
/// taken them sharper).
Effects with_modelling_choices(Effects base, const Effects& chosen);

/// Locate: where the residual θ − θ_sim of `sims` (one per run; empty for a failed run)
/// concentrates, per run and over the state, and its words (ResidualLocation).
ResidualLocation locate(const std::vector<DiagnoseRun>& runs,
                        const std::vector<std::vector<double>>& sims);

/// Re-identification of the α-model with a candidate's effects in the plant input. The α-model is
/// identified from the sine runs' steady states (section 2.3.5), which absorb an unmodelled effect
/// (a spring shifts C and β̃ with ω, a delay adds phase, friction adds damping), breakpoints and
/// all: a candidate added to that model would have to undo the distortion through a few
/// coefficient factors, and misses. Here the local points are taken again with the plant input
/// through the candidate's effects (effect_sine_point.hpp) and the α-model is fitted again
/// (alpha_fit.hpp: breakpoints by the grid search, then the two-stage fit), with each pose's
/// inertia as the runs' models have it, so the result replaces their α-model. Usable when the
/// runs carry one α-model and sine runs under a P law at one kp. `runs` must outlive it.
class Reidentifier {
 public:
  /// `sample_period_s`: the controller tick of the digital-loop correction [s]; 0: continuous.
  /// `threads`: the sine runs' points computed side by side (0: all cores).
  Reidentifier(const std::vector<DiagnoseRun>& runs, double sample_period_s, unsigned threads = 1);

  bool usable() const { return usable_; }

  /// The α-model identified with effects `e` in the plant input; nullopt when it fails.
  std::optional<AlphaModel> fit(const Effects& e) const;

  /// The sine runs' local points with effects `e` in the plant input, by pose.
  std::vector<AlphaFitPose> points(const Effects& e) const;

  /// The α-model with effects `e` at the given breakpoints; nullopt when it fails.
  std::optional<AlphaModel> fit_at(const Effects& e, const std::vector<double>& breakpoints) const;

  /// The α-model with effects `e`: the grid winner (fit()), with `refined` also the winner refined
  /// off the grid (as fit_dataset() does), and the models at the next `runners_up` best
  /// breakpoint sets of the grid search.
  std::vector<AlphaModel> variants(const Effects& e, std::size_t runners_up, bool refined) const;

  /// The α-model with effects `e` linear in α across the widest gap of the sine points' α
  /// (diagnose.cpp across_the_gap()); nullopt without such a gap or when it fails.
  std::optional<AlphaModel> across_gap(const Effects& e) const;

 private:
  struct SineRun {
    const DiagnoseRun* run;
    IndexRange window;
    std::size_t pose;
    std::vector<double> theta_dot;  ///< sine_point_theta_dot() of the run (once, not per trial)
  };

  double sample_period_s_ = 0.0;
  unsigned threads_ = 1;
  AlphaFitOptions options_;
  std::vector<double> inertia_;
  std::vector<SineRun> sines_;
  bool usable_ = false;
};

/// What a round starts from (start_round()).
struct RoundStart {
  /// RMS of θ − θ_sim over all runs with the round's model [position unit]
  double error_before = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> run_error_before;  ///< error_before run by run (indexed as the runs)
  TorqueResidual torque_residual;  ///< along the fit runs, for the equation-error starts
  /// `none`'s α-model re-identified with the current effects (the best variant; nullopt without
  /// re-identification) and its RMS over the fit runs at unit factors (NaN without).
  std::optional<AlphaModel> none_alpha;
  double none_unit_rms = std::numeric_limits<double>::quiet_NaN();
  /// The round's model as it is (its α-model and coefficient factors): RMS over the fit runs
  /// [position unit] (search_in_model()'s reference).
  double model_fit_rms = std::numeric_limits<double>::quiet_NaN();
};

/// The round's error over all runs given (`runs_in`), the torque residual along the fit windows
/// and `none`'s α-model re-identified like the candidates' (so that a candidate does not win by
/// the re-identification alone).
RoundStart start_round(const std::vector<DiagnoseRun>& runs_in, const PreparedRuns& prepared,
                       const RoundModel& model, const Reidentifier& reid,
                       const DiagnoseOptions& options);

/// One candidate's starts and search (search_candidate()).
struct CandidateSearch {
  /// true: searched with the α-model re-identified, `effects` its best point, `alpha` the best
  /// variant there and `found_rms` its RMS over the fit runs at unit factors. false (`none`, no
  /// re-identification, or no trial simulated): `effects` holds the start for the output-error
  /// fit from `start_scales` with `alpha`.
  bool searched = false;
  Effects effects;
  ModelScales start_scales;
  std::optional<AlphaModel> alpha;
  double found_rms = std::numeric_limits<double>::quiet_NaN();  ///< [position unit]
  /// Searched: the α-model re-identified at `effects` with its breakpoints refined locally
  /// (Reidentifier::variants(…, refined)), when the refinement moved them; CandidateFitter::fit()
  /// tries it as the candidate's second α-model.
  std::optional<AlphaModel> refined_alpha;
};

/// Search: the new effect `kind`'s start (the effect table's equation-error start from the torque
/// residual, or without re-identification its first parameter scanned over the search grid),
/// then with re-identification a coarse scan of its main parameter on a grid scaled by the data
/// and Nelder-Mead from the best point (and the second best when nearly as good), every trial
/// with the α-model re-identified (Reidentifier); the breakpoint set of the best point that
/// predicts the fit runs best is kept (`none` gets the same choice in start_round()).
CandidateSearch search_candidate(EffectKind kind, const PreparedRuns& prepared,
                                 const RoundModel& model, const RoundStart& start,
                                 const Reidentifier& reid, const DiagnoseOptions& options);

/// The new effect `kind`'s start in the round's model as it is, as without re-identification:
/// the equation-error start, or its first parameter scanned over the search grid with the
/// model's α-model and coefficient factors (`*scanned_rms`, when given and scanned: the fit
/// runs' RMS at the value chosen). search_candidate() without re-identification starts there.
Effects start_in_model(EffectKind kind, const PreparedRuns& prepared, const RoundModel& model,
                       const RoundStart& start, const DiagnoseOptions& options, double* scanned_rms = nullptr);

/// The new effect `kind` in the round's model as it is: start_in_model() with the model's
/// α-model and coefficient factors, and `found_rms` its RMS over the fit runs there.
/// The second way in for a candidate whose search with the α-model re-identified did not reach
/// (1 − significance/2) of `none`'s best variant: in a round after the first the re-identified
/// α-model (unit factors) can be far from the model's own with its factors (gravity named, a
/// 4 ms delay: every search at 1.5–3× `none`'s RMS, the delay at the search's bound), while the
/// effect added to the model as it is cuts its error (the delay fitted so: 5.1 ms, 15 % below
/// `none` in the folds).
CandidateSearch search_in_model(EffectKind kind, const PreparedRuns& prepared, const RoundModel& model,
                                const RoundStart& start, const DiagnoseOptions& options);

/// A candidate fitted on all fit runs, waiting for cross_validate_lowest(): its parameter blocks
/// and fitted values (empty: nothing waits).
struct PendingCrossValidation {
  std::vector<ParamBlock> blocks;
  std::vector<double> values;
};

/// The output-error fits and cross-validation of one round's candidates: the round's model, data
/// and options (all referenced: they must outlive it).
class CandidateFitter {
 public:
  CandidateFitter(const std::vector<DiagnoseRun>& runs_in, const PreparedRuns& prepared,
                  const RoundModel& model, const DiagnoseOptions& options);

  /// The output-error parameter blocks of the effects already named and of a new `kind`
  /// (none: no new block), with starts from `e`.
  std::vector<ParamBlock> blocks_with(EffectKind kind, const Effects& e) const;
  /// … and of several new `kinds` (in order; empty: the named effects' blocks alone).
  std::vector<ParamBlock> blocks_with(const std::vector<EffectKind>& kinds, const Effects& e) const;

  /// Fit: the candidate `kind` (effects `e`, factors from `start_scales`, α-model `alpha`) fitted
  /// by output error on the fit windows together with the model's coefficient factors;
  /// `searched`: started from search_candidate() (fewer iterations, no extra starts);
  /// `other_starts`: further starts of the new effects' parameters (the factors as for `e`), the
  /// lowest training cost taken (a refinement: from its parent's fit and from equation error).
  /// Its score is
  /// then: its training RMS when it is hopeless (not below (1 − significance/2) × that of `none`,
  /// set_none_training_rms()) or cannot be cross-validated; the cross-validated RMS when `cv`;
  /// else its training RMS, and its blocks and values go to *later for cross_validate(). Its
  /// error_after is the RMS over all runs given.
  /// `second_alpha`: a second α-model (the breakpoints refined locally, CandidateSearch::
  /// refined_alpha): a single command-path candidate (an effect with extra starts: delay,
  /// saturation, deadzone), hopeless or not, is fitted again with it from the lowest of its
  /// screened starts, and that fit is taken when its training RMS is kSecondAlphaGain lower
  /// (the factors can make a breakpoint set that predicts the windows worse at unit factors the
  /// better one; the winner must still beat `none` refitted at its breakpoints, passes_guards()).
  CandidateScore fit(EffectKind kind, const Effects& e, const ModelScales& start_scales,
                     const std::optional<AlphaModel>& alpha, bool searched, bool cv,
                     PendingCrossValidation* later,
                     const std::vector<Effects>& other_starts = {},
                     const std::optional<AlphaModel>& second_alpha = std::nullopt) const;

  /// fit() of several new effects at once (the pair fallback): `kinds` all fitted with the
  /// named effects and the coefficient factors, from `e`; the score's `effect` is kinds[0]. With
  /// more than one kind there are no extra starts (`searched` as for fit()).
  CandidateScore fit_joint(const std::vector<EffectKind>& kinds, const Effects& e,
                           const ModelScales& start_scales, const std::optional<AlphaModel>& alpha,
                           bool searched, bool cv, PendingCrossValidation* later,
                           const std::vector<Effects>& other_starts = {},
                           const std::optional<AlphaModel>& second_alpha = std::nullopt) const;

  /// Cross-validate: `cand` (fitted on all fit runs: `values` of `blocks`) fitted on each fold
  /// from there and scored on the other; score is the RMS over both held-out folds.
  void cross_validate(CandidateScore& cand, const std::vector<ParamBlock>& blocks,
                      const std::vector<double>& values) const;

  /// A candidate not fitted further: its search result, scored by its search RMS `found_rms`.
  CandidateScore not_fitted(EffectKind kind, const Effects& e, const std::optional<AlphaModel>& a,
                            double found_rms, const std::string& why) const;

  /// `none`'s training RMS, which the other candidates' fits are held against (NaN: not yet).
  void set_none_training_rms(double rms) { none_training_rms_ = rms; }
  /// none's RMS over all runs: a candidate below (1 − significance) × it is not hopeless.
  void set_none_error_after(double rms) { none_error_after_ = rms; }

  const std::vector<DiagnoseRun>& runs_in() const { return runs_in_; }
  const PreparedRuns& prepared() const { return prepared_; }
  const RoundModel& model() const { return model_; }
  const DiagnoseOptions& options() const { return options_; }

 private:
  const std::vector<DiagnoseRun>& runs_in_;
  const PreparedRuns& prepared_;
  const RoundModel& model_;
  const DiagnoseOptions& options_;
  double none_training_rms_;
  double none_error_after_;
};

/// A searched candidate waiting for its output-error fit (fit_searched()).
struct DeferredFit {
  std::size_t index;  ///< in the round's candidates
  Effects effects;
  std::optional<AlphaModel> alpha;
  double found_rms;
  std::optional<AlphaModel> refined_alpha;  ///< CandidateSearch::refined_alpha
};

/// Fit of the searched candidates `deferred`: each is fitted by output error unless its search RMS
/// is more than kSearchPruneRatio (4) times the best one's (then not_fitted()): the factors
/// fitted with it narrow the differences, but not by that much (measured: 2.9× and 3.2× behind
/// after the search were still 1.3× and 1.4× behind after the fit; only candidates within 1.7×
/// overtook). Writes
/// candidates[d.index] and pending[d.index].
void fit_searched(const CandidateFitter& fitter, const std::vector<DeferredFit>& deferred,
                  std::vector<CandidateScore>& candidates,
                  std::vector<PendingCrossValidation>& pending);

/// Cross-validates the pending candidates with the two lowest training RMS (only they can be
/// named: the winner must beat `none` by a margin on data it was not fitted on).
void cross_validate_lowest(const CandidateFitter& fitter, std::vector<CandidateScore>& candidates,
                           const std::vector<PendingCrossValidation>& pending);

/// The named effect `kind` takes in an effect of `named` it generalises (EffectSpec::take_in):
/// that one's level moved into its parameters in `e`, that one's parameters zeroed (the same
/// torque). Returns that effect; nullopt when `kind` generalises none of `named` or has no form
/// for it.
std::optional<EffectKind> take_in_parent(EffectKind kind, Effects& e,
                                         const std::vector<EffectKind>& named);

/// A generalisation `kind` started where its parent ended: in `e`, `kind`'s levels (its parameters
/// but the shape ones, ParameterCheck::kPositiveIfActive, which keep their equation-error start)
/// set to 0, then the level `level_v` of `parent` taken in (EffectSpec::take_in). False, `e`
/// unchanged, when the form has no such start for `parent` (try_refinements(),
/// refine_pair_member()).
bool start_from_parent_level(EffectKind kind, EffectKind parent, double level_v, Effects& e);

/// `other` is a sibling form of `kind`: another generalisation of the same effect (Stribeck and
/// asymmetric friction, both of Coulomb friction). Their extra parts are of other variables (the
/// speed, the direction), so a joint may have both: a named sibling is a way in for `kind`, as
/// its named parent is (try_refinements()).
bool is_sibling_form(EffectKind kind, EffectKind other);

/// A generalisation's fit `c` has earned its extra parameters over `parent`, the effect it
/// generalises (try_refinements()): beats() with significance/2, or beats_twin() with it (not
/// worse in either fold, and below (1 − significance/2) × the parent's RMS over all runs).
bool earns_its_place(const CandidateScore& c, const CandidateScore& parent, double significance);

/// The position in `candidates` of the effect `kind` generalises (EffectSpec::generalises) that
/// was fitted and cross-validated, the lowest scored when several; candidates.size() when none.
std::size_t best_parent(EffectKind kind, const std::vector<CandidateScore>& candidates);

/// Refinements: each candidate at `refinements` (a generalisation, EffectSpec::refines) is
/// searched, fitted and cross-validated only when the effect it generalises was cross-validated
/// (among the two lowest training RMS); it stays a contender only when it earns its place over
/// that one (earns_its_place()); else it is marked not cross-validated.
/// With no such candidate, it is tried on top of the model when the effect it generalises or a
/// sibling form (is_sibling_form()) was named in an earlier round, and must then beat `none`.
void try_refinements(const CandidateFitter& fitter, const RoundStart& start,
                     const Reidentifier& reid, const std::vector<std::size_t>& refinements,
                     std::vector<CandidateScore>& candidates);

/// `c` is below (1 − significance) × `ref` in its score and in both folds.
bool beats(const CandidateScore& c, const CandidateScore& ref, double significance);
/// The winner against `none` refitted at its breakpoints (choose_winner()): beats(), or not
/// worse in both folds and the RMS over all runs below (1 − significance) × the twin's.
bool beats_twin(const CandidateScore& c, const CandidateScore& twin, double significance);

/// `c` is a time delay shorter than one controller tick of the digital loop (`simulation`): below
/// what the loop resolves, its sample-and-hold and the α filter's timing already differ from the
/// plant's by as much. Or at one tick: the fits' lower bound for a delay (make_problem()), where
/// a fit that wanted a shorter one stops.
bool delay_below_one_tick(const CandidateScore& c, const SimulationOptions& simulation);

/// Relative level below which a fitted amplitude (gravity, deadzone half-width, offset, Coulomb,
/// cogging) is taken as 0: 1e-3 of the largest |v| of the runs, below the noise floor of θ.
inline constexpr double kInactiveRelativeLevel = 1e-3;

/// The largest |v| over the runs of `prepared` [command unit].
double largest_abs_command_v(const PreparedRuns& prepared);

/// Why the fitted candidate `c` does not move the simulated θ on runs whose largest |v| is
/// `largest_abs_v` (it is `none` in disguise): a saturation level at or above largest_abs_v
/// ("never reached"), or a deadzone half-width, gravity, offset, Coulomb or cogging amplitude
/// below kInactiveRelativeLevel × largest_abs_v. Also a Stribeck friction fitted without its
/// breakaway hump (Fs <= Fc): not the form it names. Empty when it is active (and for `none`).
std::string inactive_reason(const CandidateScore& c, double largest_abs_v);

/// Sets `c` aside when inactive_reason() is non-empty: c.inactive = the reason, not
/// cross-validated, the reason in its message. Returns true when set aside.
bool set_aside_if_inactive(CandidateScore& c, double largest_abs_v);

/// What choose_winner() decided.
struct Choice {
  bool none_fitted = false;          ///< false: `none` could not be fitted (the round fails)
  std::optional<std::size_t> winner;  ///< index into the round's candidates (after parsimony)
  bool named = false;                 ///< the winner is an effect and passed the guards
};

/// Choose: inactive candidates set aside first (set_aside_if_inactive()); the cross-validated
/// candidate with the lowest score; among those within 5 % of it the
/// one with fewest parameters, a simpler one first refitted at the winner's breakpoints (it then
/// replaces its entry in rd.candidates). Named when it is not `none`, not a delay below one tick,
/// beats `none` in both folds and beats `none` refitted at its breakpoints
/// (rd.none_at_winner_breakpoints) and with the α-model linear across the gap of the sine
/// points' α (rd.none_across_gap).
Choice choose_winner(const CandidateFitter& fitter, const Reidentifier& reid, DiagnoseRound& rd);

/// The runner-up when the winner rd.candidates[first] (an effect) was not named: among the other
/// cross-validated, active effects the lowest score, named under the winner's guards (`none`
/// in both folds, `none` at its breakpoints, kept in rd.none_at_runner_up_breakpoints, and
/// across the α gap). No candidate when `first` is `none` (then none beat it).
Choice choose_runner_up(const CandidateFitter& fitter, const Reidentifier& reid, DiagnoseRound& rd,
                        std::size_t first);

/// Settle: the winner fitted again on the whole fit runs (from its window fit; the error over all
/// runs also counts the runs' starts). Returns `winner` improved when the RMS over all runs drops,
/// else `winner`. Only with options.fit_window_s > 0.
CandidateScore settle_winner(const CandidateFitter& fitter, const CandidateScore& winner);
/// … of a winner with several new effects `kinds` (a pair: its parameters all settled).
CandidateScore settle_winner(const CandidateFitter& fitter, const CandidateScore& winner,
                             const std::vector<EffectKind>& kinds);

/// The settled winner's RMS over all runs is at most (1 − significance/2) × the round's before.
bool improves_all_runs(const CandidateScore& settled, double error_before, double significance);
/// The same test on the two RMS values over all runs.
bool improves_all_runs(double error_after, double error_before, double significance);
/// The settled RMS over all runs `error_after` against the round's `error_before`: empty when it
/// is at most (1 − significance/2) × error_before (improves_all_runs()), else why not.
std::string not_below_before(double error_after, double error_before, double significance);
/// The lowest of the round's error before and the RMS over all runs of every `none` the round
/// refitted (`none` itself, at the winner's and the runner-up's breakpoints, across the α gap).
double none_reference_rms(const DiagnoseRound& rd);
/// A settled single winner's last test over all runs: not_below_before() the round's error
/// before, and not above none_reference_rms() (the cross-validated score already says the effect
/// is significant; over all runs it must not do worse than a `none` refit). Empty when it passes,
/// else why not. (A pair is held to not_below_before() only: try_pairs().)
std::string fails_all_runs(double error_after, const DiagnoseRound& rd, double significance);

/// The median over the runs of after[i] / before[i] (the runs where both are finite and before
/// is positive); NaN when fewer than kMinRunsForMedian runs have both.
double median_run_ratio(const std::vector<double>& after, const std::vector<double>& before);
inline constexpr std::size_t kMinRunsForMedian = 3;
/// "better on k of n runs (median RMS ratio r)" of after against before, run by run (the runs
/// where both are finite); empty when fewer than kMinRunsForMedian runs have both.
std::string runs_better_in_words(const std::vector<double>& after, const std::vector<double>& before);
/// A cut "by far": both folds at most this share of every cross-validated `none` of the round.
inline constexpr double kFarBelowNone = 0.5;
/// A settled single winner that fails fails_all_runs() is still named by most runs when it
/// cuts the cross-validated error by far (both folds at most kFarBelowNone × those of every
/// `none` the round scored) and, run by run, the median of its RMS over the round's before is at
/// most 1 − significance/2 and over every `none` refit's (DiagnoseRound::candidates,
/// none_at_*_breakpoints, none_across_gap) at most 1. The pooled RMS weighs the runs by their
/// squared error, and one run can outweigh the rest: the cogging of seed 45, fitted almost
/// exactly (0.0228 V, period 0.01538 rad) and 74 % below `none` in both folds, took the nine
/// sine runs' error down (3.6 % → 2.3 % of the amplitude) and the square run's up
/// (0.0037 → 0.0070 rad: its steps settle in other wells of the cogging, a multistable plant),
/// 0.00371 over all runs against 0.00351 before. Returns the note said when named (on how many
/// runs it is better: runs_better_in_words()), nullopt otherwise; a winner without per-run RMS:
/// nullopt.
std::optional<std::string> named_by_most_runs(const CandidateScore& settled, const DiagnoseRound& rd,
                                              double significance);

/// The member a named pair keeps alone (the other added nothing: try_pairs()), settled alone:
/// `named` when it passes fails_all_runs(); with `on_trial_allowed`, also when it fails only
/// the `none` refit (not_below_before() passes): then `on_trial` (DiagnoseRound::
/// on_trial_reference_rms). `why`: fails_all_runs()'s reason (empty when it passed).
struct KeptAloneVerdict {
  bool named = false;
  bool on_trial = false;
  std::string why;
};
KeptAloneVerdict judge_kept_alone(double error_after, const DiagnoseRound& rd, double significance,
                                  bool on_trial_allowed);

/// Pairs fitted jointly by the fallback at most (each with the iteration limits of a single).
inline constexpr std::size_t kMaxPairFits = 3;

/// Whether the round's candidate `c` may be one of a pair (try_pairs()): fitted (or searched)
/// and active, an effect of the catalogue that is searched in the rounds (not `none`, not a
/// refinement tried only after its parent, not a torque of time) and not already in the model.
bool pair_eligible(const CandidateScore& c, const RoundModel& model);

/// Whether an effect of `kind` may be one of a pair searched afresh (choose_pairs()): an effect
/// of the catalogue searched in the rounds with a scan (EffectSpec::search_grid), not `none`, not
/// a refinement, not a torque of time, not already in the model; whatever its single fit gave.
bool pair_afresh_kind(EffectKind kind, const RoundModel& model);

/// Candidates of each ranking in the pair fallback's pool (choose_pairs()).
inline constexpr std::size_t kPairPoolEach = 3;

/// A pair to fit jointly (choose_pairs()): the two candidates (indices into the round's
/// candidates, the better single score first), the start (both effects) and its α-model.
struct PairStart {
  std::array<std::size_t, 2> at{};
  Effects effects;
  std::optional<AlphaModel> alpha;
  /// The start's pooled RMS over the fit runs (unit factors, the α-model re-identified with
  /// both) [position unit]
  double screen_rms = std::numeric_limits<double>::quiet_NaN();
  /// Found by the search of both from nothing (search_pair_afresh()), not from the pool.
  bool afresh = false;
};

/// The pairs try_pairs() fits. The pool: the eligible candidates of the round (pair_eligible())
/// with the kPairPoolEach lowest training RMS and those with the kPairPoolEach lowest RMS over
/// all runs. Each pair of the pool is screened: the second's parameters searched like a single
/// candidate's (search_candidate(): a scan and Nelder-Mead, the α-model re-identified at every
/// trial) with the first's fitted ones in the model, since a masked effect's own fit is made
/// without its partner (without re-identification: both fitted sets together, simulated).
/// With re-identification, every pair of the round's kinds pair_afresh_kind() admits whose scan has
/// three points or more is also searched afresh, both from nothing (search_pair_afresh(): the
/// product of their scans, then Nelder-Mead on both; PairStart::afresh), whatever their single
/// fits gave; a pair found both ways keeps the lower search RMS. The kMaxPairFits pairs of the lowest search RMS are returned, the first's parameters searched
/// again with the second's found ones (kept when the RMS drops), each with the breakpoint set
/// that predicts the fit runs best. Empty with fewer than two eligible candidates and no pair
/// searched afresh.
std::vector<PairStart> choose_pairs(const CandidateFitter& fitter, const Reidentifier& reid,
                                    const DiagnoseRound& rd);

/// The pair fallback (a round that named nothing while structure remains): the pairs of
/// choose_pairs() each fitted jointly with the named effects (fit_joint(), from both
/// candidates' own fitted parameters, the α-model re-identified with both where usable) and
/// cross-validated; the best is named when it passes the tests of a single winner: beats `none`
/// in both folds, beats `none` refitted at its breakpoints, and settled on the whole fit runs
/// cuts the error over all runs by significance/2. Writes rd.pairs; returns the index of the
/// named pair (then *settled is its settled fit), nullopt when none.
/// Each member of the named pair must be needed: the settled pair's RMS over all runs at most
/// (1 − significance/2) × its pooled run_rms_without_effect(); otherwise the member whose removal
/// costs least is dropped (PairScore::dropped) and the other named alone when, settled alone from
/// the pair's values, it passes fails_all_runs(); with `on_trial_allowed`, also when it fails only
/// the `none` refit (not_below_before() passes): then on trial, rd.on_trial_reference_rms set.
/// With `torque_residual` (the round's, RoundStart), the best pair, when it beats `none` in both
/// folds, is first offered its members' generalisations (refine_pair_member()).
std::optional<std::size_t> try_pairs(const CandidateFitter& fitter, const Reidentifier& reid,
                                     DiagnoseRound& rd, CandidateScore* settled,
                                     bool on_trial_allowed = false,
                                     const TorqueResidual* torque_residual = nullptr);

/// The pair rd.pairs[best] with one member in a form that generalises it (EffectSpec::generalises,
/// a catalogue candidate not in the model: a Coulomb friction as Stribeck, asymmetric or
/// position-dependent friction), each fitted jointly with the other member from the pair's fit,
/// the member's level taken in (EffectSpec::take_in) and the form's shape from equation error on
/// `torque_residual`, cross-validated, and appended to rd.pairs (PairScore::refined_from). A pair
/// of the nearest names is what the pool's single fits offer: a generalisation is tried in a
/// round only when its parent is among the two best singles, and a member masked by its partner
/// is not (deadzone + Stribeck friction, seed 41: the pair deadzone + Coulomb friction named, the
/// Stribeck hump then taken for a 2.4 ms delay in round 2). Returns the index of the refined pair
/// of lowest score among those whose extra parameters earn their place against the pair
/// (earns_its_place()); nullopt when none does (each one's note says why).
std::optional<std::size_t> refine_pair_member(const CandidateFitter& fitter, const TorqueResidual& torque_residual,
                                              DiagnoseRound& rd, std::size_t best);

/// The RMS of each run given [position unit] of `settled`'s model (effects, factors, α-model)
/// with the effect `kind` off (NaN for a run not simulated; pooled_rms() pools them).
std::vector<double> run_rms_without_effect(const CandidateFitter& fitter, const CandidateScore& settled,
                                           EffectKind kind);

/// One round with the model `model`: candidates of `catalogue` (`none` first) searched, fitted,
/// cross-validated and chosen; with `pair_fallback`, when nothing is named, try_pairs(). Returns
/// the round; *settled receives the settled winner when it names one (rd.named ≠ none; a pair:
/// both effects in it, rd.named_second ≠ none); *failure a message when `none` could not be
/// fitted. `on_trial_allowed`: try_pairs() may name a member on trial; the round then also
/// writes to *none_if_rolled_back (when given) the `none` refit it offers when nothing is named
/// (left as it was when there is none), for diagnose() to go on with when the trial is rolled back.
DiagnoseRound diagnose_round(const std::vector<DiagnoseRun>& runs_in, const PreparedRuns& prepared,
                             const RoundModel& model, const Reidentifier& reid,
                             const std::vector<EffectKind>& catalogue,
                             const DiagnoseOptions& options, CandidateScore* settled,
                             std::string* failure, bool pair_fallback = false,
                             bool on_trial_allowed = false,
                             CandidateScore* none_if_rolled_back = nullptr);

/// The rounds of diagnose() after the options and runs are checked: the external_disturbance
/// stage first (when `catalogue` has it), then the rounds and the verdict; returns `res` filled.
/// A disturbance located but not significant with the model given (its error dominated by an
/// effect the model misses) is kept as a known input while the rounds run, and judged again
/// with the effects they named; when it is still not significant, the rounds run again without
/// it (`provisional_disturbance` false).
DiagnoseResult diagnose_with_disturbance(const std::vector<DiagnoseRun>& runs_given,
                                         const std::vector<EffectKind>& catalogue,
                                         const DiagnoseOptions& opt, DiagnoseResult res,
                                         std::chrono::steady_clock::time_point t_start,
                                         bool provisional_disturbance = true);

/// The external_disturbance stage (DisturbanceFinding, diagnose.hpp; disturbance_stage.cpp): d̂
/// located with `model` in every run and checked by simulation (with_located_disturbance()).
DisturbanceFinding locate_external_disturbance(const std::vector<DiagnoseRun>& runs,
                                               const RoundModel& model, const DiagnoseOptions& opt);

/// Runs where `f` located intervals.
std::size_t runs_touched(const DisturbanceFinding& f);

/// Whether d̂ is judged on the runs it touches: intervals in at least two runs and at least half
/// of them. Else on all runs: intervals in a few runs are as often the model's misfit standing
/// out there (effect-free seeds 47 and 1046 of the sweep, pose 2, noise 2e-4: one run, the 3 Hz
/// run's start ringing on at t = 1.13–1.44 s, cut that run's error 31-52 %, all runs' 4-9 %; a
/// 30 ms lagged friction, seed 8: 6 intervals in 2 of 10 runs, −12 % there, −4 % over all).
bool judged_on_runs_touched(const DisturbanceFinding& f);

/// The RMS that judges d̂, without and with it known: over the runs it touches
/// (touched_before/_after) when judged_on_runs_touched(), else over all runs (error_before/_after).
struct JudgedDisturbanceError {
  double before, after;
  bool on_runs_touched;
};
JudgedDisturbanceError judged_disturbance_error(const DisturbanceFinding& f);

/// Whether d̂ is significant (DisturbanceFinding, diagnose.hpp): judged_disturbance_error()
/// drops below (1 − significance) × before.
bool disturbance_significant(const DisturbanceFinding& f, double significance);

/// RMS of θ − θ_sim (`sims`, one per run) over all samples of the runs, or of those where
/// `touched` located intervals (non-null); NaN when a simulation failed.
double error_over_runs(const std::vector<DiagnoseRun>& runs,
                       const std::vector<std::vector<double>>& sims,
                       const DisturbanceFinding* touched = nullptr);

}  // namespace alphainv::diagnose_detail
