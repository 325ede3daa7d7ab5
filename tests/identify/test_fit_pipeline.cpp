#include "alphainv/identify/fit_pipeline.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>

#include <gtest/gtest.h>

#include "alphainv/error.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "alphainv/simulate/reference.hpp"
#include "support/error_of.hpp"
#include "support/model_dataset.hpp"

namespace alphainv {
namespace {

using test::error_of;

/// A dataset made by the α-model itself (fixed point + RK4), at `poses`, with the Table 1 sweep
/// and one 0.25 Hz square run per pose, the plant with `effects`. Ground truth:
/// paper_linear_model(), paper_alpha_model().
void make_dataset(const std::vector<std::pair<double, double>>& poses, Dataset& ds,
                  std::vector<RunData>& data, const Effects& effects = {}) {
  test::ModelDatasetPlan plan;
  plan.poses_deg = poses;
  plan.effects = effects;
  test::append_model_runs(plan, ds, data);
}

TEST(FitPipeline, RecoversModelFromItsOwnSimulation) {
  Dataset ds;
  std::vector<RunData> data;
  make_dataset({{21.54, 69.54}, {19.31, 112.44}, {40.68, 68.52}, {39.83, 87.63},
                {60.68, 67.62}, {60.08, 87.00}, {59.56, 111.45}},
               ds, data);
  const DatasetFit fit = fit_dataset(ds, data);
  ASSERT_EQ(fit.poses.size(), 7u);
  ASSERT_TRUE(fit.has_inertia_model) << fit.inertia.message;
  ASSERT_TRUE(fit.alpha.ok) << fit.alpha.message;
  // The inertia model predicts each pose's linear parameters (identifiable), within a few per cent
  // of the linear fits it was given.
  EXPECT_LT(fit.inertia.rms_relative_c, 0.05);
  EXPECT_LT(fit.inertia.rms_relative_beta_tilde, 0.03);
  // The α-model fits its own steady states.
  EXPECT_LT(fit.alpha.c_rms_relative, 0.05);
  EXPECT_LT(fit.alpha.beta_rms_relative, 0.04);  // includes the inertia model's own β̃ error (< 3 %)
  // Validation: the α-model reproduces the α-model's step responses far better than the linear.
  ASSERT_TRUE(std::isfinite(fit.alpha_errors.step_median_abs_err));
  EXPECT_GT(fit.linear_errors.step_median_abs_err / fit.alpha_errors.step_median_abs_err, 2.6);
  EXPECT_LT(fit.alpha_errors.phase_p90_deg, 0.5 * fit.linear_errors.phase_p90_deg);
  // What it identified, in one line and in full.
  ASSERT_TRUE(fit.usable());
  EXPECT_EQ(fit.message,
            "identified: a linear model at 7 of 7 poses (7 by the sine runs (22), every pose with "
            "angles by the inertia model (27)-(29)), the α-model (sine (2.3.5))");
  EXPECT_EQ(fit.brief_report(),
            "dataset fit: usable; 70 runs, 7 poses, 63 sine points (0 non-physical); linear model "
            "at 7 of 7 poses, inertia model, α-model (sine (2.3.5)); step median |θ_sim − θ|: "
            "linear 0.004111, α 7.072e-08");
  const std::string full = fit.full_report();
  EXPECT_EQ(full.substr(0, full.find('\n')), fit.brief_report());
  for (const std::string& line :
       {fit.message,
        std::string("  local points (19)-(20), (36): 63 from the sine runs, kp 2, continuous loop"),
        std::string("  linear model at 21.54° / 69.54°: C_linear 5.278 1/s, β̃_linear 217.9, I "
                    "0.004587 (sine (22))"),
        "  " + fit.inertia.brief_report(),
        std::string("  α-model (sine (2.3.5)): N = 4, α_n = 0, 2.2, 25, 203.8; C_n1 = 13.24, "
                    "21.14, 34.62, 52.45; β̃_n1 = 0.8389, 1.189 at α = 0, 203.8; RMS relative "
                    "error C 0.06 %, β̃ 0.03 %"),
        std::string("  validation, linear model: mag p90 0.4909, phase p90 11.83°, step median "
                    "0.004111, step p90 0.02153, relative position error median 0.1587"),
        "    - " + fit.notes.front()}) {
    EXPECT_NE(full.find(line + "\n"), std::string::npos) << line << "\nin\n" << full;
  }
}

TEST(FitPipeline, OnePoseSaysWhyNoInertiaModel) {
  Dataset ds;
  std::vector<RunData> data;
  make_dataset({{60.08, 87.00}}, ds, data);
  const DatasetFit fit = fit_dataset(ds, data);
  EXPECT_FALSE(fit.has_inertia_model);
  bool said = false;
  for (const auto& n : fit.notes) said = said || n.find("inertia model (6) skipped") != std::string::npos;
  EXPECT_TRUE(said);
  EXPECT_TRUE(fit.alpha.ok);
  EXPECT_DOUBLE_EQ(fit.poses[0].inertia, 1.0);
  // Per-pose model: C(α) at I = 1 is C itself; compare with Table 10 at α = 25 (6.486).
  EXPECT_NEAR(fit.alpha.model.damping(25.0, 1.0), 6.486, 0.05 * 6.486);
}

TEST(FitPipeline, DigitalLoopCorrectionFollowsTheSampleRateAndCanBeSwitchedOff) {
  Dataset ds;
  std::vector<RunData> data;
  make_dataset({{60.08, 87.00}}, ds, data);
  FitPipelineOptions o;
  o.run_validation = false;
  auto said = [](const DatasetFit& f, const char* what) {
    bool found = false;
    for (const auto& n : f.notes) found = found || n.find(what) != std::string::npos;
    return found;
  };
  // No sample rate (this continuous simulation): (19)-(20) as printed.
  const DatasetFit cont = fit_dataset(ds, data, o);
  EXPECT_EQ(cont.loop_period_s, 0.0);
  EXPECT_TRUE(said(cont, "continuous loop assumed"));
  for (const auto& sp : cont.sine_points) EXPECT_EQ(sp.point.c_data, sp.point.c_data_continuous);
  // A sample rate: the digital loop's period, and the points are inverted for it.
  ds.sample_rate_hz = 1000.0;
  const DatasetFit dig = fit_dataset(ds, data, o);
  EXPECT_DOUBLE_EQ(dig.loop_period_s, 1e-3);
  EXPECT_TRUE(said(dig, "digital-loop correction"));
  ASSERT_FALSE(dig.sine_points.empty());
  for (const auto& sp : dig.sine_points) {
    if (!sp.point.physical) continue;
    EXPECT_TRUE(sp.point.sampled_exact);
    EXPECT_GT(sp.point.c_data, sp.point.c_data_continuous);  // (19) reads C low by ≈ ω²T/2
  }
  // Switched off explicitly.
  o.loop_period_s = 0.0;
  EXPECT_EQ(fit_dataset(ds, data, o).loop_period_s, 0.0);
}

TEST(FitPipeline, NoSineRunsSaysSoWithoutTheTimeDomainFit) {
  Dataset ds;
  std::vector<RunData> data;
  make_dataset({{60.08, 87.00}}, ds, data);
  for (auto& r : ds.runs) r.kind = "other";
  FitPipelineOptions o;
  o.time_domain = false;
  o.run_validation = false;
  const DatasetFit fit = fit_dataset(ds, data, o);
  EXPECT_FALSE(fit.alpha.ok);
  EXPECT_FALSE(fit.poses[0].linear.valid);
  bool said = false;
  for (const auto& n : fit.notes) said = said || n.find("no sine runs") != std::string::npos;
  EXPECT_TRUE(said);
  // Not usable, and its reports say so.
  EXPECT_FALSE(fit.usable());
  EXPECT_EQ(fit.message, "no model could be identified: no pose has a linear model and there is "
                         "no α-model (the notes say why)");
  EXPECT_EQ(fit.brief_report(),
            "dataset fit: NOT usable; 10 runs, 1 poses, 0 sine points (0 non-physical); linear "
            "model at 0 of 1 poses, no inertia model, no α-model");
  const std::string full = fit.full_report();
  EXPECT_NE(full.find("  validation: not run\n"), std::string::npos) << full;
  EXPECT_NE(full.find("  inertia model: none\n"), std::string::npos) << full;
  EXPECT_NE(full.find("    - no sine runs with freq_hz under a P law"), std::string::npos) << full;
}

TEST(FitPipeline, NoSineRunsFitsInTheTimeDomain) {
  Dataset full;
  std::vector<RunData> all;
  make_dataset({{60.08, 87.00}}, full, all);
  // Two runs, "other" kind, cut to 4 s: a 2 Hz sine and the square wave.
  Dataset ds = full;
  ds.runs = {full.runs[1], full.runs[9]};
  std::vector<RunData> data = {all[1], all[9]};
  for (auto& r : ds.runs) r.kind = "other";
  for (auto& d : data) {
    const std::size_t n = 4001;
    d.t.resize(n);
    d.r.resize(n);
    d.theta.resize(n);
    d.v.resize(n);
  }
  const DatasetFit fit = fit_dataset(ds, data);
  ASSERT_TRUE(fit.poses[0].linear.valid) << fit.poses[0].linear.message;
  EXPECT_EQ(fit.poses[0].linear_source, "time domain (output error)");
  ASSERT_TRUE(fit.alpha.ok) << fit.alpha.message;
  EXPECT_EQ(fit.alpha_source, "time domain (output error)");
  EXPECT_EQ(fit.simulation.loop_period_s, 0.0);  // no sample rate: the continuous law
  // The data came from the α-model itself (noise-free): the α-model reproduces it closely, and
  // better than the linear one.
  EXPECT_LT(fit.alpha_errors.rel_position_error_median, 0.05);
  EXPECT_LT(fit.alpha_errors.rel_position_error_median,
            0.5 * fit.linear_errors.rel_position_error_median);
  // Honest reports (#14): identifiability from the output-error SEs and correlations, and no
  // relative error on local points that do not exist.
  EXPECT_TRUE(fit.alpha.c_n1_identifiable[0]) << fit.full_report();
  EXPECT_TRUE(fit.alpha.breakpoint_identifiable[1]);
  EXPECT_TRUE(std::isnan(fit.alpha.c_rms_relative));
  const std::string report = fit.full_report();
  EXPECT_EQ(report.find("RMS relative error C 0.00 %"), std::string::npos) << report;
  EXPECT_NE(report.find("no local points to measure relative errors on"), std::string::npos)
      << report;
}

bool has_note(const DatasetFit& f, const char* what) {
  bool found = false;
  for (const auto& n : f.notes) found = found || n.find(what) != std::string::npos;
  return found;
}

TEST(FitPipeline, KnownEffectsOffLeaveTheFitUnchanged) {
  // Effects all off (a Coulomb smoothing alone switches nothing on): the fit of the option's
  // default, number for number.
  Dataset ds;
  std::vector<RunData> data;
  make_dataset({{60.08, 87.00}}, ds, data);
  ds.sample_rate_hz = 1000.0;
  FitPipelineOptions o;
  o.threads = 1;
  const DatasetFit plain = fit_dataset(ds, data, o);
  o.effects.coulomb_smoothing_rad_s = 0.05;
  ASSERT_TRUE(active_effects(o.effects).empty());
  const DatasetFit off = fit_dataset(ds, data, o);
  ASSERT_TRUE(plain.alpha.ok);
  ASSERT_EQ(plain.sine_points.size(), off.sine_points.size());
  for (std::size_t k = 0; k < plain.sine_points.size(); ++k) {
    EXPECT_EQ(plain.sine_points[k].point.c_data, off.sine_points[k].point.c_data);
    EXPECT_EQ(plain.sine_points[k].point.beta_data, off.sine_points[k].point.beta_data);
    EXPECT_EQ(plain.sine_points[k].point.alpha_data, off.sine_points[k].point.alpha_data);
  }
  EXPECT_EQ(plain.alpha.model.c_n1, off.alpha.model.c_n1);
  EXPECT_EQ(plain.alpha.model.beta_n1, off.alpha.model.beta_n1);
  EXPECT_EQ(plain.alpha_errors.rel_position_error_median,
            off.alpha_errors.rel_position_error_median);
  EXPECT_EQ(plain.notes, off.notes);
  EXPECT_FALSE(has_note(off, "known effects"));
}

TEST(FitPipeline, KnownCoulombFrictionCorrectsThePointsAndIsSimulated) {
  // The α-model's own runs with Coulomb friction Fc = 0.01 V in the plant (continuous loop): told
  // Fc, the fit reads the points against v + n(θ, θ̇) and simulates with the friction; not told,
  // the points carry the friction's extra damping 4·β̃·Fc/(π·ω·A0) and the simulations miss it.
  Effects coulomb;
  coulomb.coulomb_v = 0.01;
  Dataset ds;
  std::vector<RunData> data;
  make_dataset({{60.08, 87.00}}, ds, data, coulomb);
  FitPipelineOptions o;
  o.threads = 1;
  const DatasetFit unknown = fit_dataset(ds, data, o);
  o.effects = coulomb;
  const DatasetFit known = fit_dataset(ds, data, o);
  ASSERT_TRUE(known.alpha.ok && unknown.alpha.ok);
  EXPECT_EQ(known.effects.coulomb_v, 0.01);
  EXPECT_EQ(known.model_for_pose(0).effects.coulomb_v, 0.01);
  EXPECT_EQ(unknown.model_for_pose(0).effects.coulomb_v, 0.0);
  EXPECT_TRUE(has_note(known, "known effects: coulomb_friction (coulomb_v = 0.01, "
                              "coulomb_smoothing_rad_s = 0.001)"));
  EXPECT_FALSE(has_note(unknown, "known effects"));
  // The points against the plant's C(α_data), β̃(α_data) (I = 1 per pose without an inertia
  // model: compare C·I and β̃·I, which the pose's scale leaves unchanged).
  const LinearModel lin = paper_linear_model();
  const double inertia = lin.inertia.inertia(deg_to_rad(60.08), deg_to_rad(87.00));
  const AlphaModel truth = paper_alpha_model();
  auto worst = [&](const DatasetFit& f) {
    double c = 0.0, b = 0.0;
    for (const auto& sp : f.sine_points) {
      const double a = sp.point.alpha_data;
      c = std::max(c, std::abs(sp.point.c_data / truth.damping(a, inertia) - 1.0));
      b = std::max(b, std::abs(sp.point.beta_data / (f.kp * truth.beta_tilde(a, inertia)) - 1.0));
    }
    return std::make_pair(c, b);
  };
  const auto [c_known, b_known] = worst(known);
  const auto [c_unknown, b_unknown] = worst(unknown);
  EXPECT_GT(c_unknown, 0.1);
  EXPECT_LT(c_known, 0.05);
  EXPECT_LT(b_known, 0.03);
  // Gain and phase stay those of θ against r.
  for (std::size_t k = 0; k < known.sine_points.size(); ++k) {
    EXPECT_EQ(known.sine_points[k].gain, unknown.sine_points[k].gain);
    EXPECT_EQ(known.sine_points[k].phase_deg, unknown.sine_points[k].phase_deg);
  }
  // The validation simulates the friction: the α-model with it reproduces the runs better.
  EXPECT_LT(known.alpha_errors.rel_position_error_median,
            unknown.alpha_errors.rel_position_error_median);
  EXPECT_LT(known.alpha_errors.step_median_abs_err, unknown.alpha_errors.step_median_abs_err);
}

TEST(FitPipeline, KnownEffectsOutOfRangeThrowNamingTheField) {
  Dataset ds;
  std::vector<RunData> data;
  make_dataset({{60.08, 87.00}}, ds, data);
  FitPipelineOptions o;
  o.effects.coulomb_v = -1.0;
  EXPECT_EQ(error_of([&] { fit_dataset(ds, data, o); }).field(),
            "FitPipelineOptions::effects.coulomb_v");
}

TEST(FitPipeline, OptionsValidateThemselvesNamingTheField) {
  EXPECT_NO_THROW(FitPipelineOptions{}.validate());
  auto field = [](const FitPipelineOptions& o) { return error_of([&] { o.validate(); }).field(); };
  FitPipelineOptions o;
  o.settle_fraction = 1.0;
  EXPECT_EQ(field(o), "FitPipelineOptions::settle_fraction");
  o = FitPipelineOptions{};
  o.n_breakpoints = 9;
  EXPECT_EQ(field(o), "FitPipelineOptions::n_breakpoints");
  o = FitPipelineOptions{};
  o.loop_period_s = -1e-3;
  EXPECT_EQ(field(o), "FitPipelineOptions::loop_period_s");
  o.loop_period_s = 0.0;  // off
  EXPECT_NO_THROW(o.validate());
  o.effects.delay_s = -1.0;
  EXPECT_EQ(field(o), "FitPipelineOptions::effects.delay_s");
  o = FitPipelineOptions{};
  o.disturbance_passes = -1;
  EXPECT_EQ(field(o), "FitPipelineOptions::disturbance_passes");
  o.disturbance_passes = 0;  // off
  EXPECT_NO_THROW(o.validate());
  o = FitPipelineOptions{};
  o.n_breakpoints = 1;
  Dataset ds;
  std::vector<RunData> data;
  make_dataset({{60.08, 87.00}}, ds, data);
  EXPECT_STREQ(error_of([&] { fit_dataset(ds, data, o); }).what(),
               "'FitPipelineOptions::n_breakpoints': expected 2 to 8 breakpoints, got 1");
}

TEST(FitPipeline, ReportsProgressOfEveryStage) {
  Dataset ds;
  std::vector<RunData> data;
  make_dataset({{21.54, 69.54}, {19.31, 112.44}, {40.68, 68.52}, {39.83, 87.63}, {60.68, 67.62},
                {60.08, 87.00}},
               ds, data);
  FitPipelineOptions opt;
  opt.threads = 3;
  std::map<std::string, std::pair<std::size_t, std::size_t>> last;  // stage: (done, total)
  std::atomic<int> inside{0};
  bool overlapped = false, decreased = false;
  opt.progress = [&](std::string_view stage, std::size_t done, std::size_t total) {
    overlapped = overlapped || ++inside > 1;
    auto& l = last[std::string(stage)];
    decreased = decreased || done < l.first;
    l = {done, total};
    --inside;
  };
  const DatasetFit fit = fit_dataset(ds, data, opt);
  ASSERT_TRUE(fit.alpha.ok);
  EXPECT_FALSE(overlapped);
  EXPECT_FALSE(decreased);
  const std::size_t n = ds.runs.size();
  using P = std::pair<std::size_t, std::size_t>;
  EXPECT_EQ(last["local fits"], P(n, n));
  EXPECT_EQ(last["inertia fit"], P(1, 1));
  EXPECT_EQ(last["alpha breakpoint search"], P(1, 1));
  EXPECT_EQ(last["validation simulations"], P(n, n));
  EXPECT_EQ(last["time-domain fit"], P(1, 1));
  EXPECT_EQ(last.size(), 5u);
}

}  // namespace
}  // namespace alphainv
