// Tests of include/alphainv/identify/validation.hpp: a model validated on runs it simulated itself
// (the truth known), with noise, with a wrong model, and with runs it cannot simulate.
#include "alphainv/identify/validation.hpp"

#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "alphainv/data/model_file.hpp"
#include "alphainv/simulate/model_simulation.hpp"

namespace alphainv {
namespace {

ModelFile paper_model() {
  return read_model_file(std::string(ALPHAINV_SOURCE_DIR) + "/tests/fixtures/paper_model.json");
}

/// Runs of `model` at pose 60.08/87 deg: sines at 2 and 5 Hz and a square wave, θ plus noise.
void simulated_dataset(const ModelFile& model, double noise_std, Dataset& ds, std::vector<RunData>& data) {
  const JointModelAtPose joint = model_at(model, 60.08, 87.0, true);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  int i = 0;
  for (const auto& [kind, f] : {std::pair{ModelRunReference::kSine, 2.0},
                                {ModelRunReference::kSine, 5.0},
                                {ModelRunReference::kSquare, 0.5}}) {
    ModelRunOptions o;
    o.reference = kind;
    o.freq_hz = f;
    o.duration_s = 3.0;
    const ModelRun run = simulate_model_run(model, joint, o, 60.08, 87.0);
    ASSERT_TRUE(run.ok) << run.message;
    if (ds.runs.empty()) ds = model_run_dataset(model, run, 1000.0);
    else ds.runs.push_back(run.info);
    ds.runs.back().file = "runs/r" + std::to_string(i++) + ".csv";
    RunData d = run.data;
    for (double& th : d.theta) th += noise_std * g(rng);
    data.push_back(d);
  }
}

TEST(Validation, TheModelOnItsOwnRunsFitsToTheNoise) {
  const ModelFile model = paper_model();
  Dataset ds;
  std::vector<RunData> data;
  simulated_dataset(model, 0.0, ds, data);
  const ValidationResult clean = validate_model(model, ds, data);
  ASSERT_TRUE(clean.ok) << clean.message;
  ASSERT_EQ(clean.runs.size(), 3u);
  for (const ValidatedRun& r : clean.runs) ASSERT_TRUE(r.ok) << r.file << ": " << r.message;
  // The same model, controller and reference: only the initial velocity, estimated from the first
  // 10 ms of a run that starts from rest, differs (its transient is the 5e-5 rad left).
  EXPECT_LT(clean.position.rms, 1e-4) << clean.full_report();
  EXPECT_GT(clean.position.fit_percent, 99.5);
  EXPECT_LT(clean.command.relative_error, 1e-2);  // the closed loop's command is predicted too
  // With the initial state fitted on the first 100 samples, the rest agrees much better.
  ValidationOptions fitted_start;
  fitted_start.initial_samples = 100;
  const ValidationResult refined = validate_model(model, ds, data, fitted_start);
  ASSERT_TRUE(refined.ok);
  EXPECT_LT(refined.position.rms, 0.5 * clean.position.rms) << refined.full_report();

  Dataset nds;
  std::vector<RunData> noisy;
  simulated_dataset(model, 2e-4, nds, noisy);
  const ValidationResult vn = validate_model(model, nds, noisy, fitted_start);
  ASSERT_TRUE(vn.ok);
  EXPECT_NEAR(vn.position.rms, 2e-4, 2e-5) << vn.full_report();  // the noise floor
  EXPECT_EQ(vn.runs_tested, 3u);
  EXPECT_GE(vn.runs_white, 2u) << vn.full_report();  // white noise is (almost always) white
  EXPECT_NE(vn.brief_report().find("validated 3/3 runs"), std::string::npos) << vn.brief_report();
}

TEST(Validation, AWrongModelShowsInTheFiguresAndTheResidualTests) {
  const ModelFile truth = paper_model();
  Dataset ds;
  std::vector<RunData> data;
  simulated_dataset(truth, 2e-4, ds, data);
  ModelFile wrong = truth;
  for (std::size_t k = 0; k < wrong.alpha.n_breakpoints; ++k) wrong.alpha.c_n1[k] *= 1.3;  // damping 30 % high
  const ValidationResult good = validate_model(truth, ds, data);
  const ValidationResult bad = validate_model(wrong, ds, data);
  ASSERT_TRUE(bad.ok);
  EXPECT_GT(bad.position.rms, 3.0 * good.position.rms);
  EXPECT_LT(bad.position.fit_percent, good.position.fit_percent);
  EXPECT_LT(bad.runs_white, good.runs_white + 1);
  EXPECT_GE(bad.runs_input_correlated, 2u) << bad.full_report();  // it misses input dynamics
  EXPECT_NE(bad.full_report().find("misses"), std::string::npos);
}

TEST(Validation, InitialSamplesAreFittedAndLeftOutOfTheFigures) {
  const ModelFile model = paper_model();
  Dataset ds;
  std::vector<RunData> data;
  simulated_dataset(model, 0.0, ds, data);
  // The square run starts at −A: shift its first samples' record so the measured start is off.
  RunData& sq = data[2];
  const double true_start = sq.theta[0];
  sq.theta[0] += 0.01;  // one bad first sample: the measured initial state is 10 mrad off
  ValidationOptions o;
  const ValidationResult measured = validate_model(model, ds, data, o);
  o.initial_samples = 50;
  const ValidationResult fitted = validate_model(model, ds, data, o);
  ASSERT_TRUE(fitted.ok);
  EXPECT_EQ(fitted.runs[2].first_sample, 50u);
  EXPECT_EQ(fitted.runs[2].position.n, sq.size() - 50);
  EXPECT_LT(fitted.runs[2].position.rms, 0.2 * measured.runs[2].position.rms);
  (void)true_start;
}

TEST(Validation, KnownDisturbancePulsesEnterFromTheRunsColumn) {
  const ModelFile model = paper_model();
  const JointModelAtPose joint = model_at(model, 60.08, 87.0, true);
  // Pulses of ±0.04 V for 0.1 s every 0.5 s (the truth), on a 2 Hz sine run with σ = 2e-4 rad.
  RunData pulses;
  pulses.t = uniform_times(3.0, 1e-3);
  pulses.r = pulses.theta = pulses.v = std::vector<double>(pulses.t.size(), 0.0);
  std::vector<double>& d = pulses.extra_columns["disturbance_v"];
  for (double t : pulses.t) {
    const double phase = std::fmod(t, 0.5);
    d.push_back(phase >= 0.2 && phase < 0.3 ? (std::fmod(t, 1.0) < 0.5 ? 0.04 : -0.04) : 0.0);
  }
  ModelRunOptions o;
  o.freq_hz = 2.0;
  o.duration_s = 3.0;
  o.known_inputs = &pulses;
  const ModelRun run = simulate_model_run(model, joint, o, 60.08, 87.0);
  ASSERT_TRUE(run.ok) << run.message;
  ASSERT_NE(run.data.column("disturbance_v"), nullptr);  // recorded with the run
  EXPECT_EQ(*run.data.column("disturbance_v"), d);
  Dataset ds = model_run_dataset(model, run, 1000.0);
  RunData noisy = run.data;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g(0.0, 2e-4);
  for (double& th : noisy.theta) th += g(rng);
  const std::vector<RunData> data{noisy};
  ValidationOptions used;
  used.initial_samples = 100;
  ValidationOptions ignored = used;
  ignored.use_known_inputs = false;
  const ValidationResult with = validate_model(model, ds, data, used);
  const ValidationResult without = validate_model(model, ds, data, ignored);
  ASSERT_TRUE(with.ok && without.ok) << with.message << without.message;
  EXPECT_NEAR(with.position.rms, 2e-4, 2e-5) << with.full_report();  // the noise floor
  EXPECT_GT(without.position.rms, 5.0 * with.position.rms) << without.full_report();
  EXPECT_TRUE(with.runs[0].residual.white) << with.full_report();
  EXPECT_FALSE(without.runs[0].residual.white) << without.full_report();
}

TEST(Validation, RunsItCannotSimulateAreNamedAndLeftOut) {
  const ModelFile model = paper_model();
  Dataset ds;
  std::vector<RunData> data;
  simulated_dataset(model, 0.0, ds, data);
  ds.runs[1].gamma1_deg.reset();  // the inertia model needs the pose
  const ValidationResult v = validate_model(model, ds, data);
  ASSERT_TRUE(v.ok);
  EXPECT_FALSE(v.runs[1].ok);
  EXPECT_NE(v.runs[1].message.find("gamma1_deg"), std::string::npos) << v.runs[1].message;
  EXPECT_EQ(v.position.n, data[0].size() + data[2].size());
  EXPECT_NE(v.full_report().find("runs/r1.csv: not validated"), std::string::npos) << v.full_report();
  ValidationOptions bad;
  bad.residual.confidence = 1.5;
  EXPECT_THROW(validate_model(model, ds, data, bad), Error);
  data.pop_back();
  EXPECT_FALSE(validate_model(model, ds, data).ok);  // 3 runs named, 2 read
}

}  // namespace
}  // namespace alphainv
