#include "alphainv/diagnose/discovered_term.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "alphainv/error.hpp"

#include "diagnose/one_pose_dataset.hpp"

namespace alphainv {
namespace {

/// Columns of smooth, correlated functions of a common signal (like a library on a trajectory),
/// in `runs` groups of n samples each.
struct Synthetic {
  std::vector<std::vector<double>> columns;
  std::vector<std::size_t> groups;
  std::vector<double> noise;
};

Synthetic synthetic(std::size_t runs, std::size_t n, double noise_std, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  Synthetic s;
  s.columns.assign(6, {});
  for (std::size_t r = 0; r < runs; ++r) {
    const double f = 0.5 + 0.37 * static_cast<double>(r);
    for (std::size_t k = 0; k < n; ++k) {
      const double t = 0.001 * static_cast<double>(k);
      const double v = std::cos(6.283185307179586 * f * t);
      s.columns[0].push_back(1.0);
      s.columns[1].push_back(std::tanh(v / 0.05));
      s.columns[2].push_back(v);
      s.columns[3].push_back(v * std::abs(v));
      s.columns[4].push_back(std::tanh(v / 0.05) * std::exp(-v * v / 0.04));
      s.columns[5].push_back(std::sin(6.283185307179586 * f * t));
      s.groups.push_back(r);
      s.noise.push_back(noise_std * g(rng));
    }
  }
  return s;
}

TEST(SparseRegression, RecoversASparseTruthWithStandardErrors) {
  const Synthetic s = synthetic(6, 2000, 0.05, 11);
  std::vector<double> y(s.noise.size());
  for (std::size_t k = 0; k < y.size(); ++k)
    y[k] = -0.004 * s.columns[1][k] + 0.003 * s.columns[4][k] + 0.002 * s.columns[5][k] + 1e-3 * s.noise[k];
  const SparseRegressionResult r = sparse_regression(s.columns, y, s.groups);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.chosen.terms, (std::vector<std::size_t>{1, 4, 5}));
  // The coefficients within 4 standard errors of the truth, and the errors of the right size
  // (σ/√n with n = 12000 and unit-RMS columns: about 5e-5/0.7).
  const std::vector<double> truth = {0.0, -0.004, 0.0, 0.0, 0.003, 0.002};
  for (std::size_t j : r.chosen.terms) {
    EXPECT_NEAR(r.coefficients[j], truth[j], 4.0 * r.standard_errors[j]) << j;
    EXPECT_GT(r.standard_errors[j], 1e-8) << j;
    EXPECT_LT(r.standard_errors[j], 5e-6) << j;
  }
  EXPECT_EQ(r.coefficients[0], 0.0);
  EXPECT_TRUE(std::isnan(r.standard_errors[0]));
  EXPECT_LE(r.chosen.cv_rms, r.supports.front().cv_rms);  // better than nothing
}

TEST(SparseRegression, PureNoiseDiscoversNothing) {
  const Synthetic s = synthetic(5, 1500, 1.0, 12);
  const SparseRegressionResult r = sparse_regression(s.columns, s.noise, s.groups);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_TRUE(r.chosen.terms.empty()) << r.chosen.terms.size() << " terms";
}

TEST(SparseRegression, ANamedFormWinsWhenItExplainsAsMuchWithFewerTerms) {
  // y is a Coulomb level; a spurious almost-equal fit with more terms must not win.
  const Synthetic s = synthetic(6, 1500, 1.0, 13);
  std::vector<double> y(s.noise.size());
  for (std::size_t k = 0; k < y.size(); ++k) y[k] = -0.01 * s.columns[1][k] + 0.02 * s.noise[k];
  const SparseRegressionResult r =
      sparse_regression(s.columns, y, s.groups, {{"coulomb_friction", {1}}, {"stribeck", {1, 4}}});
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.chosen.terms, std::vector<std::size_t>{1});
  EXPECT_EQ(r.chosen.named_form, "coulomb_friction");
  EXPECT_NEAR(r.coefficients[1], -0.01, 4.0 * r.standard_errors[1]);
}

TEST(SparseRegression, BadInputSaysWhy) {
  const Synthetic s = synthetic(2, 200, 1.0, 14);
  std::vector<double> y = s.noise;
  EXPECT_FALSE(sparse_regression(s.columns, std::vector<double>(10, 0.0), s.groups).ok);
  std::vector<std::size_t> groups = s.groups;
  groups.pop_back();
  const SparseRegressionResult r = sparse_regression(s.columns, y, groups);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("one group per sample"), std::string::npos) << r.message;
  SparseRegressionOptions o;
  o.folds = 1;
  EXPECT_NE(sparse_regression(s.columns, y, s.groups, {}, o).message.find("regression.folds"),
            std::string::npos);
  // Two groups and five folds: blocks in time within each run instead.
  EXPECT_TRUE(sparse_regression(s.columns, y, s.groups).ok);
}

TEST(DiscoveredReading, NamesTheMatchingForm) {
  Effects e;
  e.discovered_velocity_scale_rad_s = 2.0;
  e.discovered_position_scale_rad = 0.07;
  e.discovered_sign_v = -0.004;
  EXPECT_EQ(discovered_reading(e), "this is coulomb_friction: Fc = 0.004");
  e.discovered_stribeck_fast_v = -0.006;  // breakaway 0.01 at v_s = 0.05·2
  EXPECT_EQ(discovered_reading(e), "this is stribeck_friction: Fc = 0.004, Fs = 0.01, v_s = 0.1");
  // Less friction at low speed (Fs < Fc; here Fs < 0, a driving torque) is not Stribeck's hump
  // (Coulomb friction + saturation, seed 41, read "Fc = 0.00473, Fs = -0.00525").
  e.discovered_stribeck_fast_v = 0.01;
  EXPECT_EQ(discovered_reading(e),
            "no named form matches: a Coulomb-like level 0.004; less friction at low speed than at speed "
            "(a dip, not Stribeck's hump)");
  e.discovered_stribeck_fast_v = 0.0;
  e.discovered_sign_pos_v = 0.0007;  // −σ(Fc0 + s θ): s = −0.0007/0.07
  EXPECT_EQ(discovered_reading(e), "this is position_dependent_friction: Fc0 = 0.004, s = -0.01");
  e.discovered_cos2_v = 0.001;
  EXPECT_EQ(discovered_reading(e).rfind("no named form matches", 0), 0u) << discovered_reading(e);
  EXPECT_EQ(discovered_reading(Effects{}), "nothing");
}

using test::one_pose_dataset;

/// diagnose_dataset() with only `none` to name on a dataset with `hidden`: the discovered term
/// carries what no named effect was allowed to.
DiagnoseResult diagnose_without_candidates(const ExperimentPlanOptions& plan) {
  const GeneratedDataset g = generate_dataset(make_experiment_plan(plan));
  DiagnoseOptions o;
  o.candidates = {EffectKind::kNone};
  return diagnose_dataset(g.index, g.runs, o);
}

ExperimentPlanOptions one_pose(std::uint64_t seed) {
  ExperimentPlanOptions plan = paper_plan_options(seed);
  plan.plant.effects = Effects{};
  const auto poses = paper_sine_poses();
  plan.sine_poses = {poses[seed % poses.size()]};
  plan.square_poses = plan.sine_poses;
  return plan;
}

// A contender takes a named friction's place only when its memory terms carry at least half of
// that friction (discover_term(), step 4). The numbers: a position-dependent friction of seed 44
// (0.0231 V + 0.101 V/rad·θ, θ̇_rms 1.58 rad/s) whose place a term with a Dahl friction of 0.0042
// V took (the rest velocity polynomials); the invented frictional lag of seed 32 (a lagged
// friction of 0.0091 V for a named Coulomb friction of 0.0078 V).
TEST(DiscoverTerm, ATermTakesAFrictionsPlaceOnlyWhenItsMemoryCarriesThatFriction) {
  Effects posdep;
  posdep.position_coulomb_v = 0.02314;
  posdep.position_slope_v_per_rad = 0.1013;
  posdep.position_smoothing_rad_s = 0.001578;
  Effects term;
  term.discovered_dahl_v = -0.004181;
  EXPECT_FALSE(memory_carries_friction(posdep, Effects{}, term, 1.576));
  term.discovered_lag_sign_v = -0.008;  // with a lagged friction as well: 0.0122 ≥ 0.0116
  EXPECT_TRUE(memory_carries_friction(posdep, Effects{}, term, 1.576));
  Effects coulomb;
  coulomb.coulomb_v = 0.0078;
  coulomb.coulomb_smoothing_rad_s = 0.0015;
  Effects lagged;
  lagged.discovered_lag_sign_v = -0.0091;
  EXPECT_TRUE(memory_carries_friction(coulomb, Effects{}, lagged, 1.5));
  lagged.discovered_lag_sign_v = 0.0091;  // pushing the joint along: not a friction
  EXPECT_FALSE(memory_carries_friction(coulomb, Effects{}, lagged, 1.5));
  lagged.discovered_lag_sign_v = -0.0035;  // 45 % of it
  EXPECT_FALSE(memory_carries_friction(coulomb, Effects{}, lagged, 1.5));
}

TEST(DiscoverTerm, CarriesAFrictionNoNamedEffectWasAllowedToTake) {
  // Coulomb friction Fc = 0.008 hidden, only `none` allowed in the rounds: the discovered term
  // must take it (the invented effects are the figure's: scripts/invented_effects_figure.py).
  ExperimentPlanOptions plan = one_pose(5);
  plan.plant.effects.coulomb_v = 0.008;
  const DiagnoseResult r = diagnose_without_candidates(plan);
  ASSERT_TRUE(r.ok) << r.message;
  ASSERT_TRUE(r.discovered) << r.full_report();
  const DiscoveredTermResult& d = *r.discovered;
  EXPECT_TRUE(d.kept) << d.full_report();
  EXPECT_GT(d.gap_closed, 0.5) << d.full_report();
  EXPECT_LT(r.error_after, 0.5 * r.error_before) << d.full_report();
  // Friction: a Coulomb-like term opposing the motion.
  // Friction: the term opposes slow motion (θ̇ = 5 % of its velocity scale) at the hidden
  // level within 2× (the α-model given has absorbed part of it as damping: the term found is
  // not always the Coulomb form alone).
  const double slow = 0.05 * d.effects.discovered_velocity_scale_rad_s;
  const double n_slow = discovered_torque(d.effects, 0.0, slow);
  EXPECT_LT(n_slow, -0.5 * 0.008) << d.full_report();
  EXPECT_GT(n_slow, -2.0 * 0.008) << d.full_report();
  // In the final model (its α-model re-identified with the term), and said in the reports.
  ASSERT_FALSE(d.terms.empty());
  EXPECT_EQ(r.effects.*kDiscoveredLibrary[d.terms[0].index].coefficient, d.terms[0].coefficient);
  EXPECT_TRUE(r.effects_named.empty());
  EXPECT_NE(r.full_report().find("Discovered term: discovered (kept)"), std::string::npos);
}

/// discover_term() with `base` fitted on 4 of the 10 runs of `d` (the square run among them), a
/// few output-error iterations, judged over all runs.
DiscoveredTermResult discover_on_four_runs(const test::OnePoseDiagnoseRuns& d, const DiscoveredBase& base) {
  std::vector<DiagnoseRun> fit_runs;
  for (std::size_t i : {1u, 4u, 7u, 9u}) fit_runs.push_back(d.runs.at(i));
  DiscoveredTermOptions o;
  o.simulation = d.fit.simulation;
  o.threads = 2;
  o.max_iterations = 4;
  return discover_term(fit_runs, d.runs, base, o);
}

// discover_term()'s step 4 tries taking the place of every named friction form, not only Coulomb
// friction: a friction that follows the velocity through a 30 ms lag (the memory term's own form)
// with the model's friction named as Stribeck friction at the hidden level, Fc = Fs = 0.01 (the
// same torque as a Coulomb level in the form a round may name it). The contender with it taken
// out is tried (before, only a Coulomb level was taken out: here nothing was tried), and the
// bookkeeping holds whichever wins. (The base's α-model is the runs' own, no re-identification,
// which absorbed part of the friction: here the contender wins, a friction 0.029 through a 13 ms
// lag, RMS 0.00978 -> 0.00337 against 0.00428 beside the named friction; 20 s.)
TEST(DiscoverTerm, TriesTakingThePlaceOfANamedFrictionOfAnyForm) {
  Effects hidden;
  hidden.discovered_lag_sign_v = -0.01;
  hidden.discovered_lag_s = 0.03;
  hidden.discovered_lag_smoothing_rad_s = 0.02;
  const auto d = test::one_pose_diagnose_runs(hidden, 8);
  DiscoveredBase base;
  base.effects.stribeck_coulomb_v = 0.01;
  base.effects.stribeck_breakaway_v = 0.01;
  const DiscoveredTermResult r = discover_on_four_runs(*d, base);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.took_in_tried, EffectKind::kStribeckFriction) << r.full_report();
  EXPECT_TRUE(std::isfinite(r.took_in_error_after)) << r.full_report();
  EXPECT_NE(r.full_report().find("the contender with the named stribeck_friction taken out: RMS"), std::string::npos)
      << r.full_report();
  const bool took_in = r.took_in == EffectKind::kStribeckFriction;
  EXPECT_TRUE(took_in || r.took_in == EffectKind::kNone);
  EXPECT_EQ(took_in, r.kept && r.effects.stribeck_coulomb_v == 0.0 && r.effects.stribeck_breakaway_v == 0.0)
      << r.full_report();
  if (took_in) {
    EXPECT_LE(r.error_after, r.took_in_error_after);
  }
}

// discover_term()'s step 5: a named torque of the state outside the friction family (a cogging,
// gravity, an offset) is taken out in a contender too, which takes its place only when over all
// runs its RMS is no worse than the best contender's and the judged structure is lower by the
// significance. The numbers: the invented frictional lag of seed 32 (docs/diagnose.md), whose
// round 2 named a cogging of 0.0032 V: with it taken out the term's RMS 0.000947 against 0.000971
// and the judged structure 0.000103 against 0.000179 (the floor 6.7e-5); the plant's own cogging
// (the test below): RMS 0.00396 against 0.00431 without it, but the structure 0.00159 against
// 0.00104.
TEST(DiscoverTerm, ATermTakesTheStatesEffectsPlaceOnlyWhenItCutsTheJudgedStructureAndNotTheRms) {
  EXPECT_TRUE(taken_out_contender_wins(0.000947, 0.000103, 0.000971, 0.000179, 0.1));
  EXPECT_FALSE(taken_out_contender_wins(0.00396, 0.00159, 0.00431, 0.00104, 0.1));
  EXPECT_FALSE(taken_out_contender_wins(0.000972, 0.000103, 0.000971, 0.000179, 0.1));  // RMS worse
  EXPECT_FALSE(taken_out_contender_wins(0.000947, 0.000170, 0.000971, 0.000179, 0.1));  // within 10 %
  EXPECT_FALSE(taken_out_contender_wins(0.000947, 0.000179, 0.000947, 0.000179, 0.1));  // a tie: named
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(taken_out_contender_wins(0.000947, nan, 0.000971, 0.000179, 0.1));
  EXPECT_FALSE(taken_out_contender_wins(nan, 0.000103, 0.000971, 0.000179, 0.1));
  EXPECT_FALSE(taken_out_contender_wins(0.000947, 0.000103, 0.000971, nan, 0.1));
}

// … tried in discover_term() on a plant with a cogging (0.02 V, period 0.02 rad) and a friction
// through a 30 ms lag (the memory term's own form), the cogging in the model at the plant's
// values: the contender without it is tried and loses. Its RMS over all runs is lower (the base's
// α-model is the runs' own here, fitted without the effects), but the library's slow functions of
// θ cannot make the cogging and the judged structure says so. (Where a round named a cogging the
// plant does not have, the term took its place: the invented lag of seed 32, docs/diagnose.md.)
TEST(DiscoverTerm, TriesTakingThePlaceOfANamedCoggingAndKeepsThePlantsOwn) {
  Effects hidden;
  hidden.discovered_lag_sign_v = -0.01;
  hidden.discovered_lag_s = 0.03;
  hidden.discovered_lag_smoothing_rad_s = 0.02;
  hidden.cogging_v = 0.02;
  hidden.cogging_period_rad = 0.02;
  hidden.cogging_phase_rad = 0.5;
  const auto d = test::one_pose_diagnose_runs(hidden, 8);
  DiscoveredBase base;
  base.effects.cogging_v = hidden.cogging_v;
  base.effects.cogging_period_rad = hidden.cogging_period_rad;
  base.effects.cogging_phase_rad = hidden.cogging_phase_rad;
  const DiscoveredTermResult r = discover_on_four_runs(*d, base);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_TRUE(r.kept) << r.full_report();
  EXPECT_EQ(r.took_in_tried, EffectKind::kCogging) << r.full_report();
  ASSERT_TRUE(std::isfinite(r.took_in_structure_after)) << r.full_report();
  EXPECT_EQ(r.took_in, EffectKind::kNone) << r.full_report();
  EXPECT_EQ(r.effects.cogging_v, 0.02);
  EXPECT_GT(r.took_in_structure_after, 1.2 * r.structure_after) << r.full_report();
  EXPECT_NE(r.full_report().find("the contender with the named cogging taken out: RMS"), std::string::npos)
      << r.full_report();
}

// End to end (a whole diagnosis, about a minute; not run under the sanitizers, .ci/run): a
// friction that follows the velocity through a 30 ms lag, hidden in the plant in the memory
// term's own form (ground truth), the friction forms in the rounds. Whatever they name, the
// discovered term must take the lag with its time and level, and close most of what the
// verdict judges. (The invented forms, not the term's own, are the figure's:
// scripts/invented_effects_figure.py, docs/diagnose.md.)
TEST(DiscoverTermEndToEnd, FindsALaggedFrictionWithItsLagTimeAndLevel) {
  ExperimentPlanOptions plan = one_pose(8);
  plan.plant.effects.discovered_lag_sign_v = -0.01;
  plan.plant.effects.discovered_lag_s = 0.03;
  plan.plant.effects.discovered_lag_smoothing_rad_s = 0.02;
  const GeneratedDataset g = generate_dataset(make_experiment_plan(plan));
  // The friction forms and the offset (asymmetric friction's second parent) in the rounds: the
  // catalogue's other effects, searched and not named here, were 18 % of the test's time.
  DiagnoseOptions o;
  o.candidates = {EffectKind::kCoulombFriction, EffectKind::kOffsetTorque, EffectKind::kStribeckFriction,
                  EffectKind::kAsymmetricFriction, EffectKind::kPositionDependentFriction};
  const DiagnoseResult r = diagnose_dataset(g.index, g.runs, o);
  ASSERT_TRUE(r.ok) << r.message;
  ASSERT_TRUE(r.discovered) << r.full_report();
  const DiscoveredTermResult& d = *r.discovered;
  EXPECT_TRUE(d.kept) << d.full_report();
  EXPECT_NE(r.effects.discovered_lag_sign_v, 0.0) << d.full_report();
  EXPECT_NEAR(r.effects.discovered_lag_s, 0.03, 0.3 * 0.03) << d.full_report();
  // Its level: the torque on steady forward motion (σ = 1, f = θ̇ ≫ ε_f, z = 1) of every
  // sign-like term (the lagged sign, the term's σ and Dahl state, the rounds' Coulomb friction)
  // opposes it at the hidden level, ±40 %.
  const double steady = r.effects.discovered_lag_sign_v + r.effects.discovered_sign_v +
                        r.effects.discovered_dahl_v - r.effects.coulomb_v;
  EXPECT_NEAR(steady, -0.01, 0.004) << d.full_report();
  EXPECT_GT(d.structure_gap_closed, 0.5) << d.full_report();
  EXPECT_NE(d.reading.find("memory"), std::string::npos) << d.reading;
  EXPECT_NE(d.equation.find("tanh(f/eps_f)"), std::string::npos) << d.equation;
  // The rounds named Coulomb friction for it (its nearest memoryless form): the contender with
  // that level taken out was tried. Here it does not cut the RMS over all runs of the one that
  // keeps it by significance/2 (0.001136 against 0.001109), so the named form stays, with its
  // name; where it does (the invented hysteresis of docs/diagnose.md) both go.
  EXPECT_TRUE(std::isfinite(d.took_in_error_after)) << d.full_report();
  const bool took_in = d.took_in == EffectKind::kCoulombFriction;
  EXPECT_EQ(took_in, d.took_in_error_after <= 0.95 * d.memory_error_after) << d.full_report();
  EXPECT_EQ(took_in, r.effects.coulomb_v == 0.0);
  EXPECT_EQ(took_in, std::count(r.effects_named.begin(), r.effects_named.end(), EffectKind::kCoulombFriction) == 0);
}

TEST(DiscoverTerm, EffectFreeDataIsNotTried) {
  const DiagnoseResult r = diagnose_without_candidates(one_pose(7));
  ASSERT_TRUE(r.ok) << r.message;
  if (r.verdict_before.verdict == ResidualVerdict::kExplained) {
    EXPECT_FALSE(r.discovered);
  } else if (r.discovered) {
    EXPECT_TRUE(r.discovered->terms.empty() || !r.discovered->kept) << r.discovered->full_report();
  }
}

TEST(DiscoverTerm, BadInputSaysWhy) {
  const DiscoveredTermResult r = discover_term({}, {}, {});
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.message, "no runs");
  DiscoveredTermOptions o;
  o.significance = 2.0;
  RunData d;
  d.t = {0.0, 0.001};
  d.r = d.theta = d.v = {0.0, 0.0};
  DiagnoseRun run;
  run.data = &d;
  run.name = "short.csv";
  EXPECT_NE(discover_term({run}, {run}, {}, o).message.find("significance"), std::string::npos);
  EXPECT_NE(discover_term({run}, {run}, {}).message.find("short.csv"), std::string::npos);
  // The discovered term is no candidate of the rounds.
  DiagnoseOptions opt;
  opt.candidates = {EffectKind::kDiscovered};
  EXPECT_THROW(opt.validate(), Error);
}

}  // namespace
}  // namespace alphainv
