// The stages of diagnose() (src/diagnose/diagnose_stages.hpp), each on its own: prepare on
// hand-made runs, locate on a known residual, search / fit / cross-validate / settle on the
// sweep's one-pose dataset with a hidden offset torque, choose on hand-built candidates.
#include "diagnose/diagnose_stages.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include <gtest/gtest.h>

#include "diagnose/one_pose_dataset.hpp"

namespace alphainv::diagnose_detail {
namespace {

constexpr double kTwoPi = 6.283185307179586;

/// A run of `seconds` at 1 kHz: r = θ = 0.1·sin(2π·t), v = v_amp·sin(2π·t), under a P law kp.
RunData sine_data(double seconds, double v_amp) {
  RunData d;
  const std::size_t n = static_cast<std::size_t>(std::lround(seconds * 1000.0)) + 1;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = 0.001 * static_cast<double>(k);
    d.t.push_back(t);
    d.r.push_back(0.1 * std::sin(kTwoPi * t));
    d.theta.push_back(0.1 * std::sin(kTwoPi * t));
    d.v.push_back(v_amp * std::sin(kTwoPi * t));
  }
  return d;
}

DiagnoseRun run_of(const RunData& d, const std::string& name, double kp) {
  DiagnoseRun r;
  r.data = &d;
  r.name = name;
  r.kind = "sine";
  r.freq_hz = 1.0;
  r.controller.kp = kp;
  r.model = model_at_pose(paper_linear_model(), paper_alpha_model(), deg_to_rad(60.08),
                          deg_to_rad(87.0));
  return r;
}

TEST(DiagnoseStages, PrepareCutsWindowsAndFoldsAndMeasuresTheScales) {
  const RunData a = sine_data(4.0, 0.5), b = sine_data(3.0, 0.8), c = sine_data(2.0, 0.2);
  const std::vector<DiagnoseRun> runs = {run_of(a, "a", 2.0), run_of(b, "b", 3.0),
                                         run_of(c, "c", 3.0)};
  DiagnoseOptions opt;
  opt.fit_window_s = 2.5;
  const PreparedRuns p = prepare_runs(runs, opt);
  ASSERT_EQ(p.fit_runs, (std::vector<std::size_t>{0, 1, 2}));
  ASSERT_EQ(p.runs.size(), 3u + 6u);  // the runs, then two halves per fit run
  EXPECT_EQ(p.all, (std::vector<std::size_t>{0, 1, 2}));
  // Windows: the last 2.5 s (2501 samples) with 0.3 s of history; c (2 s) whole, no history.
  EXPECT_EQ(p.runs[0].data->size(), 2501u);
  EXPECT_DOUBLE_EQ(p.runs[0].data->t.front(), a.t[1500]);
  EXPECT_EQ(p.runs[0].command_history.size(), 300u);
  EXPECT_EQ(p.runs[0].command_history.back(), a.v[1499]);
  EXPECT_EQ(p.runs[1].data->size(), 2501u);
  EXPECT_EQ(p.runs[2].data->size(), c.size());
  EXPECT_TRUE(p.runs[2].command_history.empty());
  // Folds: first and second half of each window; the second half's history is the 300
  // commands before it.
  ASSERT_EQ(p.folds[0], (std::vector<std::size_t>{3, 5, 7}));
  ASSERT_EQ(p.folds[1], (std::vector<std::size_t>{4, 6, 8}));
  EXPECT_TRUE(p.can_cross_validate);
  EXPECT_EQ(p.runs[3].data->size(), 1250u);
  EXPECT_EQ(p.runs[4].data->size(), 1251u);
  EXPECT_DOUBLE_EQ(p.runs[4].data->t.front(), a.t[1500 + 1250]);
  EXPECT_EQ(p.runs[4].command_history.size(), 300u);
  EXPECT_EQ(p.runs[4].command_history.back(), a.v[1500 + 1249]);
  EXPECT_EQ(p.runs[3].command_history, p.runs[0].command_history);
  // Scales of the windows: the largest |v| (b's 0.8), θ's range, the first run's kp, and the
  // RMS of θ̇ = 0.2π·cos(2πt) over whole periods (0.2π/√2 ≈ 0.444).
  EXPECT_NEAR(p.scales.v_max, 0.8, 1e-6);
  EXPECT_NEAR(p.scales.theta_min, -0.1, 1e-6);
  EXPECT_NEAR(p.scales.theta_max, 0.1, 1e-6);
  EXPECT_EQ(p.scales.kp, 2.0);
  EXPECT_NEAR(p.scales.theta_dot_rms, 0.1 * kTwoPi / std::sqrt(2.0), 0.01);
  // Unit factors shaped like the α-model: one per breakpoint, two β̃ ends.
  EXPECT_EQ(p.unit_scales.c, std::vector<double>(paper_alpha_model().n_breakpoints, 1.0));
  EXPECT_EQ(p.unit_scales.beta, (std::vector<double>{1.0, 1.0}));
  const RoundModel m = initial_model(runs, p);
  EXPECT_TRUE(m.named.empty());
  EXPECT_DOUBLE_EQ(m.effects.coulomb_smoothing_rad_s, 0.01 * p.scales.theta_dot_rms);

  // At most two fit runs: spread over the runs; no fit window: whole runs.
  opt.max_fit_runs = 2;
  opt.fit_window_s = 0.0;
  const PreparedRuns q = prepare_runs(runs, opt);
  EXPECT_EQ(q.fit_runs, (std::vector<std::size_t>{0, 2}));
  EXPECT_EQ(q.runs[0].data->size(), a.size());
  EXPECT_EQ(q.runs.size(), 3u + 4u);
}

TEST(DiagnoseStages, LocateMeasuresTheResidualWhereItIs) {
  const RunData a = sine_data(2.0, 0.5), b = sine_data(2.0, 0.5);
  const std::vector<DiagnoseRun> runs = {run_of(a, "a.csv", 2.0), run_of(b, "b.csv", 2.0)};
  // Run a off by 0.01 everywhere, run b by 0.02 only where |θ̇| is below 10 % of its largest
  // value (at the reversals).
  std::vector<std::vector<double>> sims = {a.theta, b.theta};
  for (double& x : sims[0]) x -= 0.01;
  std::size_t n_rev = 0;
  for (std::size_t k = 0; k < b.size(); ++k) {
    if (std::abs(std::cos(kTwoPi * b.t[k])) < 0.1) {
      sims[1][k] -= 0.02;
      ++n_rev;
    }
  }
  const ResidualLocation loc = locate(runs, sims);
  ASSERT_EQ(loc.run_rms.size(), 2u);
  EXPECT_NEAR(loc.run_rms[0], 0.01, 1e-12);
  const double share = static_cast<double>(n_rev) / static_cast<double>(b.size());
  EXPECT_NEAR(loc.run_rms[1], 0.02 * std::sqrt(share), 1e-4);
  EXPECT_NEAR(loc.rms, std::sqrt(0.5 * (0.01 * 0.01 + 0.02 * 0.02 * share)), 1e-4);
  EXPECT_GT(loc.reversal_concentration, 1.5);
  const bool said = std::any_of(loc.findings.begin(), loc.findings.end(), [](const std::string& f) {
    return f.find("at velocity reversals") != std::string::npos;
  });
  EXPECT_TRUE(said);
  EXPECT_NE(loc.findings.back().find("largest errors in runs a.csv"), std::string::npos)
      << loc.findings.back();
}

/// The sweep's 10-run dataset of one pose (test_diagnose.cpp) with a hidden offset torque,
/// fitted without the offset, as diagnose() sees it: 4 fit runs, 1.5 s windows.
struct OffsetCase {
  std::unique_ptr<test::OnePoseDiagnoseRuns> fitted;  // (the runs point into it)
  std::vector<DiagnoseRun> runs;
  DiagnoseOptions opt;
  PreparedRuns prepared;
  RoundModel model;
};

const OffsetCase& offset_case() {
  static const OffsetCase* c = [] {
    auto* oc = new OffsetCase;
    Effects hidden;
    hidden.offset_v = 0.02;
    oc->fitted = test::one_pose_diagnose_runs(hidden, 4);
    oc->runs = oc->fitted->runs;
    oc->opt.simulation = oc->fitted->fit.simulation;
    oc->opt.max_fit_runs = 4;
    oc->opt.fit_window_s = 1.5;
    oc->prepared = prepare_runs(oc->runs, oc->opt);
    oc->model = initial_model(oc->runs, oc->prepared);
    return oc;
  }();
  return *c;
}

TEST(DiagnoseStages, SearchFindsTheHiddenOffsetLowest) {
  const OffsetCase& c = offset_case();
  const Reidentifier reid(c.runs, c.opt.simulation.loop_period_s);
  ASSERT_TRUE(reid.usable());
  const RoundStart start = start_round(c.runs, c.prepared, c.model, reid, c.opt);
  ASSERT_TRUE(start.none_alpha.has_value());
  ASSERT_TRUE(std::isfinite(start.none_unit_rms));
  EXPECT_GT(start.torque_residual.n_hat.size(), 1000u);
  const CandidateSearch offset =
      search_candidate(EffectKind::kOffsetTorque, c.prepared, c.model, start, reid, c.opt);
  ASSERT_TRUE(offset.searched);
  EXPECT_NEAR(offset.effects.offset_v, 0.02, 0.1 * 0.02);
  // The search alone (unit factors) cuts the gap on the fit runs to 13 % here.
  EXPECT_LT(offset.found_rms, 0.2 * start.none_unit_rms);
  for (EffectKind other : {EffectKind::kTimeDelay, EffectKind::kDeadzone}) {
    const CandidateSearch s = search_candidate(other, c.prepared, c.model, start, reid, c.opt);
    ASSERT_TRUE(s.searched) << effect_name(other);
    EXPECT_GT(s.found_rms, 4.0 * offset.found_rms) << effect_name(other);  // 6× here
  }
  // `none` is not searched: it starts from its own re-identified α-model at unit factors.
  const CandidateSearch none =
      search_candidate(EffectKind::kNone, c.prepared, c.model, start, reid, c.opt);
  EXPECT_FALSE(none.searched);
  EXPECT_EQ(none.start_scales.c, c.prepared.unit_scales.c);
  ASSERT_TRUE(none.alpha.has_value());
  EXPECT_EQ(none.alpha->alpha, start.none_alpha->alpha);
}

TEST(DiagnoseStages, SearchInTheModelAsItIsAddsTheEffectToTheModelsOwnAlphaModelAndFactors) {
  // search_in_model(): the second way in when the search with the α-model re-identified did not
  // reach `none`'s best variant. The model as it is here: the offset case's (the runs' own
  // α-model and its unit coefficient factors).
  const OffsetCase& c = offset_case();
  const Reidentifier reid(c.runs, c.opt.simulation.loop_period_s);
  const RoundModel& model = c.model;
  const RoundStart start = start_round(c.runs, c.prepared, model, reid, c.opt);
  ASSERT_TRUE(std::isfinite(start.model_fit_rms));
  const CandidateSearch offset = search_in_model(EffectKind::kOffsetTorque, c.prepared, model, start, c.opt);
  EXPECT_FALSE(offset.searched);  // started for an output-error fit from the model's own
  EXPECT_EQ(offset.start_scales.c, model.scales.c);
  EXPECT_EQ(offset.alpha.has_value(), model.alpha.has_value());
  // The equation-error start finds the hidden 0.02 V and cuts the model's error on the fit runs.
  EXPECT_NEAR(offset.effects.offset_v, 0.02, 0.25 * 0.02);
  EXPECT_LT(offset.found_rms, 0.5 * start.model_fit_rms) << offset.found_rms << " against " << start.model_fit_rms;
  // An effect not hidden, scanned over its grid (no equation-error start), does not pass the
  // second way's test (1 − significance/2 of the model's own error).
  const CandidateSearch delay = search_in_model(EffectKind::kTimeDelay, c.prepared, model, start, c.opt);
  EXPECT_GT(delay.effects.delay_s, 0.0);
  EXPECT_FALSE(delay.found_rms <= (1.0 - 0.5 * c.opt.significance) * start.model_fit_rms)
      << delay.found_rms << " against " << start.model_fit_rms;
}

TEST(DiagnoseStages, FitAndCrossValidateScoreTheOffsetBelowNoneAndSettleIt) {
  // Without re-identification: the offset starts from the equation-error regression on the
  // torque residual and is fitted by output error with the model's factors.
  const OffsetCase& c = offset_case();
  const std::vector<DiagnoseRun> no_runs;
  const Reidentifier reid(no_runs, 0.0);
  const RoundStart start = start_round(c.runs, c.prepared, c.model, reid, c.opt);
  EXPECT_FALSE(start.none_alpha.has_value());
  CandidateFitter fitter(c.runs, c.prepared, c.model, c.opt);
  const CandidateSearch none_start =
      search_candidate(EffectKind::kNone, c.prepared, c.model, start, reid, c.opt);
  const CandidateScore none = fitter.fit(EffectKind::kNone, none_start.effects,
                                         none_start.start_scales, none_start.alpha, false, true,
                                         nullptr);
  ASSERT_TRUE(none.ok) << none.message;
  EXPECT_TRUE(none.cross_validated);
  fitter.set_none_training_rms(none.training_rms);
  const CandidateSearch s =
      search_candidate(EffectKind::kOffsetTorque, c.prepared, c.model, start, reid, c.opt);
  EXPECT_FALSE(s.searched);
  EXPECT_NEAR(s.effects.offset_v, 0.02, 0.1 * 0.02);  // the regression's start
  PendingCrossValidation later;
  CandidateScore offset =
      fitter.fit(EffectKind::kOffsetTorque, s.effects, s.start_scales, s.alpha, false, false, &later);
  ASSERT_TRUE(offset.ok) << offset.message;
  EXPECT_FALSE(offset.cross_validated);  // left for cross_validate()
  EXPECT_EQ(offset.score, offset.training_rms);
  ASSERT_EQ(later.blocks.size(), 1u);
  EXPECT_EQ(later.blocks[0].kind, EffectKind::kOffsetTorque);
  EXPECT_EQ(later.values.size(), c.prepared.unit_scales.c.size() + 2u + 1u);
  EXPECT_NEAR(offset.effects.offset_v, 0.02, 0.1 * 0.02);
  EXPECT_LT(offset.training_rms, 0.1 * none.training_rms);  // 7 % here
  fitter.cross_validate(offset, later.blocks, later.values);
  EXPECT_TRUE(offset.cross_validated);
  for (const CandidateScore* x : {&none, static_cast<const CandidateScore*>(&offset)}) {
    EXPECT_TRUE(std::isfinite(x->score));
    EXPECT_TRUE(std::isfinite(x->fold_scores[0]));
    EXPECT_TRUE(std::isfinite(x->fold_scores[1]));
    EXPECT_TRUE(std::isfinite(x->error_after));
  }
  // The score pools both held-out folds: it lies between them.
  EXPECT_LE(offset.score, std::max(offset.fold_scores[0], offset.fold_scores[1]) * (1 + 1e-12));
  EXPECT_GE(offset.score, std::min(offset.fold_scores[0], offset.fold_scores[1]) * (1 - 1e-12));
  EXPECT_LT(offset.score, 0.1 * none.score);  // 8 % here
  EXPECT_TRUE(beats(offset, none, c.opt.significance));
  EXPECT_FALSE(beats(none, offset, c.opt.significance));
  EXPECT_LT(offset.error_after, 0.7 * start.error_before);

  // Settle: fitted again on the whole fit runs, the error over all runs is not larger, and it
  // passes the all-runs check.
  const CandidateScore settled = settle_winner(fitter, offset);
  // 0.00122 from 0.00127 here (0.0035 from 0.0044 when the windows started from a one-sided
  // measured state: the windows' fit is closer to the whole runs' now).
  EXPECT_LT(settled.error_after, offset.error_after);
  EXPECT_NE(settled.message.find("settled on the whole fit runs"), std::string::npos);
  EXPECT_EQ(settled.effect, EffectKind::kOffsetTorque);
  EXPECT_TRUE(improves_all_runs(settled, start.error_before, c.opt.significance));
  EXPECT_FALSE(improves_all_runs(settled, settled.error_after, c.opt.significance));
  // Without fit windows there is nothing to settle.
  DiagnoseOptions whole = c.opt;
  whole.fit_window_s = 0.0;
  CandidateFitter whole_fitter(c.runs, c.prepared, c.model, whole);
  EXPECT_EQ(settle_winner(whole_fitter, offset).error_after, offset.error_after);
}

TEST(DiagnoseStages, ACandidateTakesItsRefinedBreakpointsWhenItsFitIsBetterThere) {
  // A hidden deadzone of 7 mV (seed 15, pose 6): the search's breakpoint variant (the grid's,
  // chosen at unit factors) is not the one that predicts best once the coefficient factors are
  // fitted; the breakpoints refined locally at the search's point are (the plant's 2.2, 25, 250).
  Effects hidden;
  hidden.deadzone_v = 0.007;
  const auto d = test::one_pose_diagnose_runs(hidden, 15);
  DiagnoseOptions opt;
  opt.simulation = d->fit.simulation;
  const PreparedRuns prepared = prepare_runs(d->runs, opt);
  const RoundModel model = initial_model(d->runs, prepared);
  const Reidentifier reid(d->runs, opt.simulation.loop_period_s);
  ASSERT_TRUE(reid.usable());
  const RoundStart start = start_round(d->runs, prepared, model, reid, opt);
  CandidateFitter fitter(d->runs, prepared, model, opt);
  const CandidateSearch none_start = search_candidate(EffectKind::kNone, prepared, model, start, reid, opt);
  EXPECT_FALSE(none_start.refined_alpha.has_value());  // `none` is not searched
  const CandidateScore none = fitter.fit(EffectKind::kNone, none_start.effects, none_start.start_scales,
                                         none_start.alpha, false, true, nullptr);
  ASSERT_TRUE(none.ok) << none.message;
  fitter.set_none_training_rms(none.training_rms);
  fitter.set_none_error_after(none.error_after);
  const CandidateSearch s = search_candidate(EffectKind::kDeadzone, prepared, model, start, reid, opt);
  ASSERT_TRUE(s.searched);
  ASSERT_TRUE(s.alpha.has_value());
  ASSERT_TRUE(s.refined_alpha.has_value());
  EXPECT_NE(s.refined_alpha->alpha, s.alpha->alpha);
  PendingCrossValidation later, later_both;
  const CandidateScore grid = fitter.fit(EffectKind::kDeadzone, s.effects, prepared.unit_scales, s.alpha,
                                         true, false, &later);
  CandidateScore both = fitter.fit(EffectKind::kDeadzone, s.effects, prepared.unit_scales, s.alpha,
                                   true, false, &later_both, {}, s.refined_alpha);
  ASSERT_TRUE(grid.ok && both.ok) << grid.message << both.message;
  EXPECT_TRUE(grid.modelling_note.empty()) << grid.modelling_note;
  // At the grid's breakpoints the deadzone fits no better than `none` (0.00107 against 0.00092
  // here); at the refined ones the fit is taken, said so, and 38 % lower (0.00067).
  EXPECT_GT(grid.training_rms, none.training_rms);
  ASSERT_TRUE(both.alpha.has_value());
  EXPECT_EQ(both.alpha->alpha, s.refined_alpha->alpha);
  EXPECT_NE(both.modelling_note.find("α-model at its breakpoints refined locally"), std::string::npos)
      << both.modelling_note;
  EXPECT_LT(both.training_rms, 0.7 * grid.training_rms) << both.training_rms << " against " << grid.training_rms;
  // Cross-validated, it beats `none` by the significance in both folds (0.00060 against 0.00095
  // here), and settled on the whole fit runs the deadzone is within 20 % of the plant's (6.7 mV).
  ASSERT_FALSE(later_both.values.empty());
  fitter.cross_validate(both, later_both.blocks, later_both.values);
  EXPECT_TRUE(beats(both, none, opt.significance)) << both.score << " against " << none.score;
  const CandidateScore settled = settle_winner(fitter, both);
  EXPECT_NEAR(settled.effects.deadzone_v, 0.007, 0.2 * 0.007);
  // A second α-model that fits no better is not taken: the first given twice.
  const CandidateScore same = fitter.fit(EffectKind::kDeadzone, s.effects, prepared.unit_scales, s.alpha,
                                         true, false, &later, {}, s.alpha);
  EXPECT_TRUE(same.modelling_note.empty()) << same.modelling_note;
  EXPECT_EQ(same.training_rms, grid.training_rms);
}

/// A cross-validated candidate with score s in both folds.
CandidateScore scored(EffectKind kind, double s) {
  CandidateScore c;
  c.effect = kind;
  c.ok = true;
  c.score = s;
  c.fold_scores = {s, s};
  // Active amplitudes (0.1 V on runs whose largest |v| is 0.5 V): not set aside as inactive.
  c.effects.gravity_v = 0.1;
  c.effects.offset_v = 0.1;
  c.effects.cogging_v = 0.1;
  c.effects.coulomb_v = 0.1;
  return c;
}

/// What choose_winner() needs besides the candidates: one run with v = 0.5·sin(2π·t) (the
/// largest |v| is 0.5 V), the 1 ms loop, no re-identification.
struct ChooseSetup {
  DiagnoseOptions opt = [] {
    DiagnoseOptions o;
    o.simulation.loop_period_s = 0.001;
    return o;
  }();
  RunData a = sine_data(2.0, 0.5);
  std::vector<DiagnoseRun> runs = {run_of(a, "a", 2.0)};
  PreparedRuns p = prepare_runs(runs, opt);
  RoundModel m = initial_model(runs, p);
  CandidateFitter fitter{runs, p, m, opt};
  std::vector<DiagnoseRun> no_runs;
  Reidentifier reid{no_runs, 0.0};
};

TEST(DiagnoseStages, TheAllRunsReferenceIsTheLowestNoneOfTheRound) {
  // A winner must cut the RMS over all runs of the model as it was AND of every `none` the round
  // refitted: the lowest of them is the reference; effects and non-finite values do not count.
  DiagnoseRound rd;
  rd.error_before = 0.0526;
  CandidateScore none = scored(EffectKind::kNone, 0.0096);
  none.error_after = 0.0159;
  CandidateScore saturation = scored(EffectKind::kSaturation, 0.0053);
  saturation.error_after = 0.0100;  // an effect: not a reference
  rd.candidates = {none, saturation};
  EXPECT_DOUBLE_EQ(none_reference_rms(rd), 0.0159);
  CandidateScore twin = scored(EffectKind::kNone, 0.0097);
  twin.error_after = 0.0149;
  rd.none_at_winner_breakpoints = twin;
  EXPECT_DOUBLE_EQ(none_reference_rms(rd), 0.0149);
  CandidateScore gap = scored(EffectKind::kNone, 0.013);
  gap.error_after = std::numeric_limits<double>::quiet_NaN();
  rd.none_across_gap = gap;
  EXPECT_DOUBLE_EQ(none_reference_rms(rd), 0.0149);
  CandidateScore unfitted = scored(EffectKind::kNone, 0.01);
  unfitted.error_after = 0.0120;
  unfitted.ok = false;  // not fitted: not a reference
  rd.candidates.push_back(unfitted);
  EXPECT_DOUBLE_EQ(none_reference_rms(rd), 0.0149);
  // The 5.2 ms delay's case: saturation settled at 0.0197 cut the error before (0.0526) but not
  // that of `none` at its breakpoints (0.0149): not named.
  EXPECT_TRUE(improves_all_runs(0.0197, rd.error_before, 0.1));
  const std::string why = fails_all_runs(0.0197, rd, 0.1);
  EXPECT_NE(why.find("above that of none refitted, 0.0149"), std::string::npos) << why;
  // Not above the reference passes: the cross-validated score says the effect is significant
  // (a cogging of 0.008 V, seed 42: settled 0.001601 against none refitted 0.001648).
  EXPECT_EQ(fails_all_runs(0.0149, rd, 0.1), "");
  EXPECT_EQ(fails_all_runs(0.0140, rd, 0.1), "");
  // Not below the error before by significance/2: fails whatever the refits.
  DiagnoseRound close = rd;
  close.error_before = 0.0142;
  EXPECT_NE(fails_all_runs(0.0140, close, 0.1).find("not below (1 − significance/2) × 0.0142"),
            std::string::npos);
  // A pair's test is the first half alone (not_below_before()): the same message, and no refit.
  EXPECT_EQ(not_below_before(0.0197, 0.0526, 0.1), "");
  EXPECT_EQ(not_below_before(0.0140, 0.0142, 0.1),
            fails_all_runs(0.0140, close, 0.1));
  // Nothing refitted: the error before.
  DiagnoseRound bare;
  bare.error_before = 0.02;
  EXPECT_DOUBLE_EQ(none_reference_rms(bare), 0.02);
}

TEST(DiagnoseStages, AMemberKeptAloneFailingOnlyTheNoneRefitIsNamedOnTrial) {
  // The member a pair keeps alone (the other added nothing), settled alone over all runs.
  DiagnoseRound rd;
  rd.error_before = 0.04649;  // gravity + a 4 ms delay, seed 41, round 1
  CandidateScore none = scored(EffectKind::kNone, 0.01);
  none.error_after = 0.02483;  // `none` refitted
  rd.candidates = {none};
  // Below `none` refitted: named, not on trial (the on-trial permission changes nothing).
  for (bool allowed : {false, true}) {
    const KeptAloneVerdict v = judge_kept_alone(0.0240, rd, 0.1, allowed);
    EXPECT_TRUE(v.named);
    EXPECT_FALSE(v.on_trial);
    EXPECT_EQ(v.why, "");
  }
  // Coulomb friction kept alone from saturation + Coulomb: 0.0355, below the error before by
  // significance/2 but above `none` refitted. On trial when allowed, else vetoed; the same reason.
  const KeptAloneVerdict trial = judge_kept_alone(0.0355, rd, 0.1, true);
  EXPECT_TRUE(trial.named);
  EXPECT_TRUE(trial.on_trial);
  EXPECT_NE(trial.why.find("above that of none refitted, 0.02483"), std::string::npos) << trial.why;
  const KeptAloneVerdict vetoed = judge_kept_alone(0.0355, rd, 0.1, false);
  EXPECT_FALSE(vetoed.named);
  EXPECT_FALSE(vetoed.on_trial);
  EXPECT_EQ(vetoed.why, trial.why);
  // Not below the error before by significance/2 (0.95 × 0.04649 = 0.04417): never on trial.
  for (bool allowed : {false, true}) {
    const KeptAloneVerdict v = judge_kept_alone(0.0445, rd, 0.1, allowed);
    EXPECT_FALSE(v.named);
    EXPECT_FALSE(v.on_trial);
    EXPECT_NE(v.why.find("not below (1 − significance/2) × 0.04649"), std::string::npos) << v.why;
  }
  EXPECT_TRUE(judge_kept_alone(0.0441, rd, 0.1, true).on_trial);
}

TEST(DiagnoseStages, TheMedianRunRatioSkipsRunsWithoutBothAndNeedsThreeAndIsSaidInWords) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_DOUBLE_EQ(median_run_ratio({1.0, 3.0, 2.0}, {2.0, 2.0, 2.0}), 1.0);        // 0.5, 1.5, 1
  EXPECT_DOUBLE_EQ(median_run_ratio({1.0, 3.0, 2.0, 4.0}, {4.0, 4.0, 4.0, 4.0}), 0.625);  // (0.5 + 0.75)/2
  // A run without an RMS (not simulated) or with a zero before is not counted.
  EXPECT_DOUBLE_EQ(median_run_ratio({1.0, nan, 2.0, 3.0, 9.0, 4.0}, {1.0, 1.0, nan, 1.0, 0.0, 2.0}), 2.0);
  EXPECT_TRUE(std::isnan(median_run_ratio({1.0, 2.0}, {1.0, 1.0})));
  EXPECT_TRUE(std::isnan(median_run_ratio({1.0, 2.0, 3.0}, {1.0, nan, 1.0})));
  EXPECT_EQ(runs_better_in_words({1.0, 3.0, 2.0, 1.5}, {2.0, 2.0, 2.0, 2.0}),
            "better on 2 of 4 runs (median RMS ratio 0.875)");  // (0.75 + 1)/2; a tie is not better
  EXPECT_EQ(runs_better_in_words({1.0, 2.0}, {2.0, 2.0}), "");
}

TEST(DiagnoseStages, AWinnerFarBelowNoneInBothFoldsIsNamedByMostRunsWhenOneRunOutweighsThem) {
  // Cogging of seed 45 (--vary; plant 0.0228 V, period 0.01538 rad), round 1: the nine sine runs
  // and the square run, RMS before and with the cogging settled (its steps settle in other wells).
  DiagnoseRound rd;
  rd.error_before = 0.003507;
  rd.run_error_before = {0.002526, 0.001512, 0.002207, 0.002396, 0.003166,
                         0.001968, 0.004493, 0.0029,   0.005258, 0.005316};
  CandidateScore none = scored(EffectKind::kNone, 0.002595);
  none.fold_scores = {0.002641, 0.002549};
  none.error_after = 0.003315;
  rd.candidates = {none};
  CandidateScore at_breakpoints = scored(EffectKind::kNone, 0.002643);
  at_breakpoints.fold_scores = {0.002645, 0.002642};
  at_breakpoints.error_after = 0.0032;
  rd.none_at_winner_breakpoints = at_breakpoints;
  CandidateScore cogging = scored(EffectKind::kCogging, 0.0006753);
  cogging.fold_scores = {0.0007133, 0.0006351};
  cogging.error_after = 0.003714;
  cogging.run_error_after = {0.0004866, 0.0005107, 0.0007201, 0.002008, 0.0006746,
                             0.0005661, 0.0002966, 0.0009703, 0.008959, 0.006446};
  // The pooled test refuses it (0.003714 against 0.95 × 0.003507) ...
  EXPECT_NE(fails_all_runs(cogging.error_after, rd, 0.1), "");
  // ... run by run it is below before on 8 of 10 (median ratio (0.3263 + 0.3346)/2 = 0.3305).
  std::optional<std::string> note = named_by_most_runs(cogging, rd, 0.1);
  ASSERT_TRUE(note.has_value());
  EXPECT_NE(note->find("over all runs better on 8 of 10 runs (median RMS ratio 0.33)"), std::string::npos)
      << *note;
  // No per-run RMS of the refits: only the error before is compared.
  EXPECT_EQ(note->find("to none refitted"), std::string::npos) << *note;
  // A `none` refit with per-run RMS: the winner must be at least as good in most runs.
  CandidateScore refit = at_breakpoints;
  refit.run_error_after = cogging.run_error_after;
  for (std::size_t i = 0; i < 6; ++i) refit.run_error_after[i] *= 0.9;  // 6 of 10 below the winner
  rd.none_at_winner_breakpoints = refit;
  EXPECT_FALSE(named_by_most_runs(cogging, rd, 0.1).has_value());
  for (std::size_t i = 0; i < 6; ++i) refit.run_error_after[i] /= 0.8;  // now 6 of 10 above it
  rd.none_at_winner_breakpoints = refit;
  note = named_by_most_runs(cogging, rd, 0.1);
  ASSERT_TRUE(note.has_value());
  EXPECT_NE(note->find("the median ratio at most 0.889 to none refitted"), std::string::npos) << *note;  // 0.8/0.9
  rd.none_at_winner_breakpoints = at_breakpoints;
  // Not far below `none` in one fold (0.6 × 0.002549 > kFarBelowNone × it): the pooled test holds.
  CandidateScore near = cogging;
  near.fold_scores[1] = 0.6 * 0.002549;
  EXPECT_FALSE(named_by_most_runs(near, rd, 0.1).has_value());
  // Far below in the folds but the median run not below 0.95 × before (4 runs at half, 6 at
  // 0.96): refused; with 6 at half it passes.
  CandidateScore flat = cogging;
  for (std::size_t i = 0; i < flat.run_error_after.size(); ++i)
    flat.run_error_after[i] = (i < 4 ? 0.5 : 0.96) * rd.run_error_before[i];
  EXPECT_FALSE(named_by_most_runs(flat, rd, 0.1).has_value());
  for (std::size_t i = 4; i < 6; ++i) flat.run_error_after[i] = 0.5 * rd.run_error_before[i];
  EXPECT_TRUE(named_by_most_runs(flat, rd, 0.1).has_value());  // median (0.5 + 0.96)/2 = 0.73
  // Without per-run RMS (a member kept alone from a pair): the pooled test only.
  CandidateScore pooled_only = cogging;
  pooled_only.run_error_after.clear();
  EXPECT_FALSE(named_by_most_runs(pooled_only, rd, 0.1).has_value());
}

TEST(DiagnoseStages, ChooseTakesTheSimplerWithinFivePercentAndRefusesASubTickDelay) {
  // Hand-built candidates without α-models: choose_winner() fits nothing then.
  const ChooseSetup setup;
  [[maybe_unused]] const DiagnoseOptions& opt = setup.opt;
  const CandidateFitter& fitter = setup.fitter;
  const Reidentifier& reid = setup.reid;
  [[maybe_unused]] const PreparedRuns& p = setup.p;

  DiagnoseRound rd;
  rd.candidates = {scored(EffectKind::kNone, 1.0), scored(EffectKind::kGravity, 0.50),
                   scored(EffectKind::kOffsetTorque, 0.52), scored(EffectKind::kCogging, 0.40)};
  rd.candidates[3].cross_validated = false;  // pruned: its training RMS, not a score
  Choice ch = choose_winner(fitter, reid, rd);
  ASSERT_TRUE(ch.none_fitted);
  ASSERT_TRUE(ch.winner.has_value());
  EXPECT_EQ(rd.candidates[*ch.winner].effect, EffectKind::kOffsetTorque);  // 1 parameter, +4 %
  EXPECT_TRUE(ch.named);
  EXPECT_FALSE(rd.none_at_winner_breakpoints.has_value());

  rd.candidates[2].score = 0.53;  // +6 %: the better one stays
  ch = choose_winner(fitter, reid, rd);
  EXPECT_EQ(rd.candidates[*ch.winner].effect, EffectKind::kGravity);
  EXPECT_TRUE(ch.named);

  rd.candidates[1].fold_scores[1] = 0.95;  // not 10 % below `none` in fold 2
  ch = choose_winner(fitter, reid, rd);
  EXPECT_EQ(rd.candidates[*ch.winner].effect, EffectKind::kGravity);
  EXPECT_FALSE(ch.named);

  // A delay of half a tick wins but is not named; one of two ticks is.
  DiagnoseRound d;
  d.candidates = {scored(EffectKind::kNone, 1.0), scored(EffectKind::kTimeDelay, 0.5)};
  d.candidates[1].effects.delay_s = 0.0005;
  ch = choose_winner(fitter, reid, d);
  EXPECT_EQ(d.candidates[*ch.winner].effect, EffectKind::kTimeDelay);
  EXPECT_FALSE(ch.named);
  EXPECT_TRUE(delay_below_one_tick(d.candidates[1], opt.simulation));
  d.candidates[1].effects.delay_s = 0.002;
  EXPECT_TRUE(choose_winner(fitter, reid, d).named);

  // `none` not fitted: the round fails.
  d.candidates[0].ok = false;
  EXPECT_FALSE(choose_winner(fitter, reid, d).none_fitted);
}

TEST(DiagnoseStages, TheRunnerUpIsTheNextLowestScoreUnderTheWinnersGuards) {
  // Hand-built candidates without α-models (no twin is fitted): the runner-up of a winner that
  // was not named is the next lowest cross-validated, active effect, held to the same guards.
  const ChooseSetup setup;
  const CandidateFitter& fitter = setup.fitter;
  const Reidentifier& reid = setup.reid;
  DiagnoseRound rd;
  rd.candidates = {scored(EffectKind::kNone, 1.0), scored(EffectKind::kTimeDelay, 0.40),
                   scored(EffectKind::kStribeckFriction, 0.45), scored(EffectKind::kGravity, 0.60),
                   scored(EffectKind::kCogging, 0.30)};
  rd.candidates[1].effects.delay_s = 0.004;
  rd.candidates[2].effects.stribeck_coulomb_v = 0.02;  // with its breakaway hump: active
  rd.candidates[2].effects.stribeck_breakaway_v = 0.05;
  rd.candidates[4].cross_validated = false;  // pruned: not a runner-up however low
  const Choice first = choose_winner(fitter, reid, rd);
  ASSERT_TRUE(first.winner.has_value());
  EXPECT_EQ(rd.candidates[*first.winner].effect, EffectKind::kTimeDelay);
  Choice ch = choose_runner_up(fitter, reid, rd, *first.winner);
  ASSERT_TRUE(ch.winner.has_value());
  EXPECT_EQ(rd.candidates[*ch.winner].effect, EffectKind::kStribeckFriction);
  EXPECT_TRUE(ch.named);
  EXPECT_FALSE(rd.none_at_runner_up_breakpoints.has_value());
  // Held to the guards: not 10 % below `none` in fold 1 (0.91 against 1.0) → not named.
  rd.candidates[2].fold_scores[0] = 0.91;
  ch = choose_runner_up(fitter, reid, rd, *first.winner);
  EXPECT_EQ(rd.candidates[*ch.winner].effect, EffectKind::kStribeckFriction);
  EXPECT_FALSE(ch.named);
  // Set aside as inactive: the next one (gravity, 0.60) is the runner-up.
  rd.candidates[2].inactive = "no breakaway hump";
  ch = choose_runner_up(fitter, reid, rd, *first.winner);
  EXPECT_EQ(rd.candidates[*ch.winner].effect, EffectKind::kGravity);
  EXPECT_TRUE(ch.named);
  // A winner that is `none`: nothing beat it, no runner-up.
  DiagnoseRound n;
  n.candidates = {scored(EffectKind::kNone, 0.5), scored(EffectKind::kGravity, 0.6)};
  const Choice none_won = choose_winner(fitter, reid, n);
  ASSERT_TRUE(none_won.winner.has_value());
  EXPECT_EQ(n.candidates[*none_won.winner].effect, EffectKind::kNone);
  EXPECT_FALSE(choose_runner_up(fitter, reid, n, *none_won.winner).winner.has_value());
  // The runner-up's twin counts in the all-runs reference.
  CandidateScore twin = scored(EffectKind::kNone, 0.5);
  twin.error_after = 0.0017;
  rd.error_before = 0.0020;
  rd.none_at_runner_up_breakpoints = twin;
  EXPECT_DOUBLE_EQ(none_reference_rms(rd), 0.0017);
}

TEST(DiagnoseStages, ChooseSetsAsideAnEffectInactiveOnTheData) {
  // Runs with v = 0.5·sin(2π·t): the largest |v| is 0.5 V.
  const ChooseSetup setup;
  [[maybe_unused]] const DiagnoseOptions& opt = setup.opt;
  const CandidateFitter& fitter = setup.fitter;
  const Reidentifier& reid = setup.reid;
  [[maybe_unused]] const PreparedRuns& p = setup.p;
  const double largest_v = largest_abs_command_v(p);
  EXPECT_NEAR(largest_v, 0.5, 1e-12);

  // A saturation at 1.3 V (never reached) has the lowest score (0.49, one parameter); a deadzone
  // of half-width 1e-5 V (< 1e-3 × 0.5 V) is within 5 % of gravity's 0.50 with one parameter
  // fewer: either would win by score or parsimony if not set aside. Gravity (0.1 V) wins.
  DiagnoseRound rd;
  rd.candidates = {scored(EffectKind::kNone, 1.0), scored(EffectKind::kGravity, 0.50),
                   scored(EffectKind::kSaturation, 0.49), scored(EffectKind::kDeadzone, 0.51)};
  rd.candidates[2].effects.saturation_v = 1.3;
  rd.candidates[3].effects.deadzone_v = 1e-5;
  ASSERT_LT(effect_parameters(EffectKind::kDeadzone).size(),
            effect_parameters(EffectKind::kGravity).size());
  EXPECT_EQ(inactive_reason(rd.candidates[2], largest_v),
            "saturation level 1.3 V above the largest |v| 0.5 V: never reached");
  EXPECT_EQ(inactive_reason(rd.candidates[3], largest_v),
            "deadzone half-width 1e-05 V below 0.001 × the largest |v| 0.5 V: no effect on θ");
  EXPECT_EQ(inactive_reason(rd.candidates[1], largest_v), "");  // gravity 0.1 V: active
  EXPECT_EQ(inactive_reason(rd.candidates[0], largest_v), "");  // none: never set aside
  Choice ch = choose_winner(fitter, reid, rd);
  ASSERT_TRUE(ch.winner.has_value());
  EXPECT_EQ(rd.candidates[*ch.winner].effect, EffectKind::kGravity);
  EXPECT_TRUE(ch.named);
  EXPECT_EQ(rd.candidates[2].inactive,
            "saturation level 1.3 V above the largest |v| 0.5 V: never reached");
  EXPECT_FALSE(rd.candidates[2].cross_validated);
  EXPECT_FALSE(rd.candidates[3].inactive.empty());
  EXPECT_FALSE(rd.candidates[3].cross_validated);
  EXPECT_TRUE(rd.candidates[1].inactive.empty());

  // A saturation at 0.4 V (below 0.5 V) is reached: active, and it wins with one parameter.
  DiagnoseRound reached;
  reached.candidates = {scored(EffectKind::kNone, 1.0), scored(EffectKind::kGravity, 0.50),
                        scored(EffectKind::kSaturation, 0.49)};
  reached.candidates[2].effects.saturation_v = 0.4;
  ch = choose_winner(fitter, reid, reached);
  EXPECT_EQ(reached.candidates[*ch.winner].effect, EffectKind::kSaturation);
  EXPECT_TRUE(reached.candidates[2].inactive.empty());

  // Only a gravity of ~0 amplitude beats `none`: set aside, `none` wins and nothing is named.
  DiagnoseRound only;
  only.candidates = {scored(EffectKind::kNone, 1.0), scored(EffectKind::kGravity, 0.5)};
  only.candidates[1].effects.gravity_v = 2e-4;  // < 5e-4 V
  ch = choose_winner(fitter, reid, only);
  ASSERT_TRUE(ch.winner.has_value());
  EXPECT_EQ(only.candidates[*ch.winner].effect, EffectKind::kNone);
  EXPECT_FALSE(ch.named);
  EXPECT_EQ(only.candidates[1].inactive,
            "gravity amplitude 0.0002 V below 0.001 × the largest |v| 0.5 V: no effect on θ");
}

TEST(DiagnoseStages, ChooseSetsAsideAStribeckFrictionWithoutItsBreakawayHump) {
  const ChooseSetup setup;
  [[maybe_unused]] const DiagnoseOptions& opt = setup.opt;
  const CandidateFitter& fitter = setup.fitter;
  const Reidentifier& reid = setup.reid;
  [[maybe_unused]] const PreparedRuns& p = setup.p;
  const double largest_v = largest_abs_command_v(p);

  // Stribeck 15 % better than Coulomb (beyond the 5 % parsimony band), but fitted with the
  // breakaway below the sliding level (the bundled data's case: Fs 0.0052, Fc 0.0082 V): friction
  // that falls at low speed is not Stribeck's form. It is set aside and Coulomb friction wins.
  DiagnoseRound rd;
  rd.candidates = {scored(EffectKind::kNone, 1.0), scored(EffectKind::kCoulombFriction, 0.60),
                   scored(EffectKind::kStribeckFriction, 0.51)};
  rd.candidates[2].effects.stribeck_coulomb_v = 0.0082;
  rd.candidates[2].effects.stribeck_breakaway_v = 0.0052;
  EXPECT_EQ(inactive_reason(rd.candidates[2], largest_v),
            "breakaway level Fs 0.0052 V not above the Coulomb level Fc 0.0082 V: no breakaway "
            "hump, not Stribeck friction");
  Choice ch = choose_winner(fitter, reid, rd);
  ASSERT_TRUE(ch.winner.has_value());
  EXPECT_EQ(rd.candidates[*ch.winner].effect, EffectKind::kCoulombFriction);
  EXPECT_TRUE(ch.named);
  EXPECT_FALSE(rd.candidates[2].cross_validated);
  EXPECT_EQ(rd.candidates[2].message.rfind("set aside: breakaway level", 0), 0u)
      << rd.candidates[2].message;

  // With its hump (Fs 2.5 × Fc) the same scores name Stribeck friction.
  DiagnoseRound hump;
  hump.candidates = {scored(EffectKind::kNone, 1.0), scored(EffectKind::kCoulombFriction, 0.60),
                     scored(EffectKind::kStribeckFriction, 0.51)};
  hump.candidates[2].effects.stribeck_coulomb_v = 0.01;
  hump.candidates[2].effects.stribeck_breakaway_v = 0.025;
  EXPECT_EQ(inactive_reason(hump.candidates[2], largest_v), "");
  ch = choose_winner(fitter, reid, hump);
  ASSERT_TRUE(ch.winner.has_value());
  EXPECT_EQ(hump.candidates[*ch.winner].effect, EffectKind::kStribeckFriction);
}

/// The sweep's one-pose dataset (seed 6) with omni_gen's ±0.05 V pulses (0.1 s every 1 s), its
/// disturbance_v column kept (`recorded`) or left out.
struct PulseCase {
  GeneratedDataset g;
  GeneratedDataset truth;  ///< the same with the column: the pulses' times
  DatasetFit fit;
  std::vector<DiagnoseRun> runs;
  DiagnoseOptions opt;
};

/// The 10-run dataset of `seed` at one pose (seed % 9), the bundled Coulomb friction off, with
/// ±`pulse_v` pulses (0: none) and encoder noise `noise_rad` (negative: the plan's), fitted.
PulseCase pulse_case(bool recorded, std::uint64_t seed = 6, double pulse_v = 0.05,
                     double noise_rad = -1.0) {
  PulseCase c;
  ExperimentPlanOptions plan = paper_plan_options(seed);
  plan.plant.effects.coulomb_v = 0.0;
  plan.disturbance_pulses.amplitude_v = pulse_v;
  if (noise_rad >= 0.0) plan.plant.measurement.noise_std_rad = noise_rad;
  const auto poses = paper_sine_poses();
  plan.sine_poses = {poses[seed % poses.size()]};
  plan.square_poses = plan.sine_poses;
  c.truth = generate_dataset(make_experiment_plan(plan));
  c.g = c.truth;
  if (!recorded) {
    for (RunData& r : c.g.runs) r.extra_columns.erase("disturbance_v");
  }
  FitPipelineOptions fo;
  fo.run_validation = false;
  c.fit = fit_dataset(c.g.index, c.g.runs, fo);
  c.runs = diagnose_runs(c.g.index, c.g.runs, c.fit);
  c.opt.simulation = c.fit.simulation;
  return c;
}

TEST(DiagnoseStages, ExternalDisturbanceLocatesUnrecordedPulsesInTime) {
  const PulseCase c = pulse_case(false);
  const PreparedRuns prepared = prepare_runs(c.runs, c.opt);
  const DisturbanceFinding f =
      locate_external_disturbance(c.runs, initial_model(c.runs, prepared), c.opt);
  ASSERT_TRUE(f.tried);
  EXPECT_TRUE(f.named) << f.message;
  EXPECT_LT(f.error_after, 0.9 * f.error_before) << f.message;
  EXPECT_LT(f.touched_after, 0.9 * f.touched_before) << f.message;
  for (bool r : f.recorded) EXPECT_FALSE(r);
  // The pulses of the truth after the runs' first second: most have an interval starting within
  // 10 ms (not those within 0.5 s after a square run's jumps, which are left out), with its
  // level within 25 % of the pulse's.
  std::size_t pulses = 0, found = 0, level_ok = 0;
  for (std::size_t i = 0; i < c.truth.runs.size(); ++i) {
    const RunData& d = c.truth.runs[i];
    const std::vector<double>& col = *d.column("disturbance_v");
    for (std::size_t k = 1; k < d.size(); ++k) {
      if (col[k] == 0.0 || col[k - 1] != 0.0 || d.t[k] < 1.0) continue;
      ++pulses;
      for (const DisturbanceInterval& iv : f.runs[i].intervals) {
        if (std::abs(iv.start_s - d.t[k]) < 0.01) {
          ++found;
          level_ok += std::abs(iv.level_v / col[k] - 1.0) < 0.25;
        }
      }
    }
  }
  ASSERT_GT(pulses, 20u);
  // Measured at the merge of #15's first disturbance stage: 29 of 52 (56 %) — the pulses within
  // 0.5 s after a square run's jumps are among the truth's but left out by the locator, and short
  // pulses on the sines' reversals are missed; the floor below catches a locator that stops
  // finding them, and is to rise as the stage does (docs/diagnose.md). 35 of 52 (34 levels
  // within 25 %, 43 intervals) before n̂ took C, β̃ at the recorded command's α (2026-12-07), 34
  // (32, 41) after.
  EXPECT_GE(found, pulses / 2) << found << " of " << pulses;
  EXPECT_GE(level_ok, found * 8 / 10) << level_ok << " of " << found;
  // Not many intervals where there is no pulse.
  EXPECT_LE(f.intervals, pulses + pulses / 5);
}

TEST(DiagnoseStages, TheDisturbanceIsJudgedOnTheRunsItTouches) {
  // Three runs of 1001 samples: θ − θ_sim = 0.01, 0.02 and 0.1 (the last a run d̂ does not
  // touch, e.g. one near a resonance whose pulses were not located). Over all runs the RMS is
  // sqrt((1e-4 + 4e-4 + 1e-2)/3); over the two with intervals sqrt((1e-4 + 4e-4)/2).
  const RunData a = sine_data(1.0, 0.5), b = sine_data(1.0, 0.5), c = sine_data(1.0, 0.5);
  const std::vector<DiagnoseRun> runs = {run_of(a, "a", 2.0), run_of(b, "b", 2.0), run_of(c, "c", 2.0)};
  std::vector<std::vector<double>> sims;
  for (double e : {0.01, 0.02, 0.1}) {
    sims.push_back(a.theta);
    for (double& x : sims.back()) x -= e;
  }
  EXPECT_NEAR(error_over_runs(runs, sims), std::sqrt((1e-4 + 4e-4 + 1e-2) / 3.0), 1e-12);
  DisturbanceFinding f;
  f.runs.resize(3);
  f.runs[0].intervals.push_back({0.2, 0.3, 0.01, 8.0});
  f.runs[1].intervals.push_back({0.5, 0.6, -0.01, 8.0});
  EXPECT_NEAR(error_over_runs(runs, sims, &f), std::sqrt((1e-4 + 4e-4) / 2.0), 1e-12);
  // Significant on the runs it touches when they are two or more and at least half (2 of 3 here:
  // −10 % there, −1 % over all).
  f.touched_before = 0.02, f.touched_after = 0.0179;
  f.error_before = 0.06, f.error_after = 0.0594;
  EXPECT_TRUE(disturbance_significant(f, 0.10));
  f.touched_after = 0.0181;
  EXPECT_FALSE(disturbance_significant(f, 0.10));
  // One run touched: over all runs.
  f.runs[1].intervals.clear();
  f.touched_after = 0.01;
  EXPECT_FALSE(disturbance_significant(f, 0.10));
  f.error_after = 0.0539;
  EXPECT_TRUE(disturbance_significant(f, 0.10));
  f.runs[1].intervals.push_back({0.5, 0.6, -0.01, 8.0});
  // A failed simulation of a touched run: NaN; of an untouched one: not counted.
  sims[2].clear();
  EXPECT_NEAR(error_over_runs(runs, sims, &f), std::sqrt((1e-4 + 4e-4) / 2.0), 1e-12);
  EXPECT_TRUE(std::isnan(error_over_runs(runs, sims)));
  sims[0].clear();
  EXPECT_TRUE(std::isnan(error_over_runs(runs, sims, &f)));
}

TEST(DiagnoseStages, ExternalDisturbanceRecordedIsKnownAndNothingIsLeftToLocate) {
  const PulseCase c = pulse_case(true);
  const PreparedRuns prepared = prepare_runs(c.runs, c.opt);
  const DisturbanceFinding f =
      locate_external_disturbance(c.runs, initial_model(c.runs, prepared), c.opt);
  for (bool r : f.recorded) EXPECT_TRUE(r);
  EXPECT_FALSE(f.named) << f.message;
}

TEST(DiagnoseStages, ExternalDisturbanceIsNotTheStartTransientRunningOn) {
  // Effect-free data (seed 1031, pose 5, 5e-5 rad noise: the effect-free case of the sweep's seed
  // 31 that named external_disturbance): the 2.5 Hz sine run's start transient still stood out
  // at t = 1.00-1.10 and 1.15-1.30 s, just after the second the locator leaves out, and cut the
  // error by 14 %. An interval that begins where a left-out span ends is that span's tail.
  const PulseCase c = pulse_case(false, 1031, 0.0, 5e-5);
  const PreparedRuns prepared = prepare_runs(c.runs, c.opt);
  const DisturbanceFinding f =
      locate_external_disturbance(c.runs, initial_model(c.runs, prepared), c.opt);
  ASSERT_TRUE(f.tried);
  EXPECT_FALSE(f.named) << f.message;
  for (const DisturbanceEstimate& r : f.runs) {
    for (const DisturbanceInterval& iv : r.intervals) {
      EXPECT_FALSE(iv.start_s >= 1.0 && iv.start_s < 1.1) << iv.start_s;
    }
  }
}

TEST(DiagnoseStages, FitWindowsAndFoldsKeepTheRunsKnownInputs) {
  // A recorded disturbance_v: the fit windows (the runs' last fit_window_s) and the folds' halves
  // are the run's rows with it, so the candidates are fitted with the pulses known (before, the
  // windows had t, r, θ, v only: a free fall or a known pulse was simulated as if absent).
  const PulseCase c = pulse_case(true);
  const PreparedRuns p = prepare_runs(c.runs, c.opt);
  ASSERT_FALSE(p.fit_runs.empty());
  std::size_t checked = 0;
  for (std::size_t i : p.fit_runs) {
    const RunData& whole = *c.runs[i].data;
    const RunData& w = *p.runs[i].data;
    ASSERT_LT(w.size(), whole.size());
    const std::vector<double>* dw = w.column("disturbance_v");
    ASSERT_NE(dw, nullptr);
    ASSERT_EQ(dw->size(), w.size());
    const std::size_t k0 = whole.size() - w.size();
    for (std::size_t k = 0; k < w.size(); ++k) {
      ASSERT_EQ(w.t[k], whole.t[k0 + k]);
      ASSERT_EQ((*dw)[k], (*whole.column("disturbance_v"))[k0 + k]);
    }
    ++checked;
  }
  EXPECT_EQ(checked, p.fit_runs.size());
  for (const auto& fold : p.folds) {
    for (std::size_t j : fold) {
      const std::vector<double>* d = p.runs[j].data->column("disturbance_v");
      ASSERT_NE(d, nullptr);
      EXPECT_EQ(d->size(), p.runs[j].data->size());
    }
  }
}

// The pair fallback on effect-free data (a generated 10-run dataset, seed 25): run on purpose
// (the verdict there is "explained", where diagnose() would not try it), it fits pairs of the
// round's eligible candidates when there are two, and names none of them.
TEST(DiagnoseStages, PairFallbackNamesNoPairOnEffectFreeData) {
  const GeneratedDataset g = test::one_pose_dataset(Effects{}, 25);
  const DatasetFit fit = fit_dataset(g.index, g.runs);
  ASSERT_TRUE(fit.usable());
  const std::vector<DiagnoseRun> runs = diagnose_runs(g.index, g.runs, fit);
  DiagnoseOptions opt;
  opt.simulation = fit.simulation;
  opt.candidates = {EffectKind::kNone, EffectKind::kOffsetTorque, EffectKind::kGravity,
                    EffectKind::kTimeDelay, EffectKind::kDeadzone};
  const PreparedRuns prepared = prepare_runs(runs, opt);
  const RoundModel model = initial_model(runs, prepared);
  const Reidentifier reid(runs, opt.simulation.loop_period_s, opt.threads);
  ASSERT_TRUE(reid.usable());
  CandidateScore settled;
  std::string failure;
  const DiagnoseRound rd = diagnose_round(runs, prepared, model, reid, opt.candidates, opt,
                                          &settled, &failure, true);
  ASSERT_TRUE(failure.empty()) << failure;
  EXPECT_EQ(rd.named, EffectKind::kNone);
  EXPECT_EQ(rd.named_second, EffectKind::kNone);
  EXPECT_DOUBLE_EQ(rd.error_after, rd.error_before);  // the model is left as it was
  // Tried whenever two candidates can be paired from the pool (fitted, active: on effect-free
  // data the fitted levels are often below kInactiveRelativeLevel and set aside) or two scanned
  // effects searched together from nothing: gravity, the delay and the deadzone here, whatever
  // their single fits gave (the offset's scan has two points).
  std::string table;
  std::size_t afresh_kinds = 0;
  for (const CandidateScore& c : rd.candidates) {
    afresh_kinds += pair_afresh_kind(c.effect, model) && c.effect != EffectKind::kOffsetTorque;
    table += std::string(effect_name(c.effect)) + ": " + c.message + "\n";
  }
  EXPECT_EQ(afresh_kinds, 3u) << table;
  EXPECT_FALSE(rd.pairs.empty()) << table;
  EXPECT_LE(rd.pairs.size(), kMaxPairFits);
  for (const PairScore& p : rd.pairs) {
    EXPECT_FALSE(p.named);
    EXPECT_NE(p.kinds[0], p.kinds[1]);
    EXPECT_NE(p.kinds[0], EffectKind::kNone);
    EXPECT_FALSE(p.fit.message.empty());  // why it was not named
  }
}

// A Stribeck friction named on top of the Coulomb level of an earlier round takes it in: the
// level goes into its Fc and Fs, coulomb_friction leaves the model's torque (the same torque);
// an offset torque, which it does not generalise, stays.
TEST(DiagnoseStages, AGeneralisationTakesInTheCoulombLevelOfAnEarlierRound) {
  Effects e;
  e.coulomb_v = 0.012, e.offset_v = 0.003;
  e.coulomb_smoothing_rad_s = e.stribeck_smoothing_rad_s = 0.014;
  e.stribeck_coulomb_v = 0.002, e.stribeck_breakaway_v = 0.025, e.stribeck_velocity_rad_s = 0.3;
  const Effects before = e;
  const std::vector<EffectKind> named = {EffectKind::kOffsetTorque, EffectKind::kCoulombFriction,
                                         EffectKind::kStribeckFriction};
  const std::optional<EffectKind> x = take_in_parent(EffectKind::kStribeckFriction, e, named);
  ASSERT_TRUE(x.has_value());
  EXPECT_EQ(*x, EffectKind::kCoulombFriction);
  EXPECT_EQ(e.coulomb_v, 0.0);
  EXPECT_DOUBLE_EQ(e.stribeck_coulomb_v, 0.014);
  EXPECT_DOUBLE_EQ(e.stribeck_breakaway_v, 0.037);
  EXPECT_EQ(e.stribeck_velocity_rad_s, 0.3);
  EXPECT_EQ(e.offset_v, 0.003);
  for (double w : {-0.9, -0.01, 0.0, 0.005, 0.2, 1.4})
    EXPECT_NEAR(effect_torque(e, 0.01, w), effect_torque(before, 0.01, w), 1e-15) << w;
  // Nothing to take in: an effect that generalises nothing named, or no generalisation at all.
  Effects f = before;
  EXPECT_FALSE(take_in_parent(EffectKind::kStribeckFriction, f, {EffectKind::kOffsetTorque}));
  EXPECT_FALSE(take_in_parent(EffectKind::kAsymmetricFriction, f, {EffectKind::kOffsetTorque}));
  EXPECT_FALSE(take_in_parent(EffectKind::kGravity, f, named));
  EXPECT_EQ(f.coulomb_v, before.coulomb_v);
}

// The parent of a generalisation (try_refinements(), and the generalisation settled against
// it in a round): the lowest scored of the effects it generalises that were fitted and
// cross-validated. Asymmetric friction generalises Coulomb friction and the offset.
TEST(DiagnoseStages, TheBestParentIsTheLowestScoredCrossValidatedEffectItGeneralises) {
  std::vector<CandidateScore> c = {scored(EffectKind::kNone, 1.0), scored(EffectKind::kCoulombFriction, 0.5),
                                   scored(EffectKind::kOffsetTorque, 0.4), scored(EffectKind::kGravity, 0.1),
                                   scored(EffectKind::kAsymmetricFriction, 0.3)};
  for (CandidateScore& x : c) x.cross_validated = true;
  EXPECT_EQ(best_parent(EffectKind::kAsymmetricFriction, c), 2u);  // the offset, 0.4
  EXPECT_EQ(best_parent(EffectKind::kStribeckFriction, c), 1u);    // Coulomb friction only
  c[2].cross_validated = false;                                    // not scored: not a parent
  EXPECT_EQ(best_parent(EffectKind::kAsymmetricFriction, c), 1u);
  c[1].ok = false;  // not fitted
  EXPECT_EQ(best_parent(EffectKind::kStribeckFriction, c), c.size());
  EXPECT_EQ(best_parent(EffectKind::kGravity, c), c.size());  // generalises nothing
}

// A generalisation earns its extra parameters over its parent (try_refinements()): below
// (1 − significance/2) × the parent in its score and both folds, or not worse in either fold and
// that much below it over all runs. The numbers are two Stribeck frictions' round-1 fits against
// the Coulomb friction they generalise (seeds 44 and 45 of the --vary sweep, 2026-12-07).
TEST(DiagnoseStages, AGeneralisationEarnsItsPlaceInBothFoldsOrNotWorseInThemAndOverAllRuns) {
  const auto fit = [](double score, double f1, double f2, double all) {
    CandidateScore c = scored(EffectKind::kStribeckFriction, score);
    c.cross_validated = true;
    c.fold_scores = {f1, f2};
    c.error_after = all;
    return c;
  };
  // Seed 44: fold 1 only 4.7 % below (5 % asked), 8.2 % below over all runs.
  CandidateScore coulomb = fit(0.001789, 0.001895, 0.001676, 0.002253);
  coulomb.effect = EffectKind::kCoulombFriction;
  EXPECT_FALSE(beats(fit(0.001638, 0.001806, 0.00145, 0.002069), coulomb, 0.05));
  EXPECT_TRUE(earns_its_place(fit(0.001638, 0.001806, 0.00145, 0.002069), coulomb, 0.10));
  // … but not when over all runs it is only 3 % below, nor when a fold is worse.
  EXPECT_FALSE(earns_its_place(fit(0.001638, 0.001806, 0.00145, 0.002185), coulomb, 0.10));
  EXPECT_FALSE(earns_its_place(fit(0.001638, 0.0019, 0.00145, 0.002069), coulomb, 0.10));
  // Seed 45: 11 % below in its score, but fold 1 worse and worse over all runs.
  CandidateScore coulomb45 = fit(0.001369, 0.001392, 0.001345, 0.001825);
  EXPECT_FALSE(earns_its_place(fit(0.001222, 0.001485, 0.0008844, 0.002036), coulomb45, 0.10));
  // Both folds 5 % below: earned whatever the RMS over all runs.
  EXPECT_TRUE(earns_its_place(fit(0.0016, 0.0017, 0.0015, 0.003), coulomb, 0.10));
}

// Sibling forms: two generalisations of one effect (the three friction forms of Coulomb
// friction); not a generalisation and its parent, not an effect and itself, not two effects that
// generalise nothing.
TEST(DiagnoseStages, SiblingFormsGeneraliseTheSameEffect) {
  EXPECT_TRUE(is_sibling_form(EffectKind::kStribeckFriction, EffectKind::kAsymmetricFriction));
  EXPECT_TRUE(is_sibling_form(EffectKind::kAsymmetricFriction, EffectKind::kStribeckFriction));
  EXPECT_TRUE(is_sibling_form(EffectKind::kPositionDependentFriction, EffectKind::kStribeckFriction));
  EXPECT_FALSE(is_sibling_form(EffectKind::kStribeckFriction, EffectKind::kStribeckFriction));
  EXPECT_FALSE(is_sibling_form(EffectKind::kStribeckFriction, EffectKind::kCoulombFriction));
  EXPECT_FALSE(is_sibling_form(EffectKind::kCoulombFriction, EffectKind::kStribeckFriction));
  EXPECT_FALSE(is_sibling_form(EffectKind::kGravity, EffectKind::kOffsetTorque));
  EXPECT_FALSE(is_sibling_form(EffectKind::kNone, EffectKind::kNone));
}

// A friction form's smoothing ε is a modelling choice the data may sharpen
// (CandidateFitter::fit_joint()): Coulomb friction generated switching within 0.001 rad/s is
// fitted at ε × kSharperFrictionSmoothing; generated smoother than the first ε (0.05 rad/s
// against 0.014), it keeps the first (the sharper fit's training RMS is 8 % higher there).
TEST(DiagnoseStages, AFrictionFitTakesItsSmoothingSharperOnlyWhenTheDataSwitchSharper) {
  struct Outcome {
    double eps_first, eps_fitted, level;
    std::string modelling_note, message;
  };
  const auto fit_coulomb = [](double generated_eps) {
    Effects hidden;
    hidden.coulomb_v = 0.025;
    hidden.coulomb_smoothing_rad_s = generated_eps;
    const auto d = test::one_pose_diagnose_runs(hidden, 5);
    const std::vector<DiagnoseRun>& runs = d->runs;
    DiagnoseOptions opt;
    opt.simulation = d->fit.simulation;
    const PreparedRuns prepared = prepare_runs(runs, opt);
    const RoundModel model = initial_model(runs, prepared);
    const std::vector<DiagnoseRun> no_runs;
    const Reidentifier reid(no_runs, 0.0);
    const RoundStart start = start_round(runs, prepared, model, reid, opt);
    CandidateFitter fitter(runs, prepared, model, opt);
    const CandidateSearch none_start = search_candidate(EffectKind::kNone, prepared, model, start, reid, opt);
    const CandidateScore none =
        fitter.fit(EffectKind::kNone, none_start.effects, none_start.start_scales, none_start.alpha, false, false, nullptr);
    EXPECT_TRUE(none.ok) << none.message;
    fitter.set_none_training_rms(none.training_rms);
    fitter.set_none_error_after(none.error_after);
    const CandidateSearch s = search_candidate(EffectKind::kCoulombFriction, prepared, model, start, reid, opt);
    PendingCrossValidation later;
    const CandidateScore c =
        fitter.fit(EffectKind::kCoulombFriction, s.effects, s.start_scales, s.alpha, false, false, &later);
    EXPECT_TRUE(c.ok) << c.message;
    EXPECT_LT(c.training_rms, 0.8 * none.training_rms);  // 0.53 and 0.71 here
    return Outcome{model.effects.coulomb_smoothing_rad_s, c.effects.coulomb_smoothing_rad_s, c.effects.coulomb_v,
                   c.modelling_note, c.message};
  };
  const Outcome sharp = fit_coulomb(0.001);
  EXPECT_NEAR(sharp.eps_first, kFrictionSmoothingShareOfRmsVelocity * 1.4, 0.5 * 0.014);  // the RMS velocity ~1.4 rad/s
  EXPECT_DOUBLE_EQ(sharp.eps_fitted, kSharperFrictionSmoothing * sharp.eps_first);
  EXPECT_EQ(sharp.modelling_note.rfind(kSharperSmoothingNote, 0), 0u) << sharp.message;
  EXPECT_NEAR(sharp.level, 0.025, 0.15 * 0.025) << sharp.message;  // 0.0273 here (training RMS 8 % lower)
  const Outcome smooth = fit_coulomb(0.05);
  EXPECT_EQ(smooth.eps_fitted, smooth.eps_first);
  EXPECT_EQ(smooth.modelling_note, "") << smooth.message;
}

TEST(DiagnoseStages, AnEffectTheOthersMadeRedundantIsDroppedAfterTheRounds) {
  // Hidden: Coulomb friction 0.025 V alone. A model that named an offset torque as well (as a
  // round can when an effect named after it is still missing) refits without it as well as with
  // it: the offset is dropped, the Coulomb friction kept. With an offset hidden too, neither is.
  const auto dropped_from = [](double hidden_offset_v, std::vector<EffectKind>& named_after,
                               Effects& effects_after) {
    Effects hidden;
    hidden.coulomb_v = 0.025;
    hidden.coulomb_smoothing_rad_s = 0.001;
    hidden.offset_v = hidden_offset_v;
    const auto d = test::one_pose_diagnose_runs(hidden, 5);
    DiagnoseOptions opt;
    opt.simulation = d->fit.simulation;
    const PreparedRuns prepared = prepare_runs(d->runs, opt);
    RoundModel model = initial_model(d->runs, prepared);
    model.effects.coulomb_v = 0.025;
    model.effects.coulomb_smoothing_rad_s = 0.1 * model.effects.coulomb_smoothing_rad_s;
    model.effects.offset_v = hidden_offset_v > 0.0 ? hidden_offset_v : 0.004;
    model.named = {EffectKind::kOffsetTorque, EffectKind::kCoulombFriction};
    const std::vector<DroppedEffect> out = drop_redundant_effects(d->runs, prepared, model, model.named, opt);
    named_after = model.named;
    effects_after = model.effects;
    return out;
  };
  std::vector<EffectKind> named;
  Effects e;
  const std::vector<DroppedEffect> spurious = dropped_from(0.0, named, e);
  ASSERT_EQ(spurious.size(), 1u);
  EXPECT_EQ(spurious[0].effect, EffectKind::kOffsetTorque);
  EXPECT_FALSE(spurious[0].score_with <= 0.9 * spurious[0].score_without) << spurious[0].message;
  EXPECT_NE(spurious[0].message.find("offset_torque dropped after the rounds"), std::string::npos);
  EXPECT_EQ(named, std::vector<EffectKind>{EffectKind::kCoulombFriction});
  EXPECT_EQ(e.offset_v, 0.0);
  EXPECT_NEAR(e.coulomb_v, 0.025, 0.2 * 0.025);
  const std::vector<DroppedEffect> real = dropped_from(0.012, named, e);
  EXPECT_TRUE(real.empty()) << real.front().message;
  EXPECT_EQ(named.size(), 2u);
  EXPECT_NEAR(e.offset_v, 0.012, 0.3 * 0.012);
}

}  // namespace
}  // namespace alphainv::diagnose_detail
