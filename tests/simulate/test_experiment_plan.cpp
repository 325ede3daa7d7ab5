#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/error.hpp"
#include "alphainv/simulate/experiment_plan.hpp"
#include "alphainv/identify/local_linear.hpp"
#include "alphainv/identify/metrics.hpp"
#include "alphainv/rt/alpha_estimator.hpp"

namespace alphainv {
namespace {

constexpr double kTwoPi = 2.0 * kPi;

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// --- (f) the paper's plan
// --------------------------------------------------------------------------

TEST(ExperimentPlan, PaperPlanHasTables1And2) {
  const ExperimentPlan plan = paper_experiment_plan(1);
  std::size_t sines = 0, squares = 0;
  std::set<std::pair<double, double>> sine_poses, square_poses;
  std::multiset<double> freqs;
  std::set<std::string> files;
  std::set<std::uint64_t> seeds;
  for (const PlannedRun& run : plan.runs) {
    const PlannedPose& pose = plan.poses.at(run.pose);
    files.insert(run.file);
    seeds.insert(run.noise_seed);
    EXPECT_LT(run.noise_seed, std::uint64_t{1} << 53);
    // True angles: γ1 = set − 3.5…5.5°, γ2 = set − 0.5…3.6° (Table 3's spread), to 0.01°.
    EXPECT_GE(pose.gamma1_deg - pose.gamma1_set_deg, -5.5 - 1e-9) << run.file;
    EXPECT_LE(pose.gamma1_deg - pose.gamma1_set_deg, -3.5 + 1e-9) << run.file;
    EXPECT_GE(pose.gamma2_deg - pose.gamma2_set_deg, -3.6 - 1e-9) << run.file;
    EXPECT_LE(pose.gamma2_deg - pose.gamma2_set_deg, -0.5 + 1e-9) << run.file;
    EXPECT_NEAR(pose.gamma1_deg * 100.0, std::round(pose.gamma1_deg * 100.0), 1e-6);
    EXPECT_DOUBLE_EQ(pose.inertia, paper_inertia_model().inertia(deg_to_rad(pose.gamma1_deg),
                                                                 deg_to_rad(pose.gamma2_deg)));
    EXPECT_EQ(run.amplitude_rad, 0.07);
    if (run.kind == "sine") {
      ++sines;
      sine_poses.insert({pose.gamma1_set_deg, pose.gamma2_set_deg});
      freqs.insert(run.freq_hz);
      EXPECT_EQ(run.initial_theta_rad, 0.0);
      EXPECT_EQ(run.steady_state_start_s, 4.0);
      // 4 s settle + whole periods covering at least 2 s: exactly 2 s for all Table 1 frequencies.
      EXPECT_NEAR(run.duration_s, 6.0, 1e-12) << run.file;
    } else {
      ASSERT_EQ(run.kind, "square");
      ++squares;
      square_poses.insert({pose.gamma1_set_deg, pose.gamma2_set_deg});
      EXPECT_EQ(run.freq_hz, 0.25);
      EXPECT_EQ(run.duration_s, 8.0);
      EXPECT_EQ(run.initial_theta_rad, -0.07);  // θ(0⁻) = −A, eq. (47)
    }
  }
  EXPECT_EQ(sines, 81u);
  EXPECT_EQ(squares, 25u);
  EXPECT_EQ(files.size(), 106u);
  EXPECT_EQ(seeds.size(), 106u);
  EXPECT_EQ(plan.poses.size(), 25u);  // Table 1's 9 poses are among Table 2's 25
  EXPECT_EQ(sine_poses.size(), 9u);
  EXPECT_EQ(square_poses.size(), 25u);
  for (double g1 : {25.0, 45.0, 65.0}) {
    for (double g2 : {70.0, 90.0, 115.0}) EXPECT_EQ(sine_poses.count({g1, g2}), 1u);
  }
  for (double g1 : {25.0, 35.0, 45.0, 55.0, 65.0}) {
    for (double g2 : {60.0, 70.0, 90.0, 110.0, 115.0}) EXPECT_EQ(square_poses.count({g1, g2}), 1u);
  }
  for (double f : {1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0}) EXPECT_EQ(freqs.count(f), 9u);
  // Bundled effects.
  const VirtualOmniParams& p = plan.options.plant;
  EXPECT_EQ(p.effects.coulomb_v, 0.004);
  EXPECT_EQ(p.measurement.quantisation_rad, 1.5e-4);
  EXPECT_EQ(p.measurement.noise_std_rad, 5e-5);
  EXPECT_EQ(plan.options.controller.kp, 2.0);
  EXPECT_EQ(p.tick_period_s, 1e-3);
}

TEST(ExperimentPlan, TruePosesDependOnSeedAndSetPoseOnly) {
  const ExperimentPlan full = paper_experiment_plan(7);
  ExperimentPlanOptions one = paper_plan_options(7);
  one.sine_poses = {{45.0, 90.0}};
  one.sine_freqs_hz = {3.0};
  one.square_poses = {};
  const ExperimentPlan small = make_experiment_plan(one);
  ASSERT_EQ(small.runs.size(), 1u);
  const auto same = std::find_if(full.poses.begin(), full.poses.end(), [](const PlannedPose& p) {
    return p.gamma1_set_deg == 45.0 && p.gamma2_set_deg == 90.0;
  });
  ASSERT_NE(same, full.poses.end());
  EXPECT_EQ(small.poses[0].gamma1_deg, same->gamma1_deg);
  EXPECT_EQ(small.poses[0].gamma2_deg, same->gamma2_deg);
  const auto run = std::find_if(full.runs.begin(), full.runs.end(),
                                [&](const PlannedRun& r) { return r.file == small.runs[0].file; });
  ASSERT_NE(run, full.runs.end());
  EXPECT_EQ(run->noise_seed, small.runs[0].noise_seed);

  const ExperimentPlan other = paper_experiment_plan(8);
  std::size_t moved = 0;
  for (std::size_t i = 0; i < full.poses.size(); ++i) {
    moved += full.poses[i].gamma1_deg != other.poses[i].gamma1_deg;
  }
  EXPECT_GT(moved, 20u);
}

// --- the dataset ---------------------------------------------------------------------------------

TEST(ExperimentPlan, DatasetIndexHasTheFormatFieldsAndTheTruth) {
  ExperimentPlanOptions o = paper_plan_options(3);
  o.generator_command = "omni_gen paper -o \"x\" --seed 3";
  const ExperimentPlan plan = make_experiment_plan(o);
  const Dataset ds = plan_dataset_index(plan);
  const std::string text = format_dataset_index(ds);  // throws unless it reads back
  const Dataset back = parse_dataset_index(text, "mem");
  EXPECT_EQ(back.joint, "yaw");
  EXPECT_EQ(back.position_unit, "rad");
  EXPECT_EQ(back.command_unit, "V");
  ASSERT_TRUE(back.sample_rate_hz.has_value());
  EXPECT_EQ(*back.sample_rate_hz, 1000.0);
  EXPECT_EQ(back.controller.kp, 2.0);
  EXPECT_FALSE(back.controller.has_limit());
  ASSERT_EQ(back.runs.size(), 106u);
  for (std::size_t i = 0; i < back.runs.size(); ++i) {
    const RunInfo& r = back.runs[i];
    const PlannedPose& pose = plan.poses[plan.runs[i].pose];
    EXPECT_EQ(r.file, plan.runs[i].file);
    EXPECT_EQ(r.kind, plan.runs[i].kind);
    EXPECT_EQ(r.freq_hz, plan.runs[i].freq_hz);
    EXPECT_EQ(r.amplitude_rad, 0.07);
    EXPECT_EQ(r.gamma1_deg, pose.gamma1_deg);  // the true (measured) pose
    EXPECT_EQ(r.gamma2_deg, pose.gamma2_deg);
    EXPECT_EQ(r.controller.kp, 2.0);
    EXPECT_TRUE(contains(r.extra_json, "\"gamma1_set_deg\":" +
                                           std::to_string(static_cast<int>(pose.gamma1_set_deg))))
        << r.extra_json;
    EXPECT_TRUE(
        contains(r.extra_json, "\"noise_seed\":" + std::to_string(plan.runs[i].noise_seed)));
  }
  EXPECT_TRUE(contains(text, "\"format\": \"alphainv-dataset/1\""));
  EXPECT_TRUE(contains(back.extra_json, "\"source\":\"alphainv virtual Omni, seed 3\""));
  EXPECT_TRUE(contains(back.extra_json, "\"generator\":\"omni_gen paper -o \\\"x\\\" --seed 3\""));
  for (const char* part :
       {"\"coulomb_v\":0.004", "\"coulomb_smoothing_rad_s\":0.001", "\"quantisation_rad\":0.00015",
        "\"noise_std_rad\":5e-05", "\"saturation_v\":null", "\"c_n1\":[13.509,21.57,35.316,61.733]",
        "\"beta_n1\":[0.8558,1.3405]", "\"i_base\":0.0014031", "\"cutoff_hz\":25",
        "\"rk4_substeps\":4", "\"seed\":3"}) {
    EXPECT_TRUE(contains(back.extra_json, part)) << part << " not in " << back.extra_json;
  }
}

TEST(ExperimentPlan, GeneratedRunsAreDeterministicAndRoundTripThroughTheFormat) {
  ExperimentPlanOptions o = paper_plan_options(11);
  o.sine_poses = {{65.0, 90.0}};
  o.sine_freqs_hz = {1.5, 7.0};
  o.square_poses = {{35.0, 110.0}};
  const ExperimentPlan plan = make_experiment_plan(o);
  const GeneratedDataset a = generate_dataset(plan);
  const GeneratedDataset b = generate_dataset(plan);
  ASSERT_EQ(a.runs.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(a.runs[i].theta, b.runs[i].theta);
    EXPECT_EQ(a.runs[i].v, b.runs[i].v);
  }
  EXPECT_EQ(a.runs[0].size(), 6001u);  // 0 … 6 s at 1 kHz
  EXPECT_EQ(a.runs[2].size(), 8001u);  // 0 … 8 s
  const RunData& sq = a.runs[2];
  EXPECT_EQ(sq.r.front(), 0.07);
  EXPECT_NEAR(sq.theta.front(), -0.07, 3e-4);  // −A, measured
  EXPECT_EQ(sq.r[2000], -0.07);                // the jump down at 2 s
  for (std::size_t k = 0; k < sq.size(); ++k) {
    EXPECT_DOUBLE_EQ(sq.t[k], static_cast<double>(k) * 1e-3);
    EXPECT_NEAR(sq.theta[k] / 1.5e-4, std::round(sq.theta[k] / 1.5e-4), 1e-9);
  }

  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("alphainv_test_plan_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  write_dataset(dir, a.index, a.runs);
  const Dataset back = read_dataset_index(dir);
  ASSERT_EQ(back.runs.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const RunData d = read_run(back, i);
    EXPECT_EQ(d.t, a.runs[i].t);
    EXPECT_EQ(d.r, a.runs[i].r);
    EXPECT_EQ(d.theta, a.runs[i].theta);
    EXPECT_EQ(d.v, a.runs[i].v);
  }
  std::filesystem::remove_all(dir);
}

TEST(ExperimentPlan, SineRunsRecoverThePlantsAlphaModel) {
  // Effects off: in the sinusoidal steady state v is a sine, the plant's α̂ = |H|²·α is constant and
  // the plant is linear with C(α̂, I), β̃(α̂, I). Eq. (19)-(20) on the fitted response, corrected for
  // the digital loop's half-sample delay (test_virtual_omni: C_data = (C − ω²T/2)/(1 + CT/2),
  // β_data = β/(1 + CT/2)), must give the model's C and β̃ at α = |H|²·α_data (eq. (36)).
  ExperimentPlanOptions o;  // default: effects off
  o.sine_poses = {{65.0, 90.0}, {25.0, 115.0}};
  o.square_poses = {};
  o.record_truth_columns = true;
  const ExperimentPlan plan = make_experiment_plan(o);
  const rt::AlphaEstimator est(o.plant.alpha_filter);
  const double T = o.plant.tick_period_s, kp = o.controller.kp;
  double worst_c = 0.0, worst_bt = 0.0, worst_alpha = 0.0;
  for (std::size_t i = 0; i < plan.runs.size(); ++i) {
    const PlannedRun& run = plan.runs[i];
    const double inertia = plan.poses[run.pose].inertia, w = kTwoPi * run.freq_hz;
    const RunData d = simulate_planned_run(plan, i);
    const IndexRange win = steady_state_window(d.t, run.freq_hz, run.steady_state_start_s);
    const SineFit fit = fit_sine(d.t.data() + win.begin, d.theta.data() + win.begin, win.size(), w);
    const LocalLinearPoint pt = local_linear_point(run.freq_hz, fit.a1, fit.a2, 0.07, kp);
    ASSERT_TRUE(pt.physical) << run.file;
    const double alpha_plant = est.alpha_gain(run.freq_hz) * pt.alpha_data;
    const double c_model = o.plant.alpha_model.damping(alpha_plant, inertia);
    const double bt_model = o.plant.alpha_model.beta_tilde(alpha_plant, inertia);
    const double c_est = pt.c_data * (1.0 + c_model * T / 2.0) + w * w * T / 2.0;
    const double bt_est = pt.beta_data * (1.0 + c_model * T / 2.0) / kp;
    worst_c = std::max(worst_c, std::abs(c_est / c_model - 1.0));
    worst_bt = std::max(worst_bt, std::abs(bt_est / bt_model - 1.0));
    EXPECT_NEAR(c_est, c_model, 2e-3 * c_model) << run.file << " alpha " << pt.alpha_data;
    EXPECT_NEAR(bt_est, bt_model, 2e-3 * bt_model) << run.file;
    // The truth column: the plant's α̂ over the window.
    const std::vector<double>& alpha_true = d.extra_columns.at("alpha_true");
    double mean = 0.0;
    for (std::size_t k = win.begin; k < win.end; ++k) mean += alpha_true[k];
    mean /= static_cast<double>(win.size());
    worst_alpha = std::max(worst_alpha, std::abs(mean / alpha_plant - 1.0));
    EXPECT_NEAR(mean, alpha_plant, 2e-3 * alpha_plant) << run.file;
    EXPECT_GT(est.alpha_gain(run.freq_hz), 0.995);
  }
  std::printf("  [alpha-model recovery] worst relative error: C %.2e, beta~ %.2e, alpha %.2e\n",
              worst_c, worst_bt, worst_alpha);
}

TEST(ExperimentPlan, BundledCoulombIsAboutTwoPercentOfTheTypicalCommand) {
  const ExperimentPlan plan = paper_experiment_plan(1);
  std::vector<double> amplitudes;
  for (std::size_t i = 0; i < plan.runs.size(); ++i) {
    const PlannedRun& run = plan.runs[i];
    if (run.kind != "sine") continue;
    const RunData d = simulate_planned_run(plan, i);
    const IndexRange win = steady_state_window(d.t, run.freq_hz, run.steady_state_start_s);
    const SineFit fit =
        fit_sine(d.t.data() + win.begin, d.v.data() + win.begin, win.size(), kTwoPi * run.freq_hz);
    amplitudes.push_back(std::hypot(fit.a1, fit.a2));
  }
  const double typical = median(amplitudes);
  std::printf("  [bundled] median steady-state command amplitude %.4f V; Fc/that = %.2f %%\n",
              typical, 100.0 * plan.options.plant.effects.coulomb_v / typical);
  EXPECT_GT(plan.options.plant.effects.coulomb_v / typical, 0.015);
  EXPECT_LT(plan.options.plant.effects.coulomb_v / typical, 0.03);
}

// --- validation
// --------------------------------------------------------------------------------------

TEST(ExperimentPlan, InvalidOptionsThrowNamingTheField) {
  struct Case {
    const char* field;
    std::function<void(ExperimentPlanOptions&)> spoil;
  };
  const Case cases[] = {
      {"sine_freqs_hz[1]", [](ExperimentPlanOptions& o) { o.sine_freqs_hz[1] = -2.0; }},
      {"sine_freqs_hz[2]", [](ExperimentPlanOptions& o) { o.sine_freqs_hz[2] = 600.0; }},
      {"sine_freqs_hz[3]",
       [](ExperimentPlanOptions& o) { o.sine_freqs_hz[3] = o.sine_freqs_hz[0]; }},
      {"sine_poses[2]", [](ExperimentPlanOptions& o) { o.sine_poses[2] = o.sine_poses[0]; }},
      {"square_poses[0].gamma2_deg",
       [](ExperimentPlanOptions& o) { o.square_poses[0].gamma2_deg = std::nan(""); }},
      {"sine_amplitude_rad", [](ExperimentPlanOptions& o) { o.sine_amplitude_rad = 0.0; }},
      {"sine_settle_s", [](ExperimentPlanOptions& o) { o.sine_settle_s = -1.0; }},
      {"square_duration_s", [](ExperimentPlanOptions& o) { o.square_duration_s = 0.0; }},
      {"square_freq_hz", [](ExperimentPlanOptions& o) { o.square_freq_hz = -0.25; }},
      {"controller.kp", [](ExperimentPlanOptions& o) { o.controller.kp = std::nan(""); }},
      {"controller.v_limit", [](ExperimentPlanOptions& o) { o.controller.v_limit = 0.0; }},
      {"pose_offsets.gamma1_max_deg",
       [](ExperimentPlanOptions& o) { o.pose_offsets.gamma1_max_deg = -6.0; }},
      {"plant.effects.coulomb_v",
       [](ExperimentPlanOptions& o) { o.plant.effects.coulomb_v = -0.004; }},
      {"plant.measurement.noise_std_rad",
       [](ExperimentPlanOptions& o) { o.plant.measurement.noise_std_rad = -1.0; }},
      {"plant.alpha_filter.sample_period_s",
       [](ExperimentPlanOptions& o) { o.plant.tick_period_s = 2e-3; }},
      {"sine_poses",
       [](ExperimentPlanOptions& o) {
         o.sine_poses.clear();
         o.square_poses.clear();
       }},
  };
  for (const Case& c : cases) {
    ExperimentPlanOptions o = paper_plan_options(1);
    c.spoil(o);
    try {
      (void)make_experiment_plan(o);
      ADD_FAILURE() << "no error for " << c.field;
    } catch (const Error& e) {
      EXPECT_EQ(e.field(), c.field) << e.what();
    }
  }
  // An inertia model that is negative at the poses is named (with the pose in the message).
  ExperimentPlanOptions o = paper_plan_options(1);
  o.plant.inertia.i1 = -0.02;
  try {
    (void)make_experiment_plan(o);
    ADD_FAILURE() << "no error for a negative inertia";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "plant.inertia") << e.what();
  }
  EXPECT_THROW((void)planned_plant(paper_experiment_plan(1), 106), Error);
}

}  // namespace
}  // namespace alphainv
