#pragma once
/// \file diagnose.hpp
/// The diagnose workflow: where a model's simulation and the measurement disagree, which physical
/// effect of the catalogue (effects.hpp) explains the gap, and how much adding it shrinks it.
///
/// 0. A torque of time (external_disturbance, DisturbanceFinding): located in time windows of
///    every run's equation-error torque residual, checked by simulation, and when named known
///    to everything after (the runs get d̂ as their disturbance_v column).
/// 1. Every run is simulated under its own controller with the model; the residual θ − θ_sim is
///    located per run, per frequency and over the state (velocity reversals, θ, |v|, α, time
///    after reference jumps) and the concentrations are said in words.
/// 2. Each candidate effect is fitted together with the model. First its parameters are searched
///    (a coarse scan of its main parameter on a grid scaled by the data, with an equation-error
///    start for the torque-like effects, then Nelder-Mead, NLopt) with the α-model RE-IDENTIFIED at
///    every value: the sine runs' local points taken with the candidate in the plant input
///    (effect_sine_point.hpp) and the α-model fitted again to them (alpha_fit.hpp), since a model
///    identified without the effect has absorbed it (a spring, a delay, friction shift C and β̃
///    with frequency) and cannot be mended by adding the effect alone. Among the grid search's
///    winner and runners-up, the breakpoint set that predicts the fit runs best is kept (`none`
///    gets the same choice). Then output error (output_error.hpp) refines the effect together
///    with factors on the model's coefficients (C_n, β̃ ends). Without an α-model or sine runs:
///    output error from equation-error or scanned starts on the model as given.
/// 3. Each candidate is scored by 2-fold cross-validation in time (fitted on the first half of
///    every fit window, RMS error on the second half, and the other way round), so a bigger model
///    does not win by default. The best candidate is named only when its cross-validated error is below
///    (1 − significance) times that of `none` in both folds, it also beats `none` refitted at the
///    winner's α-model breakpoints, and, settled on the whole fit runs (output error from its
///    window fit: the runs' starts count in the error over all runs too), its RMS over all
///    samples of all runs is below (1 − significance/2) times that of the model before;
///    otherwise `none`. Candidates whose search or
///    fit on all fit runs is not below (1 − significance/2) times that of `none` cannot meet
///    this and are not fitted further or cross-validated, nor are those whose search RMS is more
///    than 4 times the best candidate's, nor any but the two with the lowest training RMS (their
///    score is their training RMS, marked). Among candidates within 5 % of
///    the best score the one with fewest parameters is taken.
/// 4. With max_effects > 1 it goes round again with the named effects kept (and refitted),
///    until a round names `none` or the residual is explained to the noise floor. When a round
///    names nothing while structure remains (and max_effects leaves room for two), the pair
///    fallback fits pairs of the round's best candidates jointly (two effects that mask each
///    other) and names a pair that passes the same tests (DiagnoseRound::pairs).
/// 5. With DiagnoseOptions::discover, when structure remains after the named effects: a
///    discovered term for the rest (discovered_term.hpp), kept when it cuts the RMS over all runs.
/// 6. The verdict (verdict.hpp): a noise floor estimated from the data, and whether the residual
///    of the final model is explained to it or where structure remains, and how big.
/// 7. With DiagnoseOptions::run_levels, when structure remains and the model has a friction
///    level: that level fitted run by run (run_levels.hpp), and when it varies between runs, said
///    as a part of the structure that remains (a level that drifts between runs).
/// Offline; never throws on what the data cannot support: the result says.

#include <array>
#include <cstddef>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "alphainv/diagnose/external_disturbance.hpp"
#include "alphainv/diagnose/separability.hpp"
#include "alphainv/diagnose/verdict.hpp"
#include "alphainv/model/controller.hpp"
#include "alphainv/simulate/recorded_run.hpp"  // MeasuredStart
#include "alphainv/data/dataset.hpp"
#include "alphainv/model/effects.hpp"
#include "alphainv/identify/fit_pipeline.hpp"
#include "alphainv/simulate/simulate.hpp"

namespace alphainv {

struct DiscoveredTermResult;  // discovered_term.hpp
struct RunLevelsResult;       // run_levels.hpp

/// Factors on the model's coefficients, fitted together with an effect: c[n] multiplies C_n (the
/// α-model's value at breakpoint n, eq. (38); a linear model has c[0] only) and beta[j] multiplies
/// β̃_j (eq. (41); beta[0] only for a linear model). All 1: the model as given.
struct ModelScales {
  std::vector<double> c{1.0};
  std::vector<double> beta{1.0};
};

/// One run to diagnose: data, controller and the model at its pose.
struct DiagnoseRun {
  const RunData* data = nullptr;  ///< must outlive the call
  Controller controller;
  JointModelAtPose model;         ///< the model to test (its effects are kept)
  std::string name;               ///< for the report (the run's file)
  std::string kind;               ///< "sine", "square", "step", "other", …
  std::optional<double> freq_hz;  ///< reference frequency of periodic runs
  /// Commands of the ticks before the run's first sample (oldest first), for a run that starts
  /// mid-way (see InitialState::command_history). Usually empty.
  std::vector<double> command_history;
  /// The measured state at the first sample of a run that starts mid-way (measured_state_at()
  /// on the longer record; diagnose's fit windows and folds set it); NaN: from the run's first
  /// samples.
  MeasuredStart start;
};

/// Settings of diagnose().
struct DiagnoseOptions {
  /// Effects named at most (a round names one, or two by the pair fallback when both fit in).
  /// 3, as `omni_fit diagnose --max-effects` and Python's diagnose(): the rounds go on while an
  /// effect is named and structure remains (1: a single round).
  std::size_t max_effects = 3;
  unsigned threads = 0;         ///< simulations in parallel; 0: all cores
  SimulationOptions simulation; ///< continuous law or digital loop (loop_period_s > 0)
  std::size_t max_fit_runs = 20;  ///< runs used to fit and score candidates (spread over kinds)
  std::size_t max_residuals_per_run = 800;  ///< output-error residual samples per run
  /// Candidates are fitted and scored on the last fit_window_s of each fit run (started from the
  /// measured state there), which keeps the steady state of sine runs and the last jump of square
  /// runs at a fraction of the cost; 0: whole runs.
  double fit_window_s = 2.5;
  /// A candidate is named when its cross-validated RMS is below (1 − significance) × that of
  /// `none` in both folds.
  double significance = 0.10;
  std::vector<EffectKind> candidates;  ///< empty: the whole catalogue
  /// Search each candidate's parameters with the α-model's coefficients re-identified from the
  /// sine runs' local points taken with the candidate in the plant input (effect_sine_point.hpp)
  /// before the output-error fit; needs an α-model and sine runs under a P law. false: the
  /// output-error fit alone, from equation-error or scanned starts.
  bool reidentify = true;
  /// After the named effects, when the verdict says structure remains: a discovered term
  /// (discovered_term.hpp) fitted by sparse regression and output error, kept when it cuts the
  /// RMS over all runs by significance/2.
  bool discover = true;
  /// At the end, when structure remains and the model has a friction level: the level fitted run
  /// by run (run_levels.hpp); when it varies between runs, the verdict's unexplained parts say so.
  bool run_levels = true;
  /// After the rounds, with two or more effects named: each checked again against the model
  /// without it (DiagnoseResult::dropped), the one that no longer earns its place dropped; when
  /// one was dropped and structure remains, the rounds run once more in the place it freed,
  /// without the dropped in the catalogue (DiagnoseRound::after_dropping).
  bool drop_redundant = true;

  /// Throws alphainv::Error naming the field (e.g. "significance", "candidates[2]") when a value
  /// is out of range: max_effects, max_fit_runs and max_residuals_per_run ≥ 1, fit_window_s
  /// finite ≥ 0, significance in [0, 1), candidates known kinds without repeats,
  /// simulation.loop_period_s finite ≥ 0. diagnose() calls it and reports a refusal in its result.
  void validate() const;
};

/// One candidate of one round.
struct CandidateScore {
  EffectKind effect = EffectKind::kNone;
  bool ok = false;
  std::string message;  ///< what happened to it (pruned, set aside, settled); may be empty
  /// The modelling choices its fit made, which hold whatever the later stages do (e.g. "friction
  /// smoothing ε taken 10× sharper: …"); empty: the defaults. full_message() puts it first.
  std::string modelling_note;
  Effects effects;      ///< all effects of the model with this candidate (fitted on all fit runs)
  ModelScales scales;   ///< the model's coefficient factors fitted with it
  /// Cross-validated RMS of θ − θ_sim [position unit] (the score; lower is better).
  double score = std::numeric_limits<double>::infinity();
  std::array<double, 2> fold_scores{{std::numeric_limits<double>::infinity(),
                                     std::numeric_limits<double>::infinity()}};
  double error_after = std::numeric_limits<double>::quiet_NaN();  ///< RMS over all runs
  /// The RMS of each run given (indexed as the runs; NaN for a run not simulated), whose pooled
  /// value is error_after; empty where only the pooled value was computed.
  std::vector<double> run_error_after;
  /// RMS of the fit on all fit runs (fit windows) [position unit]
  double training_rms = std::numeric_limits<double>::quiet_NaN();
  bool cross_validated = true;  ///< false: pruned, `score` is its training RMS
  /// true: started from the search with the α-model re-identified (DiagnoseOptions::reidentify)
  bool reidentified = false;
  /// The α-model re-identified with the effects (replaces the runs' α-model; the scales apply to
  /// it); nullopt: the runs' own.
  std::optional<AlphaModel> alpha;
  /// Non-empty: set aside as inactive on the data, with the reason (its fitted effect does not
  /// move the simulated θ: `none` in disguise, e.g. a saturation level above the largest |v|; or
  /// its fitted parameters contradict the form it names: a Stribeck friction with Fs <= Fc).
  /// An inactive candidate is not cross-validated, cannot win and is not preferred by parsimony.
  std::string inactive;

  /// modelling_note and message, joined by "; " (either may be empty).
  std::string full_message() const {
    if (modelling_note.empty()) return message;
    return message.empty() ? modelling_note : modelling_note + "; " + message;
  }
};

/// Where the residual concentrates.
struct ResidualLocation {
  std::vector<double> run_rms;         ///< per run [position unit]
  double rms = std::numeric_limits<double>::quiet_NaN();  ///< over all runs and samples
  /// Share of residual energy over share of samples in a state region (1: no concentration).
  double reversal_concentration = std::numeric_limits<double>::quiet_NaN();  ///< |θ̇| < 10 % max
  double jump_concentration = std::numeric_limits<double>::quiet_NaN();  ///< ≤ 0.15 s after a jump
  double high_command_concentration = std::numeric_limits<double>::quiet_NaN();  ///< top 10 % |v|
  double low_command_concentration = std::numeric_limits<double>::quiet_NaN();   ///< bottom 10 % |v|
  double high_alpha_concentration = std::numeric_limits<double>::quiet_NaN();    ///< top 10 % α
  double position_r2 = std::numeric_limits<double>::quiet_NaN();  ///< residual torque ~ sin θ, cos θ
  double low_vs_high_frequency = std::numeric_limits<double>::quiet_NaN();  ///< sine-run RMS ratio
  std::vector<std::string> findings;   ///< the concentrations said in words
};

/// Two candidates of a round fitted jointly (the pair fallback, DiagnoseRound::pairs): when two
/// effects mask each other, neither alone beats `none`, but both together do.
struct PairScore {
  /// The two effects, in the order of their single scores (the better first).
  std::array<EffectKind, 2> kinds{{EffectKind::kNone, EffectKind::kNone}};
  /// The joint fit: both effects' parameters in `effects`, the coefficient factors and α-model
  /// fitted with them, the cross-validated score and folds, the RMS over all runs (after
  /// settling, when it was named); `effect` is kinds[0]; `message` says why it was not named.
  CandidateScore fit;
  /// `none` refitted with the α-model at the pair's breakpoints (the pair must beat it too).
  std::optional<CandidateScore> none_at_breakpoints;
  bool named = false;  ///< the pair passed the tests a single winner must pass
  /// A member that added nothing over all runs when the pair was named: the other was named
  /// alone (`fit` is then its settled fit); kNone when both were named.
  EffectKind dropped = EffectKind::kNone;
  /// Its start was found by searching both effects together from nothing (a product of their
  /// scans, then Nelder-Mead on both), not from either one's single fit: two effects that mask
  /// each other can each fit alone at a wrong value.
  bool afresh = false;
  /// A pair fitted with this member's generalisation in its place (EffectSpec::generalises): the
  /// best pair had `refined_from` (a Coulomb friction) where this one has the generalisation,
  /// started from that pair's fit with its level taken in (EffectSpec::take_in); kNone otherwise.
  EffectKind refined_from = EffectKind::kNone;
};

/// One round.
struct DiagnoseRound {
  EffectKind named = EffectKind::kNone;
  /// The second effect named in this round: only by the pair fallback (`pairs`); kNone otherwise.
  EffectKind named_second = EffectKind::kNone;
  std::vector<CandidateScore> candidates;  ///< in catalogue order
  /// `none` refitted with the α-model at the winner's breakpoints (when the winner's α-model was
  /// re-identified): the winner is named only if it beats this too.
  std::optional<CandidateScore> none_at_winner_breakpoints;
  /// The same for the runner-up, tried when the winner was not named (the next lowest score,
  /// held to the winner's tests).
  std::optional<CandidateScore> none_at_runner_up_breakpoints;
  /// `none` refitted with the α-model linear in α across the widest gap of the sine points' α
  /// (when there is one, more than 4× between neighbours, and a winner): the winner is named only
  /// if it beats this too. The grid's breakpoints may put a knee anywhere in such a gap, which
  /// the square runs' ringing passes through, and a friction then makes up for the knee
  /// (effect-free at 25°/115°: coulomb_friction named in 3 of 8 datasets).
  std::optional<CandidateScore> none_across_gap;
  /// The pairs fitted jointly when no single candidate was named and structure remained (at most
  /// 3; empty when the fallback did not run): one named at most, then `named`, `named_second`.
  std::vector<PairScore> pairs;
  double error_before = std::numeric_limits<double>::quiet_NaN();
  double error_after = std::numeric_limits<double>::quiet_NaN();
  /// error_before run by run (indexed as the runs given): the runs judged one by one too
  /// (docs/diagnose.md, item 4).
  std::vector<double> run_error_before;
  /// Nothing named, and `none` (the model's own α-model re-identified, its coefficient factors
  /// refitted by output error, settled on the whole fit runs; or the α-model linear across the
  /// widest gap of the sine points' α, with unit factors, as the sine points give it) explains the data to the noise
  /// floor where the model as it came does not: the model goes on with it (error_after is its
  /// RMS). The grid's α-model can place its breakpoints anywhere in a gap of the sine points'
  /// α that the other runs pass through (an effect-free one-pose dataset: 0.0059 as given,
  /// 0.0024 refitted). Only then: where structure remains the refit's factors have bent C and
  /// β̃ towards the missing effect (a friction: the discovered term then closed 29 % of the gap
  /// from it, 50 % and more from the model as it came); and where the model as it came is
  /// explained, the refit may trade the sine runs' gains and phases (each exact in the sine
  /// points) for the other runs'.
  bool none_refitted = false;
  /// A round run after the backward elimination dropped an effect (DiagnoseResult::dropped),
  /// with the place it freed and without the dropped in the catalogue.
  bool after_dropping = false;
  /// With none_refitted: which refit, in words (for the report).
  std::string none_refit_how;
  /// The effect already in the model (named in an earlier round, or the model given's) this
  /// round's generalisation took in (EffectSpec::take_in: a Coulomb level named before gravity
  /// was in the model, then Stribeck or asymmetric friction named on top of it, is one friction
  /// term of that form); kNone otherwise. The taken-in effect is no longer in the model, nor in
  /// DiagnoseResult::effects_named.
  EffectKind took_in = EffectKind::kNone;
  /// A member kept alone from the named pair (PairScore::dropped) whose RMS over all runs was
  /// below the round's error before (not_below_before()) but above a `none` this round refitted
  /// (fails_all_runs()) is named on trial: the effects the later rounds name with it in the
  /// model must take the diagnosis below this RMS over all runs (none_reference_rms() of the
  /// round), else this round and the ones after it are rolled back (`rolled_back`): this round
  /// then names nothing (`named` none, `rolled_back_why` says what it had named) and the diagnosis
  /// goes on as though the member had been vetoed. NaN otherwise. (On
  /// gravity + a 4 ms delay the Coulomb friction kept alone from saturation + Coulomb, 0.0355
  /// against `none` refitted 0.0248, opened the rounds that named gravity and the delay, and was
  /// dropped after them.) At most one round per diagnosis, and not after an effect was dropped.
  double on_trial_reference_rms = std::numeric_limits<double>::quiet_NaN();
  /// Rolled back: the round that named a member on trial (on_trial_reference_rms) when the
  /// diagnosis did not end below its reference, and every round after it (their effects, named
  /// with the member in the model, are not in the result). Rounds after the last rolled-back
  /// one ran from the model as it was before the trial.
  bool rolled_back = false;
  /// On the round that named a member on trial and was rolled back: what it had named, and the
  /// RMS over all runs the diagnosis ended at with it.
  std::string rolled_back_why;
};

/// The external_disturbance stage (before the rounds, when the candidates include it): a torque
/// of time located in every run's equation-error torque residual with the model given
/// (external_disturbance.hpp), then checked by simulating every run with d̂ added to its
/// `disturbance_v` column (a known input, plant_input.hpp). Named when some run has intervals and
/// the RMS of θ − θ_sim drops below (1 − significance) × before, over the runs with intervals
/// (the runs d̂ touches; the others do not change) when they are at least two and half the runs,
/// else over all runs (a few runs' intervals are as often the model's misfit standing out there:
/// diagnose_stages.hpp judged_on_runs_touched()). The rounds then run with d̂ known. (Judged over
/// all runs always, one run whose pulses were not located dominated the pooled error: pulses of
/// 0.065 V located at their level in 9 of 10 runs cut those runs' error 21 % but all runs' 6 %,
/// the unlocated run near the resonance holding 72 % of the squared error.) Located but not
/// significant with the model given (masked by an effect the model misses): the rounds run with
/// d̂ known, and it is judged again with the effects they named (error_before/_after and
/// touched_before/_after are then that check's, the message gives both); still not
/// significant, the rounds run again without it.
struct DisturbanceFinding {
  bool tried = false;   ///< the candidates include external_disturbance
  bool named = false;   ///< located, and the error judged (above) drops
  std::string message;  ///< what was found, or why it is not named
  std::vector<std::string> run_names;       ///< every run's name, in order
  std::vector<DisturbanceEstimate> runs;    ///< per run (not ok: too short)
  /// Per run: it records a `disturbance_v` column (a known input the model already takes; the
  /// estimate is what remains beyond it).
  std::vector<bool> recorded;
  double error_before = std::numeric_limits<double>::quiet_NaN();  ///< RMS over all runs
  double error_after = std::numeric_limits<double>::quiet_NaN();   ///< … with d̂ known
  /// RMS over the runs with intervals, without and with d̂ known (what `named` judges).
  double touched_before = std::numeric_limits<double>::quiet_NaN();
  double touched_after = std::numeric_limits<double>::quiet_NaN();
  double rms_v = 0.0;  ///< RMS of d̂ over the runs with intervals [command unit]
  std::size_t intervals = 0;  ///< over all runs
};

/// A named effect of the result in the order it was named (DiagnoseResult::named_in_order()).
struct NamedEffect {
  EffectKind effect = EffectKind::kNone;
  /// The RMS of θ − θ_sim over all runs after its round (a pair: the pair's; the disturbance:
  /// with d̂ known) [position unit].
  double error_after = std::numeric_limits<double>::quiet_NaN();
  /// The effect already in the model its round's generalisation took in (DiagnoseRound::took_in).
  EffectKind took_in = EffectKind::kNone;
};

/// Why diagnose() stopped (like Ceres' TerminationType).
enum class DiagnoseTermination {
  kNoneNamed,       ///< usable: the last round named `none` (the model is left as it was then)
  kExplained,       ///< usable: after the last effect named the residual is at the noise floor
  kMaxEffects,      ///< usable: DiagnoseOptions::max_effects effects named
  kInvalidOptions,  ///< not usable: DiagnoseOptions::validate() refused them (message: the field)
  kInvalidInput,    ///< not usable: no runs, or a run shorter than 50 samples (message: which)
  kFailure,         ///< not usable: the model without a new effect could not be fitted
};

/// "none named", "explained", "max effects", "invalid options", "invalid input", "failure".
const char* termination_name(DiagnoseTermination termination);

/// An effect a round named and the model then did without (backward elimination after the
/// rounds: an effect named early, in a model without the effects named after it, can carry
/// their share of the error until they are in; stepwise regression checks each term again so).
struct DroppedEffect {
  EffectKind effect = EffectKind::kNone;
  /// Cross-validated RMS of θ − θ_sim of the named effects refitted with it and without it.
  double score_with = std::numeric_limits<double>::quiet_NaN();
  double score_without = std::numeric_limits<double>::quiet_NaN();
  std::string message;  ///< in words, for the report
};

/// What diagnose() found. Like Ceres' Solver::Summary: whether it is usable (`ok`), why it
/// stopped (`termination`, `message`), the error before and after, the rounds, the time, and a
/// one-line and a multi-line report (report.md: diagnose_report.hpp).
struct DiagnoseResult {
  bool ok = false;       ///< usable: the rounds ran (an effect named or `none`)
  std::string message;   ///< why not usable; empty when ok
  DiagnoseTermination termination = DiagnoseTermination::kFailure;
  std::vector<DiagnoseRound> rounds;
  std::vector<EffectKind> effects_named;  ///< in order
  Effects effects;                         ///< the final model's effects
  ModelScales scales;                      ///< the final model's coefficient factors
  /// The final model's α-model when re-identified with its effects (replaces the runs' α-model
  /// before the factors); nullopt: the runs' own.
  std::optional<AlphaModel> alpha;
  ResidualLocation before, after;          ///< the residual of the model given and of the final one
  /// The noise floor (estimated from the residual of the model given; verdict.hpp) and the
  /// verdicts on the model given and on the final one: explained to the floor, or where
  /// structure remains and how big against it.
  NoiseFloor noise_floor;
  VerdictReport verdict_before, verdict;
  /// The external_disturbance stage; when named, effects_named starts with it, `effects` has
  /// its size (disturbance_rms_v), and error_after, `after` and `verdict` are with d̂ known.
  DisturbanceFinding disturbance;
  double error_before = std::numeric_limits<double>::quiet_NaN();  ///< RMS of θ − θ_sim, all runs
  double error_after = std::numeric_limits<double>::quiet_NaN();
  /// The discovered term tried after the named effects (DiagnoseOptions::discover), kept or not
  /// (its `kept`; kept: in `effects`; effects_named lists the catalogue's named effects only);
  /// nullptr: not tried (explained, not usable, or switched off).
  std::shared_ptr<const DiscoveredTermResult> discovered;
  /// The friction level fitted run by run (DiagnoseOptions::run_levels; run_levels.hpp); when it
  /// varies, verdict.unexplained has a part "runs: the friction level differs …"; nullptr: not
  /// tried (explained, no friction level, or switched off).
  std::shared_ptr<const RunLevelsResult> run_levels;
  /// The last round's candidates the data cannot tell from the named effects (separability.hpp):
  /// not named, and not ruled out either.
  std::vector<NotSeparable> not_separable;
  /// Effects the rounds named that the model did without in the end (not in effects_named nor
  /// in `effects`; their rounds stay in `rounds`).
  std::vector<DroppedEffect> dropped;
  std::vector<std::size_t> fit_runs;  ///< indices of the runs used to fit and score
  double seconds = 0.0;               ///< wall time

  /// One line: the effects named (or none) and the RMS before → after over all runs, e.g.
  /// "offset_torque; RMS of theta - theta_sim 0.01199 -> 0.003536 (10 runs, 6.2 s)"; when not
  /// usable, "not usable (invalid input): run a.csv has fewer than 50 samples".
  std::string brief_report() const;
  /// Several lines: usable, termination, runs, the error before and after, the effects named
  /// with their parameters, every round's candidates (score, folds, RMS after, note), where
  /// the residual concentrates before and after, and the verdict (its last line).
  std::string full_report() const;
  /// The named effects in the order they were named, each with the error after its round: the
  /// external disturbance when named (located before the rounds), then every round's (both of a
  /// pair) but those of rounds rolled back, effects dropped after the rounds and effects a later
  /// round's generalisation or the kept discovered term took in (DiscoveredTermResult::took_in).
  /// The same effects as effects_named (not the discovered term).
  std::vector<NamedEffect> named_in_order() const;
};

/// Runs the workflow (file comment). Never throws: options that validate() refuses, runs too
/// short and a failed fit are said in the result (ok, termination, message).
DiagnoseResult diagnose(const std::vector<DiagnoseRun>& runs, const DiagnoseOptions& options = {});

/// The model `base` with its α-model replaced by `alpha` (when given), then the effects `e` and
/// the coefficient factors applied.
JointModelAtPose diagnosed_model(const JointModelAtPose& base, const Effects& e,
                                 const ModelScales& scales,
                                 const std::optional<AlphaModel>& alpha = std::nullopt);

/// `runs` with the d̂ of `finding` added to each run's `disturbance_v` column (the data copied
/// into `storage`, which must outlive the result): the runs as diagnose() simulated them after a
/// named external_disturbance. `runs` as they are when it was not named or `finding` does not
/// match them (another number of runs or samples).
std::vector<DiagnoseRun> with_located_disturbance(const std::vector<DiagnoseRun>& runs,
                                                  const DisturbanceFinding& finding,
                                                  std::vector<RunData>& storage);

/// Simulates every run with its model changed by diagnosed_model(); returns the simulated θ of
/// each (empty for a failed run).
std::vector<std::vector<double>> simulate_diagnosed(const std::vector<DiagnoseRun>& runs,
                                                    const Effects& e,
                                                    const ModelScales& scales,
                                                    const SimulationOptions& simulation,
                                                    unsigned threads = 0,
                                                    const std::optional<AlphaModel>& alpha = std::nullopt);

/// The runs of `dataset` with the models of `fit` (model_for_pose of each run's pose), each under
/// its own controller; runs that switch the motor off (torque_enable = 0) are in, the column a
/// known input of their simulations (plant_input.hpp), as fit and validate take it.
std::vector<DiagnoseRun> diagnose_runs(const Dataset& dataset, const std::vector<RunData>& data,
                                       const DatasetFit& fit);

/// Fits the α-invariant model to the dataset (fit_dataset() without validation; `fit_options`
/// as given), then diagnoses it with the fit's simulation mode. `fit_out` receives the fit (not
/// made when `options` are invalid: the result says which field).
DiagnoseResult diagnose_dataset(const Dataset& dataset, const std::vector<RunData>& data,
                                DiagnoseOptions options, const FitPipelineOptions& fit_options = {},
                                DatasetFit* fit_out = nullptr);

}  // namespace alphainv
