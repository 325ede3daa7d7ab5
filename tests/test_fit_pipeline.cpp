#include "alphainv/fit_pipeline.hpp"

#include <atomic>
#include <cmath>
#include <map>

#include <gtest/gtest.h>

#include "alphainv/inertia_model.hpp"
#include "alphainv/reference.hpp"

namespace alphainv {
namespace {

/// A dataset made by the α-model itself (fixed point + RK4), at `poses`, with the Table 1 sweep
/// and one 0.25 Hz square run per pose. Ground truth: paper_linear_model(), paper_alpha_model().
void make_dataset(const std::vector<std::pair<double, double>>& poses, Dataset& ds,
                  std::vector<RunData>& data) {
  const LinearModel lin = paper_linear_model();
  ds.controller.kp = 2.0;
  for (const auto& [g1, g2] : poses) {
    JointModelAtPose m;
    m.inertia = lin.inertia.inertia(deg_to_rad(g1), deg_to_rad(g2));
    m.c_linear = lin.damping(m.inertia);
    m.beta_tilde_linear = lin.beta_tilde(m.inertia);
    m.alpha = paper_alpha_model();
    auto add = [&](const Reference& ref, const std::string& kind, double f, double theta0) {
      const auto times = uniform_times(8.0, 1e-3);
      const SimulationResult s = simulate(m, Controller{}, ref, times, {theta0, 0.0, 0.0});
      ASSERT_TRUE(s.ok);
      RunData d;
      d.t = times;
      for (double t : times) d.r.push_back(ref.at(t).r);
      d.theta = s.theta;
      d.v = s.v;
      data.push_back(d);
      RunInfo run;
      run.file = kind + std::to_string(data.size()) + ".csv";
      run.kind = kind;
      run.freq_hz = f;
      run.amplitude_rad = 0.07;
      run.gamma1_deg = g1;
      run.gamma2_deg = g2;
      run.controller = ds.controller;
      ds.runs.push_back(run);
    };
    for (double f : {1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0}) add(SineReference(0.07, f), "sine", f, 0.0);
    add(SquareReference(0.07, 0.25), "square", 0.25, -0.07);
  }
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
  o.validate = false;
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
  const DatasetFit fit = fit_dataset(ds, data, o);
  EXPECT_FALSE(fit.alpha.ok);
  EXPECT_FALSE(fit.poses[0].linear.valid);
  bool said = false;
  for (const auto& n : fit.notes) said = said || n.find("no sine runs") != std::string::npos;
  EXPECT_TRUE(said);
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
