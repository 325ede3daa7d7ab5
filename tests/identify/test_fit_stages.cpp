// The stages of fit_dataset() one by one (fit_stages.hpp), on the bundled set: the virtual Omni's
// paper plan, seed 1, generated here bit for bit as data/omni_yaw_sim. Figures printed with "%.4g"
// (or the format named) are those of that set's report.md (`omni_fit fit data/omni_yaw_sim`).

#include "alphainv/identify/fit_stages.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "alphainv/simulate/experiment_plan.hpp"

namespace alphainv {
namespace {

/// The bundled set, generated once.
const GeneratedDataset& bundled() {
  static const GeneratedDataset g = generate_dataset(paper_experiment_plan(1));
  return g;
}

/// `x` as report.md prints it.
std::string printed(double x, const char* format = "%.4g") {
  char b[64];
  std::snprintf(b, sizeof b, format, x);
  return b;
}

bool has_note(const DatasetFit& fit, const std::string& what) {
  for (const std::string& n : fit.notes) {
    if (n.find(what) != std::string::npos) return true;
  }
  return false;
}

/// Stages 1 … `last` (numbers of fit_stages.hpp) of `ds`, `data` with `options`.
DatasetFit run_stages(int last, const Dataset& ds, const std::vector<RunData>& data,
                      const FitPipelineOptions& options = {}) {
  DatasetFit fit;
  if (last >= 1) group_runs_by_pose(ds, fit);
  if (last >= 2) fit_local_linear_points(ds, data, options, fit);
  if (last >= 3) fit_global_linear_models(fit);
  if (last >= 4) fit_inertia_across_poses(options, fit);
  if (last >= 5) fit_alpha_invariant_model(options, fit);
  if (last >= 6) choose_model_simulation(data, options, fit);
  if (last >= 6) remove_known_disturbance_response(ds, data, options, fit);  // stage 6a
  if (last >= 7) fit_time_domain_poses(ds, data, options, fit);
  if (last >= 8) simulate_validation_runs(ds, data, options, fit);
  if (last >= 9) summarise_validation(ds, fit);
  return fit;
}

DatasetFit bundled_stages(int last, const FitPipelineOptions& options = {}) {
  return run_stages(last, bundled().index, bundled().runs, options);
}

TEST(FitStages, GroupRunsByPoseOnTheBundledSet) {
  const DatasetFit fit = bundled_stages(1);
  ASSERT_EQ(fit.poses.size(), 25u);
  // Pose-major: the nine sine poses (nine sines and a square each), then the square-only poses.
  EXPECT_EQ(printed(*fit.poses[0].gamma1_deg, "%.2f"), "20.01");
  EXPECT_EQ(printed(*fit.poses[0].gamma2_deg, "%.2f"), "68.43");
  EXPECT_EQ(fit.poses[0].runs.size(), 10u);
  EXPECT_EQ(fit.poses[24].runs.size(), 1u);
  EXPECT_EQ(printed(*fit.poses[24].gamma1_deg, "%.2f"), "61.48");
  const std::vector<std::size_t> pose = pose_of_runs(fit, bundled().index.runs.size());
  std::size_t runs = 0;
  for (std::size_t p = 0; p < fit.poses.size(); ++p) {
    runs += fit.poses[p].runs.size();
    for (std::size_t i : fit.poses[p].runs) EXPECT_EQ(pose[i], p);
  }
  EXPECT_EQ(runs, 106u);
}

TEST(FitStages, GroupRunsByPoseRoundsToHundredthsOfADegree) {
  Dataset ds;
  auto run = [](std::optional<double> g1, std::optional<double> g2) {
    RunInfo r;
    r.gamma1_deg = g1;
    r.gamma2_deg = g2;
    return r;
  };
  ds.runs = {run(20.001, 70.0), run(std::nullopt, std::nullopt), run(20.004, 70.0),
             run(20.006, 70.0), run(20.0, std::nullopt)};
  DatasetFit fit;
  group_runs_by_pose(ds, fit);
  ASSERT_EQ(fit.poses.size(), 3u);
  EXPECT_EQ(fit.poses[0].runs, (std::vector<std::size_t>{0, 2}));
  EXPECT_FALSE(fit.poses[1].gamma1_deg.has_value());  // no angles (or one): one pose
  EXPECT_EQ(fit.poses[1].runs, (std::vector<std::size_t>{1, 4}));
  EXPECT_EQ(fit.poses[2].runs, (std::vector<std::size_t>{3}));
}

TEST(FitStages, LocalLinearPointsOfTheSineRuns) {
  const DatasetFit fit = bundled_stages(2);
  EXPECT_EQ(fit.loop_period_s, 1e-3);  // 1/sample_rate_hz: the digital-loop correction
  EXPECT_EQ(fit.kp, 2.0);
  ASSERT_EQ(fit.sine_points.size(), 81u);
  EXPECT_TRUE(has_note(fit, "digital-loop correction: the sine runs are taken as a P law ticking "
                            "every T = 1 ms"));
  // runs/sine_25_70_1.5hz.csv | 20.01° / 68.43° | 1.5 | 1.126 | -20.71 | 17.69 | 529.6 | 0.2808
  const SineRunPoint& first = fit.sine_points.front();
  EXPECT_EQ(bundled().index.runs[first.run].file, "runs/sine_25_70_1.5hz.csv");
  EXPECT_EQ(first.pose, 0u);
  EXPECT_EQ(printed(first.gain), "1.126");
  EXPECT_EQ(printed(first.phase_deg, "%.2f"), "-20.71");
  EXPECT_EQ(printed(first.point.c_data), "17.69");
  EXPECT_EQ(printed(first.point.beta_data), "529.6");
  EXPECT_EQ(printed(first.point.alpha_data), "0.2808");
  // The resonance run of the pose: runs/sine_25_70_3.5hz.csv, gain 3.308, C_data 5.153.
  const SineRunPoint& res = fit.sine_points[4];
  EXPECT_EQ(printed(res.gain), "3.308");
  EXPECT_EQ(printed(res.point.c_data), "5.153");
  EXPECT_EQ(printed(res.point.alpha_data), "145.9");
  for (const SineRunPoint& sp : fit.sine_points) {
    EXPECT_TRUE(sp.point.physical);
    EXPECT_TRUE(sp.point.sampled_exact);
    EXPECT_GT(sp.point.c_data, sp.point.c_data_continuous);  // (19) reads C low by ≈ ω²T/2
  }
}

TEST(FitStages, LocalLinearPointsSkipRunsNotUnderAPLaw) {
  Dataset ds = bundled().index;
  ds.runs[0].controller.ki = 0.5;
  ds.runs[1].controller.kp = 0.0;
  FitPipelineOptions o;
  o.loop_period_s = 0.0;  // off: (19)-(20) as printed
  DatasetFit fit;
  group_runs_by_pose(ds, fit);
  fit_local_linear_points(ds, bundled().runs, o, fit);
  EXPECT_EQ(fit.loop_period_s, 0.0);
  ASSERT_EQ(fit.sine_points.size(), 79u);
  EXPECT_EQ(fit.sine_points.front().run, 2u);
  EXPECT_TRUE(has_note(fit, "2 sine run(s) were not under a pure P law"));
  EXPECT_TRUE(has_note(fit, "continuous loop assumed"));
  for (const SineRunPoint& sp : fit.sine_points) {
    EXPECT_EQ(sp.point.c_data, sp.point.c_data_continuous);
  }
}

TEST(FitStages, GlobalLinearModelPerPoseOnTheResonanceBand) {
  const DatasetFit fit = bundled_stages(3);
  // | 20.01° / 68.43° | 2.69–4.55 | 5.595 | 441.1 | 220.6 |
  const PoseFit& p0 = fit.poses[0];
  ASSERT_TRUE(p0.linear.valid) << p0.linear.message;
  EXPECT_EQ(p0.linear_source, "sine (22)");
  EXPECT_EQ(printed(p0.band_lo_hz, "%.2f"), "2.69");  // 3.5 Hz / 1.3
  EXPECT_EQ(printed(p0.band_hi_hz, "%.2f"), "4.55");  // 3.5 Hz · 1.3
  EXPECT_EQ(printed(p0.linear.c_linear), "5.595");
  EXPECT_EQ(printed(p0.linear.beta_linear), "441.1");
  EXPECT_EQ(printed(p0.linear.beta_tilde_linear), "220.6");
  // | 60.73° / 113.15° | 2.69–4.55 | 5.507 | 431.8 | 215.9 |
  EXPECT_EQ(printed(fit.poses[8].linear.c_linear), "5.507");
  EXPECT_EQ(printed(fit.poses[8].linear.beta_tilde_linear), "215.9");
  std::size_t valid = 0;
  for (const PoseFit& p : fit.poses) valid += p.linear.valid ? 1 : 0;
  EXPECT_EQ(valid, 9u);  // the square-only poses have no local points
}

TEST(FitStages, InertiaModelAcrossThePoses) {
  const DatasetFit fit = bundled_stages(4);
  ASSERT_TRUE(fit.has_inertia_model) << fit.inertia.message;
  EXPECT_EQ(fit.inertia.num_poses, 9);
  // The paper's fit (27)-(29) to the nine global linear models, before stage 5 re-identifies it
  // (report.md shows the re-identified model: C̄0 39.017, I_base 0.0015244).
  EXPECT_EQ(printed(fit.inertia.model.c0_bar, "%.5g"), "38.497");
  EXPECT_EQ(printed(fit.inertia.parameters[kIBase], "%.5g"), "0.0019383");
  EXPECT_EQ(printed(100 * fit.inertia.rms_relative_c, "%.2f"), "2.94");
  // Every pose with angles gets I from the model, the square-only ones too.
  for (const PoseFit& p : fit.poses) {
    EXPECT_EQ(p.inertia, fit.inertia.model.inertia.inertia(deg_to_rad(*p.gamma1_deg),
                                                           deg_to_rad(*p.gamma2_deg)));
  }
}

TEST(FitStages, InertiaModelNeedsSixPoses) {
  Dataset ds = bundled().index;
  for (std::size_t i = 45; i < ds.runs.size(); ++i) ds.runs[i].kind = "other";  // 5 sine poses
  const DatasetFit fit = run_stages(4, ds, bundled().runs);
  EXPECT_FALSE(fit.has_inertia_model);
  EXPECT_TRUE(has_note(fit, "inertia model (6) skipped: it needs global linear fits at 6 or more "
                            "poses with gamma1_deg/gamma2_deg, this dataset has 5"));
  for (const PoseFit& p : fit.poses) EXPECT_EQ(p.inertia, 1.0);
}

TEST(FitStages, AlphaInvariantModelAndTheConsistentInertia) {
  const DatasetFit fit = bundled_stages(5);
  ASSERT_TRUE(fit.alpha.ok) << fit.alpha.message;
  EXPECT_EQ(fit.alpha_source, "sine (2.3.5)");
  const AlphaModel& a = fit.alpha.model;
  // | n | α_n | C_n1 |: 0 0 11.94, 1 2.071 19.46, 2 19.87 28.77, 3 154 45.54
  ASSERT_EQ(a.n_breakpoints, 4u);
  EXPECT_EQ(printed(a.alpha[1]), "2.071");
  EXPECT_EQ(printed(a.alpha[2]), "19.87");
  EXPECT_EQ(printed(a.alpha[3]), "154");
  EXPECT_EQ(printed(a.c_n1[0]), "11.94");
  EXPECT_EQ(printed(a.c_n1[3]), "45.54");
  EXPECT_EQ(printed(a.beta_n1[0]), "0.8369");
  EXPECT_EQ(printed(a.beta_n1[1]), "1.072");
  EXPECT_EQ(fit.alpha.candidates_tried, 560u);
  EXPECT_FALSE(fit.alpha.breakpoint_identifiable[3]);
  // The inertia model re-identified with the α-model: Table "Inertia model" of the report.
  EXPECT_EQ(printed(fit.inertia.parameters[kIBase], "%.5g"), "0.0015244");
  EXPECT_EQ(printed(fit.inertia.model.c0_bar, "%.5g"), "39.017");
  EXPECT_EQ(printed(fit.poses[0].inertia, "%.6g"), "0.0045445");
  EXPECT_TRUE(has_note(fit, "inertia model re-identified consistently with the α-model (3 pass(es)"));
  EXPECT_TRUE(has_note(fit, "identifiability, α-model: the data cover α = 0.256188 … 163.603"));
  // Without the re-identification the inertia model stays stage 4's.
  FitPipelineOptions paper;
  paper.alpha_consistent_inertia = false;
  const DatasetFit plain = bundled_stages(5, paper);
  EXPECT_EQ(plain.inertia.model.c0_bar, bundled_stages(4).inertia.model.c0_bar);
  EXPECT_FALSE(has_note(plain, "re-identified"));
}

TEST(FitStages, ModelSimulationIsTheDigitalLoopWhenSampledUniformly) {
  const DatasetFit fit = bundled_stages(6);
  EXPECT_EQ(fit.simulation.loop_period_s, 1e-3);
  EXPECT_TRUE(has_note(fit, "models simulated as the digital loop at 1000 Hz"));
  std::vector<RunData> data = bundled().runs;
  data[3].t[10] += 2e-4;  // one sample 20 % off the tick
  DatasetFit jitter;
  jitter.loop_period_s = 1e-3;
  choose_model_simulation(data, FitPipelineOptions{}, jitter);
  EXPECT_EQ(jitter.simulation.loop_period_s, 0.0);
  EXPECT_TRUE(has_note(jitter, "runs not sampled uniformly at the loop period"));
  // A loop that skipped a few late ticks (omni_ctl's t is the deadline): still the digital loop.
  data = bundled().runs;
  for (std::size_t k : {std::size_t{100}, std::size_t{2000}}) {  // rows dropped: gaps of 2T, 3T
    data[3].t.erase(data[3].t.begin() + static_cast<std::ptrdiff_t>(k),
                    data[3].t.begin() + static_cast<std::ptrdiff_t>(k + (k == 100 ? 1 : 2)));
  }
  DatasetFit skipped;
  skipped.loop_period_s = 1e-3;
  choose_model_simulation(data, FitPipelineOptions{}, skipped);
  EXPECT_EQ(skipped.simulation.loop_period_s, 1e-3);
  EXPECT_TRUE(has_note(skipped, "2 of "));
  EXPECT_TRUE(has_note(skipped, "sample intervals span skipped ticks"));
  // Gaps in more than 1 % of the intervals: not a loop that skipped a few ticks.
  std::vector<RunData> sparse(1, bundled().runs[3]);
  std::vector<double>& t = sparse[0].t;
  for (std::ptrdiff_t k = static_cast<std::ptrdiff_t>(t.size()) - 2; k > 1; k -= 40) t.erase(t.begin() + k);
  DatasetFit many;
  many.loop_period_s = 1e-3;
  choose_model_simulation(sparse, FitPipelineOptions{}, many);
  EXPECT_EQ(many.simulation.loop_period_s, 0.0);
}

TEST(FitStages, TimeDomainFitOfPosesWithoutSineRuns) {
  // Two square-only poses of the bundled set, 3 s each: no sine runs, no inertia model.
  Dataset ds = bundled().index;
  std::vector<RunData> data;
  ds.runs = {bundled().index.runs[81], bundled().index.runs[100]};
  for (std::size_t i : {81u, 100u}) {
    RunData d = bundled().runs[i];
    const std::size_t n = 3001;
    d.t.resize(n);
    d.r.resize(n);
    d.theta.resize(n);
    d.v.resize(n);
    d.extra_columns.clear();
    data.push_back(d);
  }
  const DatasetFit fit = run_stages(7, ds, data);
  ASSERT_EQ(fit.poses.size(), 2u);
  EXPECT_FALSE(fit.has_inertia_model);
  EXPECT_FALSE(fit.alpha.ok);  // the time-domain α-model is for single-pose datasets
  EXPECT_TRUE(has_note(fit, "the time-domain α-model is fitted for single-pose datasets only"));
  for (const PoseFit& p : fit.poses) {
    ASSERT_TRUE(p.linear.valid) << p.linear.message;
    EXPECT_EQ(p.linear_source, "time domain (output error)");
  }
  EXPECT_EQ(printed(fit.poses[0].linear.c_linear), "11.5");
  EXPECT_EQ(printed(fit.poses[0].linear.beta_tilde_linear), "274");
  EXPECT_EQ(printed(fit.poses[1].linear.c_linear), "8.776");
  // The plant is an α-model: a linear fit to a square wave's response lies between its C (and β̃)
  // at α = 0, where a square spends most of its time, and at the top breakpoint.
  const ExperimentPlan plan = paper_experiment_plan(1);
  const AlphaModel& truth = plan.options.plant.alpha_model;
  const double inertia = plan.poses[plan.runs[81].pose].inertia;
  const double top = truth.alpha[truth.n_breakpoints - 1];
  EXPECT_LT(fit.poses[0].linear.c_linear, truth.damping(0.0, inertia));
  EXPECT_GT(fit.poses[0].linear.c_linear, truth.damping(top, inertia));
  EXPECT_LT(fit.poses[0].linear.beta_tilde_linear, truth.beta_tilde(0.0, inertia));
  EXPECT_GT(fit.poses[0].linear.beta_tilde_linear, truth.beta_tilde(top, inertia));
}

TEST(FitStages, ValidationSimulationsOfEveryRun) {
  DatasetFit fit = bundled_stages(8);
  ASSERT_EQ(fit.validation.size(), 106u);
  for (const RunValidation& v : fit.validation) {
    EXPECT_TRUE(v.simulated) << v.message;
    EXPECT_TRUE(v.alpha.simulated);
  }
  // | runs/sine_25_70_1.5hz.csv | 24.6319 % | 1.3153 % |
  EXPECT_EQ(printed(100 * fit.validation[0].linear.rel_position_error, "%.4f"), "24.6319");
  EXPECT_EQ(printed(100 * fit.validation[0].alpha.rel_position_error, "%.4f"), "1.3153");
  EXPECT_TRUE(fit.validation[0].alpha.fundamental.valid);
  EXPECT_FALSE(fit.validation[105].alpha.fundamental.valid);  // a square run
  // Stage 9 has not run: no figures yet.
  EXPECT_TRUE(std::isnan(fit.alpha_errors.step_median_abs_err));
}

TEST(FitStages, SummariseValidationAsTables8And11) {
  const DatasetFit fit = bundled_stages(9);
  // | 20.01° / 68.43° | 0.524 | 12.24 | 0.003989 | 0.02236 | 0.04614 | 2.904 | 0.000401 | 0.003824 |
  const PoseFit& p0 = fit.poses[0];
  EXPECT_EQ(printed(p0.linear_errors.magnitude_p90), "0.524");
  EXPECT_EQ(printed(p0.linear_errors.phase_p90_deg), "12.24");
  EXPECT_EQ(printed(p0.alpha_errors.step_median_abs_err), "0.000401");
  EXPECT_EQ(printed(p0.alpha_errors.step_p90_abs_err), "0.003824");
  // A square-only pose has no Table 8 figures.
  EXPECT_TRUE(std::isnan(fit.poses[24].alpha_errors.magnitude_p90));
  EXPECT_EQ(printed(fit.poses[24].alpha_errors.step_median_abs_err), "0.0005411");
  // | **median** | 0.5078 | 12.78 | 0.004352 | 0.02305 | 0.04263 | 1.843 | 0.0005537 | 0.004137 |
  EXPECT_EQ(printed(fit.linear_errors.magnitude_p90), "0.5078");
  EXPECT_EQ(printed(fit.linear_errors.step_median_abs_err), "0.004352");
  EXPECT_EQ(printed(fit.alpha_errors.phase_p90_deg), "1.843");
  EXPECT_EQ(printed(fit.alpha_errors.step_median_abs_err), "0.0005537");
  EXPECT_EQ(printed(fit.alpha_errors.step_p90_abs_err), "0.004137");
  EXPECT_LT(fit.alpha_errors.rel_position_error_median, 0.2);  // no "do not describe" note
  EXPECT_FALSE(has_note(fit, "the fitted models do not describe these runs"));
}

/// One pose's 10 runs of the virtual Omni (omni_gen paper --seed SEED --pose POSE), with known
/// disturbance pulses ±amplitude_v (0.1 s every 1 s, recorded as disturbance_v) when > 0.
GeneratedDataset one_pose(std::uint64_t seed, std::size_t pose, double amplitude_v) {
  ExperimentPlanOptions o = paper_plan_options(seed);
  o.sine_poses = {paper_sine_poses()[pose]};
  o.square_poses = o.sine_poses;
  o.disturbance_pulses.amplitude_v = amplitude_v;
  return generate_dataset(make_experiment_plan(o));
}

/// RMS and largest relative error of the sine points' C_data and β_data against `truth`'s.
struct PointErrors {
  double rms = 0.0, max_c = 0.0, max_beta = 0.0;
};
PointErrors point_errors(const DatasetFit& fit, const DatasetFit& truth) {
  PointErrors e;
  EXPECT_EQ(fit.sine_points.size(), truth.sine_points.size());
  for (std::size_t k = 0; k < truth.sine_points.size(); ++k) {
    const LocalLinearPoint& p = fit.sine_points[k].point;
    const LocalLinearPoint& q = truth.sine_points[k].point;
    const double dc = p.c_data / q.c_data - 1.0, db = p.beta_data / q.beta_data - 1.0;
    e.rms += dc * dc + db * db;
    e.max_c = std::max(e.max_c, std::abs(dc));
    e.max_beta = std::max(e.max_beta, std::abs(db));
  }
  e.rms = std::sqrt(e.rms / (2.0 * static_cast<double>(truth.sine_points.size())));
  return e;
}

TEST(FitStages, KnownDisturbanceResponseIsTakenOutOfTheSinePoints) {
  // The same runs with and without pulses (same seed: the same poses and noise): the points of
  // the calm runs are the truth the pulse runs' points should reach. The plant's Coulomb friction
  // (0.004 V) is a known effect, as `omni_fit fit --effect coulomb_friction:coulomb_v=0.004`.
  FitPipelineOptions o;
  o.effects.coulomb_v = 0.004;
  struct Case {
    std::uint64_t seed;
    std::size_t pose;
    double amplitude_v;
    double rms_before, rms_after;  // bounds on PointErrors::rms, measured 0.0318 → 0.00343, …
    double max_beta_after;
  };
  for (const Case& c : {Case{3, 4, 0.05, 0.03, 0.005, 0.01}, Case{7, 2, 0.1, 0.09, 0.04, 0.035}}) {
    SCOPED_TRACE("seed " + std::to_string(c.seed) + ", pose " + std::to_string(c.pose));
    const GeneratedDataset calm = one_pose(c.seed, c.pose, 0.0);
    const GeneratedDataset pulses = one_pose(c.seed, c.pose, c.amplitude_v);
    const DatasetFit truth = run_stages(6, calm.index, calm.runs, o);
    EXPECT_EQ(truth.disturbance_correction.passes, 0);  // no column: the stage does nothing
    FitPipelineOptions off = o;
    off.disturbance_passes = 0;
    const DatasetFit before = run_stages(6, pulses.index, pulses.runs, off);
    EXPECT_EQ(before.disturbance_correction.runs_with_disturbance, 9u);  // counted, not corrected
    EXPECT_EQ(before.disturbance_correction.passes, 0);
    EXPECT_TRUE(has_note(before, "known disturbance response left in the sine points"));
    const DatasetFit after = run_stages(6, pulses.index, pulses.runs, o);
    const PointErrors eb = point_errors(before, truth), ea = point_errors(after, truth);
    std::printf("seed %d: RMS %.3g -> %.3g, max C %.3g -> %.3g, max beta %.3g -> %.3g\n",
                static_cast<int>(c.seed), eb.rms, ea.rms, eb.max_c, ea.max_c, eb.max_beta,
                ea.max_beta);
    EXPECT_GT(eb.rms, c.rms_before);
    EXPECT_LT(ea.rms, c.rms_after);
    EXPECT_LT(ea.rms, 0.4 * eb.rms);
    EXPECT_LT(ea.max_beta, c.max_beta_after);
    EXPECT_LT(ea.max_c, eb.max_c);
    const KnownDisturbanceCorrection& d = after.disturbance_correction;
    EXPECT_EQ(d.runs_with_disturbance, 9u);
    EXPECT_EQ(d.runs_corrected, 9u);
    EXPECT_EQ(d.passes, 3);  // neither settles below 0.1 % in three passes
    EXPECT_GT(d.chosen_pass, 0);
    EXPECT_LT(d.chosen_rms_rad, 0.5 * d.first_pass_rms_rad);  // it predicts the pulse runs better
    EXPECT_TRUE(has_note(after, "known disturbance response taken out of the sine points: 9 of 9"));
  }
}

TEST(FitStages, KnownDisturbanceResponseOfZerosChangesNothing) {
  GeneratedDataset g = one_pose(3, 4, 0.0);
  for (RunData& run : g.runs) run.extra_columns["disturbance_v"].assign(run.size(), 0.0);
  DatasetFit fit = run_stages(5, g.index, g.runs);
  choose_model_simulation(g.runs, FitPipelineOptions{}, fit);
  const DatasetFit before = fit;
  remove_known_disturbance_response(g.index, g.runs, FitPipelineOptions{}, fit);
  ASSERT_EQ(fit.sine_points.size(), 9u);
  for (std::size_t k = 0; k < fit.sine_points.size(); ++k) {
    EXPECT_EQ(fit.sine_points[k].point.c_data, before.sine_points[k].point.c_data);
    EXPECT_EQ(fit.sine_points[k].point.beta_data, before.sine_points[k].point.beta_data);
    EXPECT_EQ(fit.sine_points[k].point.alpha_data, before.sine_points[k].point.alpha_data);
  }
  EXPECT_EQ(fit.alpha.model.c_n1, before.alpha.model.c_n1);
  EXPECT_EQ(fit.notes, before.notes);
  EXPECT_EQ(fit.disturbance_correction.runs_with_disturbance, 0u);
  EXPECT_EQ(fit.disturbance_correction.passes, 0);
}

TEST(FitStages, InOrderTheyAreFitDatasetBitForBit) {
  FitPipelineOptions o;
  o.threads = 2;
  const DatasetFit staged = bundled_stages(9, o);
  const DatasetFit whole = fit_dataset(bundled().index, bundled().runs, o);
  EXPECT_EQ(staged.notes, whole.notes);
  ASSERT_EQ(staged.sine_points.size(), whole.sine_points.size());
  for (std::size_t k = 0; k < whole.sine_points.size(); ++k) {
    EXPECT_EQ(staged.sine_points[k].point.c_data, whole.sine_points[k].point.c_data);
  }
  EXPECT_EQ(staged.inertia.parameters, whole.inertia.parameters);
  EXPECT_EQ(staged.alpha.model.c_n1, whole.alpha.model.c_n1);
  EXPECT_EQ(staged.alpha.model.alpha, whole.alpha.model.alpha);
  EXPECT_EQ(staged.linear_errors.step_median_abs_err, whole.linear_errors.step_median_abs_err);
  EXPECT_EQ(staged.alpha_errors.step_median_abs_err, whole.alpha_errors.step_median_abs_err);
  EXPECT_EQ(staged.alpha_errors.rel_position_error_median,
            whole.alpha_errors.rel_position_error_median);
}

}  // namespace
}  // namespace alphainv
