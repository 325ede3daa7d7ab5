#include "alphainv/diagnose/diagnose_report.hpp"
#include "alphainv/diagnose/discovered_term.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include <gtest/gtest.h>

#include "diagnose/one_pose_dataset.hpp"

namespace alphainv {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(DiagnoseReport, EffectParametersTextHasNamesValuesAndUnits) {
  Effects e;
  e.offset_v = 0.0123456;
  e.gravity_v = 0.3;
  e.gravity_theta0_rad = -0.25;
  EXPECT_EQ(effect_parameters_text(e, EffectKind::kOffsetTorque), "offset_v = 0.01235 command unit");
  EXPECT_EQ(effect_parameters_text(e, EffectKind::kGravity),
            "gravity_v = 0.3 command unit, gravity_theta0_rad = -0.25 rad");
  EXPECT_EQ(effect_parameters_text(e, EffectKind::kNone), "–");
}

CandidateScore candidate(EffectKind kind, double score, double f1, double f2, double after) {
  CandidateScore c;
  c.effect = kind;
  c.ok = true;
  c.score = score;
  c.fold_scores = {f1, f2};
  c.error_after = after;
  return c;
}

/// A result built by hand: two runs, one round that named an offset torque.
DiagnoseResult hand_built() {
  DiagnoseResult r;
  r.ok = true;
  r.termination = DiagnoseTermination::kMaxEffects;
  r.fit_runs = {0, 1};
  r.seconds = 1.5;
  r.error_before = 0.02;
  r.error_after = 0.01;
  r.before.run_rms = {0.02, kNaN};
  r.after.run_rms = {0.01, 0.005};
  r.before.findings = {"f1"};
  r.after.findings = {"f2"};
  r.effects.offset_v = 0.0123;
  r.effects_named = {EffectKind::kOffsetTorque};
  DiagnoseRound rd;
  rd.named = EffectKind::kOffsetTorque;
  rd.error_before = 0.02;
  rd.error_after = 0.01;
  rd.candidates.push_back(candidate(EffectKind::kNone, 0.002, 0.0021, 0.0019, 0.02));
  rd.candidates.push_back(candidate(EffectKind::kOffsetTorque, 0.001, 0.0011, 0.0009, 0.01));
  rd.candidates.back().effects = r.effects;
  rd.candidates.back().message = "settled";
  CandidateScore failed;
  failed.effect = EffectKind::kTimeDelay;
  failed.message = "failed";
  rd.candidates.push_back(failed);
  rd.none_at_winner_breakpoints = candidate(EffectKind::kNone, 0.0018, 0.0018, 0.0018, kNaN);
  r.rounds.push_back(rd);
  return r;
}

TEST(DiagnoseReport, MarkdownOfAHandBuiltResult) {
  RunData d;
  DiagnoseRun a, b;
  a.data = b.data = &d;
  a.name = "a.csv";
  b.name = "b.csv";
  const std::string md = diagnose_report_markdown(hand_built(), {a, b}, "data/x", "fitted");
  const std::string expected =
      "# omni_fit diagnose report\n\nDataset: `data/x` (2 runs; model: fitted). Candidates fitted "
      "and scored on 2 runs; wall time 1.5 s.\n\n"
      "## Where the model was wrong (before)\n\n- f1\n\n"
      "## Candidates\n\nEach candidate effect was searched with the α-model re-identified from the "
      "sine runs with the effect in the plant input (when the model has an α-model and the "
      "dataset sine runs), then fitted by output error together with the α-model's coefficient "
      "factors, and scored by 2-fold cross-validation (fitted on one half of each fit window, RMS "
      "error on the other half). An effect is named only when its score is at least 10 % below "
      "that of `none` in both folds, the error over all runs drops by 5 % or more, and it also "
      "beats `none` refitted at its α-model's breakpoints. See docs/diagnose.md.\n\n"
      "### Round 1: offset_torque (RMS error 0.02 → 0.01)\n\n"
      "| effect | score (CV RMS) | fold 1 | fold 2 | RMS after, all runs | parameters | note |\n"
      "|---|---|---|---|---|---|---|\n"
      "| none | 0.002 | 0.0021 | 0.0019 | 0.02 | – |  |\n"
      "| **offset_torque** | 0.001 | 0.0011 | 0.0009 | 0.01 | offset_v = 0.0123 command unit | "
      "settled |\n"
      "| time_delay | ∞ | ∞ | ∞ | – | – | failed |\n"
      "| none at the winner's breakpoints | 0.0018 | 0.0018 | 0.0018 | – | – | the winner must "
      "beat this too |\n\n"
      "## The gap before and after\n\nRMS of θ − θ_sim over all runs: **0.02 → 0.01** (50.0 % "
      "less).\n\n| run | RMS before | RMS after | change |\n|---|---|---|---|\n"
      "| a.csv | 0.02 | 0.01 | -50.0 % |\n"
      "| b.csv | – | 0.005 | – |\n\n"
      "## Where the model is wrong now (after)\n\n- f2\n";
  EXPECT_EQ(md, expected);
}

TEST(DiagnoseReport, BriefAndFullReportOfAHandBuiltResult) {
  DiagnoseResult r = hand_built();
  EXPECT_EQ(r.brief_report(), "offset_torque; RMS of theta - theta_sim 0.02 -> 0.01 (2 runs, 1.5 s)");
  const std::string full = r.full_report();
  EXPECT_EQ(full.rfind("Diagnose report: usable\n  termination: max effects\n", 0), 0u) << full;
  EXPECT_NE(full.find("  runs: 2 (2 to fit and score), 1.5 s\n"), std::string::npos) << full;
  EXPECT_NE(full.find("over all runs: 0.02 → 0.01 (50.0 % less)\n"), std::string::npos) << full;
  // An RMS that rose (an effect named by most runs, whose pooled RMS is higher): "more".
  DiagnoseResult rose = hand_built();
  rose.error_after = 0.021;
  EXPECT_NE(rose.full_report().find("over all runs: 0.02 → 0.021 (5.0 % more)\n"), std::string::npos)
      << rose.full_report();
  EXPECT_NE(full.find("    offset_torque: offset_v = 0.0123 command unit\n"), std::string::npos);
  EXPECT_NE(full.find("Round 1: offset_torque (RMS 0.02 → 0.01)\n"), std::string::npos) << full;
  EXPECT_NE(full.find("  offset_torque *                    0.001       0.0011      0.0009      0.01        "
                      "offset_v = 0.0123 command unit; settled\n"),
            std::string::npos)
      << full;
  EXPECT_NE(full.find("  none at the winner's breakpoints   0.0018"), std::string::npos) << full;
  EXPECT_NE(full.find("Before:\n  - f1\nAfter:\n  - f2\n"), std::string::npos) << full;
  // Several effects: all named; not usable: the reason.
  r.effects_named.push_back(EffectKind::kGravity);
  EXPECT_EQ(r.brief_report().rfind("offset_torque, gravity; RMS", 0), 0u) << r.brief_report();
  const DiagnoseResult none = diagnose({});
  EXPECT_EQ(none.termination, DiagnoseTermination::kInvalidInput);
  EXPECT_EQ(none.brief_report(), "not usable (invalid input): no runs to diagnose");
  EXPECT_NE(none.full_report().find("not usable\n  termination: invalid input\n  message: no runs"),
            std::string::npos)
      << none.full_report();
}

TEST(DiagnoseReport, RoundsOnTrialAndRolledBackSaySo) {
  // Round 1 named a member on trial and was rolled back (it names nothing now); round 2 ran with
  // that member in the model and is rolled back with it; round 3 holds its trial.
  DiagnoseResult r = hand_built();
  DiagnoseRound trial = r.rounds.front();
  trial.named = EffectKind::kNone;
  trial.error_after = trial.error_before;
  trial.on_trial_reference_rms = 0.0149;
  trial.rolled_back = true;
  trial.rolled_back_why = "saturation (kept alone from the pair saturation + deadzone) named on trial, rolled "
                          "back: the diagnosis ended at 0.01794 over all runs with it, not below 0.0149";
  DiagnoseRound after = r.rounds.front();
  after.rolled_back = true;
  DiagnoseRound held = r.rounds.front();
  held.on_trial_reference_rms = 0.0248;
  r.rounds = {trial, after, held};
  const std::string full = r.full_report();
  EXPECT_NE(full.find("Round 1: none; saturation (kept alone from the pair saturation + deadzone) named on "
                      "trial, rolled back: the diagnosis ended at 0.01794 over all runs with it, not below "
                      "0.0149 (RMS 0.02 → 0.02)\n"),
            std::string::npos)
      << full;
  EXPECT_NE(full.find("Round 2: offset_torque; rolled back with the round named on trial (RMS 0.02 → 0.01)\n"),
            std::string::npos)
      << full;
  EXPECT_NE(full.find("Round 3: offset_torque on trial (the diagnosis to end below 0.0248) (RMS 0.02 → 0.01)\n"),
            std::string::npos)
      << full;
  RunData d;
  DiagnoseRun a;
  a.data = &d;
  const std::string md = diagnose_report_markdown(r, {a}, "data/x", "fitted");
  EXPECT_NE(md.find("### Round 2: offset_torque; rolled back with the round named on trial (RMS error 0.02 → "
                    "0.01)\n"),
            std::string::npos)
      << md;
}

TEST(DiagnoseReport, NamedInOrderLeavesOutWhatWasRolledBackDroppedOrTakenIn) {
  DiagnoseResult r;
  r.disturbance.named = true;
  r.disturbance.error_after = 0.05;
  const auto round = [](EffectKind a, EffectKind b, double after) {
    DiagnoseRound rd;
    rd.named = a;
    rd.named_second = b;
    rd.error_after = after;
    return rd;
  };
  DiagnoseRound trial = round(EffectKind::kNone, EffectKind::kNone, 0.04);  // rolled back: names nothing
  trial.rolled_back = true;
  DiagnoseRound after_trial = round(EffectKind::kSaturation, EffectKind::kNone, 0.03);
  after_trial.rolled_back = true;
  const DiagnoseRound coulomb = round(EffectKind::kCoulombFriction, EffectKind::kNone, 0.02);
  const DiagnoseRound pair = round(EffectKind::kGravity, EffectKind::kTimeDelay, 0.01);
  DiagnoseRound stribeck = round(EffectKind::kStribeckFriction, EffectKind::kNone, 0.008);
  stribeck.took_in = EffectKind::kCoulombFriction;
  DiagnoseRound deadzone = round(EffectKind::kDeadzone, EffectKind::kNone, 0.007);
  r.rounds = {trial, after_trial, coulomb, pair, stribeck, deadzone};
  DroppedEffect dropped;
  dropped.effect = EffectKind::kDeadzone;
  r.dropped = {dropped};
  const std::vector<NamedEffect> n = r.named_in_order();
  ASSERT_EQ(n.size(), 4u);
  EXPECT_EQ(n[0].effect, EffectKind::kExternalDisturbance);
  EXPECT_DOUBLE_EQ(n[0].error_after, 0.05);
  EXPECT_EQ(n[1].effect, EffectKind::kGravity);
  EXPECT_EQ(n[2].effect, EffectKind::kTimeDelay);
  EXPECT_DOUBLE_EQ(n[1].error_after, 0.01);
  EXPECT_DOUBLE_EQ(n[2].error_after, 0.01);  // (a pair: the pair's)
  EXPECT_EQ(n[3].effect, EffectKind::kStribeckFriction);
  EXPECT_EQ(n[3].took_in, EffectKind::kCoulombFriction);
  EXPECT_EQ(n[1].took_in, EffectKind::kNone);
  // A generalisation in a rolled-back round took nothing in: the Coulomb level stays.
  r.rounds[4].rolled_back = true;
  const std::vector<NamedEffect> m = r.named_in_order();
  ASSERT_EQ(m.size(), 4u);
  EXPECT_EQ(m[1].effect, EffectKind::kCoulombFriction);
  EXPECT_DOUBLE_EQ(m[1].error_after, 0.02);
  // A kept discovered term that took the Coulomb friction's place: its name goes; not kept, it
  // stays.
  auto term = std::make_shared<DiscoveredTermResult>();
  term->kept = true;
  term->took_in = EffectKind::kCoulombFriction;
  r.discovered = term;
  const std::vector<NamedEffect> t = r.named_in_order();
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[1].effect, EffectKind::kGravity);
  term->kept = false;
  EXPECT_EQ(r.named_in_order().size(), 4u);
}

TEST(DiagnoseReport, ReportsOfARealDiagnosis) {
  // The sweep's dataset with a hidden offset torque, two candidates, 4 fit runs of 1.5 s.
  Effects hidden;
  hidden.offset_v = 0.02;
  const auto d = test::one_pose_diagnose_runs(hidden, 4);
  const std::vector<DiagnoseRun>& runs = d->runs;
  DiagnoseOptions opt;
  opt.max_effects = 1;
  opt.simulation = d->fit.simulation;
  opt.max_fit_runs = 4;
  opt.fit_window_s = 1.5;
  opt.candidates = {EffectKind::kOffsetTorque, EffectKind::kTimeDelay};
  opt.discover = false;  // (its report is tested above, on a result made by hand; its fit was most of the time)
  const DiagnoseResult r = diagnose(runs, opt);
  ASSERT_TRUE(r.ok) << r.message;
  ASSERT_EQ(r.effects_named, (std::vector<EffectKind>{EffectKind::kOffsetTorque}));
  EXPECT_EQ(r.termination, DiagnoseTermination::kMaxEffects);
  EXPECT_NEAR(r.effects.offset_v, 0.02, 0.1 * 0.02);
  EXPECT_LT(r.error_after, 0.5 * r.error_before);

  char brief[200];
  std::snprintf(brief, sizeof brief,
                "offset_torque; RMS of theta - theta_sim %.4g -> %.4g (%zu runs, %.1f s)%s",
                r.error_before, r.error_after, runs.size(), r.seconds,
                r.verdict.verdict == ResidualVerdict::kExplained ? "; explained to the noise floor"
                                                                 : "; structure remains");
  EXPECT_EQ(r.brief_report(), brief);
  EXPECT_EQ(runs.size(), 10u);

  const std::string full = r.full_report();
  EXPECT_NE(full.find("  termination: max effects\n"), std::string::npos) << full;
  EXPECT_NE(full.find("  runs: 10 (4 to fit and score)"), std::string::npos) << full;
  EXPECT_NE(full.find("    offset_torque: " + effect_parameters_text(r.effects, EffectKind::kOffsetTorque)),
            std::string::npos)
      << full;
  EXPECT_NE(full.find("  α-model: re-identified"), std::string::npos) << full;
  ASSERT_EQ(r.rounds.size(), 1u);
  ASSERT_EQ(r.rounds[0].candidates.size(), 3u);  // none first, then the two asked for
  EXPECT_NE(full.find("Round 1: offset_torque"), std::string::npos) << full;
  EXPECT_NE(full.find("\n  none    "), std::string::npos) << full;
  EXPECT_NE(full.find("\n  offset_torque *   "), std::string::npos) << full;
  EXPECT_NE(full.find("\n  time_delay    "), std::string::npos) << full;
  EXPECT_NE(full.find("Before:\n  - " + r.before.findings.front()), std::string::npos) << full;
  EXPECT_NE(full.find("\nVerdict: " + r.verdict.text() + "\n"), std::string::npos) << full;

  const std::string md = diagnose_report_markdown(r, runs, "generated", "fitted by the pipeline");
  EXPECT_EQ(md.rfind("# omni_fit diagnose report\n\nDataset: `generated` (10 runs; model: fitted by "
                     "the pipeline). Candidates fitted and scored on 4 runs;",
                     0),
            0u)
      << md;
  EXPECT_NE(md.find("### Round 1: offset_torque (RMS error "), std::string::npos);
  EXPECT_NE(md.find("| **offset_torque** | "), std::string::npos);
  for (const DiagnoseRun& run : runs) EXPECT_NE(md.find("| " + run.name + " | "), std::string::npos);
  EXPECT_NE(md.find("## Verdict\n\nNoise floor"), std::string::npos) << md;
}

}  // namespace
}  // namespace alphainv
