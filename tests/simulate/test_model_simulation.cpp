#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "alphainv/data/dataset.hpp"
#include "alphainv/error.hpp"
#include "alphainv/simulate/experiment_plan.hpp"
#include "alphainv/identify/local_linear.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "alphainv/simulate/model_simulation.hpp"

namespace alphainv {
namespace {

namespace fs = std::filesystem;

/// The paper's model (Tables 3-7) as omni_fit would write it, under the paper's P law kp = 2 V/rad.
ModelFile paper_model() {
  ModelFile m;
  m.tool_version = "test";
  m.controller.kp = 2.0;
  m.has_inertia_model = true;
  m.linear = paper_linear_model();
  m.linear_se.fill(std::nan(""));
  m.has_alpha_model = true;
  m.alpha = paper_alpha_model();
  m.c_n1_se.fill(std::nan(""));
  m.beta_n1_se.fill(std::nan(""));
  return m;
}

// The paper's 65°/90° pose: true angles 60.08°, 87.00°.
constexpr double kG1 = 60.08, kG2 = 87.00;

JointModelAtPose direct_model(bool use_alpha) {
  return model_at_pose(paper_linear_model(), paper_alpha_model(), deg_to_rad(kG1), deg_to_rad(kG2),
                       use_alpha);
}

/// Fundamental gain and phase [deg] of theta/r over the last whole periods after `settle_s`.
std::pair<double, double> gain_phase(const RunData& d, double f, double amplitude,
                                     double settle_s) {
  const IndexRange w = steady_state_window(d.t, f, settle_s);
  const SineFit s = fit_sine(d.t.data() + w.begin, d.theta.data() + w.begin, w.size(), 2 * kPi * f);
  return {s.amplitude() / amplitude, s.phase_rad() * 180.0 / kPi};
}

TEST(ModelAt, InertiaModelGivesEq6AtThePose) {
  ModelFile m = paper_model();
  m.effects.offset_v = 0.05;
  std::string note;
  const JointModelAtPose a = model_at(m, kG1, kG2, true, &note);
  const JointModelAtPose d = direct_model(true);
  EXPECT_EQ(a.inertia, d.inertia);
  EXPECT_NEAR(a.inertia, 0.004366, 0.0005 * 0.004366);  // Table 10
  EXPECT_EQ(a.c_linear, d.c_linear);
  EXPECT_EQ(a.beta_tilde_linear, d.beta_tilde_linear);
  EXPECT_TRUE(a.use_alpha);
  EXPECT_EQ(a.alpha.c_n1, d.alpha.c_n1);
  EXPECT_EQ(a.effects.offset_v, 0.05);
  EXPECT_NE(note.find("inertia model"), std::string::npos) << note;
  EXPECT_FALSE(model_at(m, kG1, kG2, false).use_alpha);
}

TEST(ModelAt, WithoutInertiaModelUsesTheNearestPose) {
  ModelFile m = paper_model();
  m.has_inertia_model = false;
  m.poses = {{65.0, 90.0, 6.2, 229.0}, {45.0, 90.0, 5.0, 200.0}};
  m.effects.delay_s = 0.002;
  std::string note;
  const JointModelAtPose a = model_at(m, 44.0, 91.0, false, &note);
  EXPECT_EQ(a.c_linear, 5.0);
  EXPECT_EQ(a.beta_tilde_linear, 200.0);
  EXPECT_EQ(a.inertia, 1.0);
  EXPECT_EQ(a.effects.delay_s, 0.002);
  EXPECT_NE(note.find("nearest pose, 45/90 deg"), std::string::npos) << note;
  EXPECT_EQ(model_at(m, 64.0, 80.0, false).c_linear, 6.2);
  // Several poses and no pose: which one is not ours to guess.
  EXPECT_THROW(model_at(m, std::nullopt, std::nullopt, false), Error);
  m.poses.resize(1);
  const JointModelAtPose only = model_at(m, std::nullopt, std::nullopt, false, &note);
  EXPECT_EQ(only.c_linear, 6.2);
  EXPECT_NE(note.find("the only pose"), std::string::npos) << note;
}

TEST(ModelAt, SaysWhatTheModelLacks) {
  ModelFile m = paper_model();
  try {
    model_at(m, std::nullopt, std::nullopt, true);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "gamma1_deg");
  }
  m.has_alpha_model = false;
  try {
    model_at(m, kG1, kG2, true);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "alpha_model");
  }
  m.has_inertia_model = false;
  try {
    model_at(m, kG1, kG2, false);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "poses");
  }
}

TEST(SimulateModelRun, SineIsExactlyWhatSimulateGives) {
  const ModelFile m = paper_model();
  ModelRunOptions o;  // --sine 3Hz --amplitude 0.07 --duration 8s at 1 kHz
  const ModelRun run = simulate_model_run(m, model_at(m, kG1, kG2, true), o, kG1, kG2);
  ASSERT_TRUE(run.ok) << run.message;
  const std::vector<double> times = uniform_times(8.0, 1e-3);
  const SimulationResult s =
      simulate(direct_model(true), m.controller, SineReference(0.07, 3.0), times);
  ASSERT_TRUE(s.ok);
  ASSERT_EQ(run.data.size(), 8001u);
  EXPECT_EQ(run.data.t, s.t);
  EXPECT_EQ(run.data.theta, s.theta);
  EXPECT_EQ(run.data.v, s.v);
  EXPECT_EQ(run.data.extra_columns.at("alpha"), s.alpha);
  EXPECT_EQ(run.data.extra_columns.at("C"), s.damping);
  EXPECT_EQ(run.data.extra_columns.at("beta_tilde"), s.beta_tilde);
  EXPECT_EQ(run.data.extra_columns.at("theta_dot"), s.theta_dot);
  EXPECT_EQ(run.data.theta.front(), 0.0);  // θ(0) = 0 for a sine
  EXPECT_EQ(run.data.r[750], 0.07 * std::sin(2 * kPi * 3.0 * 0.75));
  RunData direct = run.data;
  direct.theta = s.theta;
  const auto [g, p] = gain_phase(run.data, 3.0, 0.07, 3.0);
  const auto [gd, pd] = gain_phase(direct, 3.0, 0.07, 3.0);
  EXPECT_EQ(g, gd);
  EXPECT_EQ(p, pd);
  EXPECT_EQ(run.info.kind, "sine");
  EXPECT_EQ(*run.info.freq_hz, 3.0);
  EXPECT_EQ(*run.info.gamma1_deg, kG1);
  EXPECT_EQ(run.info.controller.kp, 2.0);
  EXPECT_EQ(run.info.file, "runs/sine_3hz.csv");
}

TEST(SimulateModelRun, LinearSineMatchesClosedFormEq18) {
  const ModelFile m = paper_model();
  ModelRunOptions o;
  const JointModelAtPose lin = model_at(m, kG1, kG2, false);
  const ModelRun run = simulate_model_run(m, lin, o, kG1, kG2);
  ASSERT_TRUE(run.ok) << run.message;
  // θ̈ + Cθ̇ + βθ = βr, β = β̃·kp: θ/r = β / (β − ω² + jωC).
  const double w = 2 * kPi * 3.0, beta = lin.beta_tilde_linear * 2.0, c = lin.c_linear;
  const std::complex<double> h = beta / std::complex<double>(beta - w * w, w * c);
  const auto [g, p] = gain_phase(run.data, 3.0, 0.07, 4.0);
  EXPECT_NEAR(g, std::abs(h), 1e-5 * std::abs(h));
  EXPECT_NEAR(p, std::arg(h) * 180.0 / kPi, 1e-3);
  // The linear columns are constant.
  EXPECT_EQ(run.data.extra_columns.at("C").front(), c);
  EXPECT_EQ(run.data.extra_columns.at("C").back(), c);
  // kp override: the gain moves as (18) says.
  o.kp = 3.0;
  const ModelRun run3 = simulate_model_run(m, lin, o, kG1, kG2);
  ASSERT_TRUE(run3.ok);
  const double beta3 = lin.beta_tilde_linear * 3.0;
  const std::complex<double> h3 = beta3 / std::complex<double>(beta3 - w * w, w * c);
  EXPECT_NEAR(gain_phase(run3.data, 3.0, 0.07, 4.0).first, std::abs(h3), 1e-5 * std::abs(h3));
  EXPECT_EQ(run3.info.controller.kp, 3.0);
}

TEST(SimulateModelRun, OffsetTorqueShiftsTheSquareWaveByOffsetOverKp) {
  // Steady state of θ̈ + Cθ̇ = β̃(kp(r − θ) + d0): θ = r + d0/kp, for either model.
  for (bool use_alpha : {false, true}) {
    ModelFile m = paper_model();
    ModelRunOptions o;
    o.reference = ModelRunReference::kSquare;
    o.freq_hz = 0.125;  // r = +A for the first 4 s
    o.duration_s = 3.9;
    const ModelRun plain = simulate_model_run(m, model_at(m, kG1, kG2, use_alpha), o);
    m.effects.offset_v = 0.05;
    const ModelRun shifted = simulate_model_run(m, model_at(m, kG1, kG2, use_alpha), o);
    ASSERT_TRUE(plain.ok && shifted.ok) << plain.message << shifted.message;
    EXPECT_EQ(plain.data.theta.front(), -0.07);  // θ(0) = −A for a square wave
    EXPECT_EQ(plain.data.r.front(), 0.07);
    const double end_plain = plain.data.theta.back(), end_shifted = shifted.data.theta.back();
    EXPECT_NEAR(end_plain, 0.07, 1e-5) << use_alpha;
    EXPECT_NEAR(end_shifted - end_plain, 0.05 / 2.0, 1e-5) << use_alpha;
  }
}

TEST(SimulateModelRun, UsesTheDigitalLoopTheModelWasIdentifiedWith) {
  ModelFile m = paper_model();
  m.loop_period_s = 1e-3;
  ModelRunOptions o;
  o.duration_s = 2.0;
  const ModelRun run = simulate_model_run(m, model_at(m, kG1, kG2, true), o);
  ASSERT_TRUE(run.ok) << run.message;
  EXPECT_EQ(run.simulation.loop_period_s, 1e-3);
  SimulationOptions digital;
  digital.loop_period_s = 1e-3;
  const std::vector<double> times = uniform_times(2.0, 1e-3);
  const SineReference ref(0.07, 3.0);
  const SimulationResult s = simulate(direct_model(true), m.controller, ref, times, {}, digital);
  const SimulationResult c = simulate(direct_model(true), m.controller, ref, times);
  ASSERT_TRUE(s.ok && c.ok);
  EXPECT_EQ(run.data.theta, s.theta);
  EXPECT_EQ(run.data.v, s.v);
  double diff = 0.0;
  for (std::size_t k = 0; k < c.theta.size(); ++k)
    diff = std::max(diff, std::abs(c.theta[k] - s.theta[k]));
  EXPECT_GT(diff, 1e-6);  // the held command is not the continuous law
}

TEST(SimulateModelRun, BadOptionsNameTheOption) {
  const ModelFile m = paper_model();
  const JointModelAtPose j = model_at(m, kG1, kG2, true);
  auto field_of = [&](ModelRunOptions o) {
    try {
      simulate_model_run(m, j, o);
    } catch (const Error& e) {
      return e.field();
    }
    return std::string("no error");
  };
  ModelRunOptions o;
  o.freq_hz = 0.0;
  EXPECT_EQ(field_of(o), "freq_hz");
  o = {};
  o.amplitude_rad = -0.1;
  EXPECT_EQ(field_of(o), "amplitude_rad");
  o = {};
  o.duration_s = std::nan("");
  EXPECT_EQ(field_of(o), "duration_s");
  o = {};
  o.kp = 0.0;
  EXPECT_EQ(field_of(o), "kp");
}

TEST(SimulateModelRun, DatasetOfTheRunReadsBack) {
  const ModelFile m = paper_model();
  ModelRunOptions o;
  o.duration_s = 1.0;
  const ModelRun run = simulate_model_run(m, model_at(m, kG1, kG2, true), o, kG1, kG2);
  ASSERT_TRUE(run.ok);
  const fs::path dir = fs::temp_directory_path() / "alphainv_test_model_run_dataset";
  fs::remove_all(dir);
  write_dataset(dir, model_run_dataset(m, run, 1000.0), {run.data});
  const Dataset ds = read_dataset_index(dir);
  ASSERT_EQ(ds.runs.size(), 1u);
  EXPECT_EQ(ds.runs[0].kind, "sine");
  EXPECT_EQ(*ds.runs[0].gamma2_deg, kG2);
  EXPECT_EQ(ds.controller.kp, 2.0);
  const RunData back = read_run(ds, 0);
  EXPECT_EQ(back.theta, run.data.theta);
  EXPECT_EQ(back.extra_columns.at("alpha"), run.data.extra_columns.at("alpha"));
  fs::remove_all(dir);
}

// --- the omni_fit binary ------------------------------------------------------------------------
#ifdef ALPHAINV_OMNI_FIT_EXE

struct Ran {
  int exit_code = -1;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Runs the omni_fit binary in a fresh folder holding the paper's model.json.
class OmniFitBinary : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("alphainv_test_omni_fit_simulate_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    write_model_file(dir_ / "model.json", paper_model());
  }
  void TearDown() override { fs::remove_all(dir_); }

  /// `command_and_args`: e.g. "simulate MODEL --pose …".
  Ran run_omni_fit(const std::string& command_and_args) {
    const std::string cmd = std::string("'") + ALPHAINV_OMNI_FIT_EXE + "' " + command_and_args +
                            " >'" + (dir_ / "stdout").string() + "' 2>'" +
                            (dir_ / "stderr").string() + "'";
    const int status = std::system(cmd.c_str());
    Ran r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(dir_ / "stdout");
    r.err = slurp(dir_ / "stderr");
    return r;
  }
  std::string model() const { return "'" + (dir_ / "model.json").string() + "'"; }
  fs::path dir_;
};

class OmniFitSimulate : public OmniFitBinary {
 protected:
  Ran run(const std::string& args) { return run_omni_fit("simulate " + args); }
};

TEST_F(OmniFitSimulate, WritesTheRunTheLibrarySimulates) {
  const fs::path csv = dir_ / "run.csv";
  const Ran r =
      run(model() + " --pose 60.08,87 --sine 3Hz --duration 2s -o '" + csv.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const auto& entry : fs::directory_iterator(dir_)) {  // no temporary file left behind
    EXPECT_EQ(entry.path().filename().string().find(".tmp."), std::string::npos) << entry.path();
  }
  const RunData back = read_run_csv(csv);
  const ModelFile m = paper_model();
  ModelRunOptions o;
  o.duration_s = 2.0;
  const ModelRun lib = simulate_model_run(m, model_at(m, kG1, kG2, true), o);
  EXPECT_EQ(back.theta, lib.data.theta);  // the CSV's numbers read back bit-identical
  EXPECT_EQ(back.extra_columns.at("C"), lib.data.extra_columns.at("C"));
  EXPECT_NE(r.err.find("inertia model (6)"), std::string::npos) << r.err;
}

TEST_F(OmniFitSimulate, StdoutAndDatasetFolder) {
  const Ran r = run(model() + " --pose 60.08,87 --square 0.25Hz --duration 500ms --linear -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  const RunData d = parse_run_csv(r.out, "stdout");
  ASSERT_EQ(d.size(), 501u);
  EXPECT_EQ(d.theta.front(), -0.07);
  const fs::path ds_dir = dir_ / "ds";
  const Ran w =
      run(model() + " --pose 60.08,87 --sine 3Hz --duration 1s -o '" + ds_dir.string() + "/'");
  ASSERT_EQ(w.exit_code, 0) << w.err;
  const Dataset ds = read_dataset_index(ds_dir);
  EXPECT_EQ(read_run(ds, 0).size(), 1001u);
}

TEST_F(OmniFitSimulate, ExitCodesScriptsRelyOn) {
  EXPECT_EQ(run(model() + " --pose 60.08,87 --sine 3kg").exit_code, 1);
  EXPECT_EQ(run(model() + " --pose 60.08,87 --sine -3Hz").exit_code, 1);
  EXPECT_EQ(run(model() + " --pose 60.08,87 --sine 0Hz").exit_code, 1);
  EXPECT_EQ(run(model() + " --pose 60.08,87").exit_code, 1);
  EXPECT_EQ(run(model() + " --pose 60.08,87 --sine 3Hz --square 1Hz").exit_code, 1);
  EXPECT_EQ(run(model() + " --pose 60.08,87 --sine 3Hz --duration 8min").exit_code, 1);
  const Ran no_pose = run(model() + " --sine 3Hz");
  EXPECT_EQ(no_pose.exit_code, 1);
  EXPECT_NE(no_pose.err.find("--pose"), std::string::npos) << no_pose.err;
  // kp = 1e9 V/rad: the stiff loop blows up in the RK4 scheme; nothing is written.
  const Ran failed =
      run(model() + " --pose 60.08,87 --sine 3Hz --kp 1e9 -o '" + (dir_ / "f.csv").string() + "'");
  EXPECT_EQ(failed.exit_code, 3);
  EXPECT_NE(failed.err.find("the simulation failed"), std::string::npos) << failed.err;
  EXPECT_FALSE(fs::exists(dir_ / "f.csv"));
  EXPECT_EQ(run(model() + " --pose 60.08,87 --sine 3Hz -o '" +
                (dir_ / "no" / "such" / "x.csv").string() + "'")
                .exit_code,
            2);
  const Ran missing = run("'" + (dir_ / "none.json").string() + "' --pose 60.08,87 --sine 3Hz");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("none.json"), std::string::npos) << missing.err;
}

TEST_F(OmniFitSimulate, BadEffectInTheModelFileIsExit2NamingFileAndKey) {
  std::string text = format_model_file(paper_model());
  const std::string from = "\"effects\": []";
  ASSERT_NE(text.find(from), std::string::npos);
  text.replace(text.find(from), from.size(),
               R"("effects": [{"effect": "offset_torque", "parameters": {"offset_v": 0.1}},
                              {"effect": "time_delay", "parameters": {"delay_s": -0.004}}])");
  const fs::path bad = dir_ / "bad_model.json";
  std::ofstream(bad) << text;
  const Ran r = run("'" + bad.string() + "' --pose 60.08,87 --sine 3Hz -o '" +
                    (dir_ / "x.csv").string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("bad_model.json"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("effects[1].parameters.delay_s"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "x.csv"));
}

TEST_F(OmniFitSimulate, ModelWithoutAlphaModelIsExit2NamingTheKey) {
  ModelFile m = paper_model();
  m.has_alpha_model = false;
  write_model_file(dir_ / "model.json", m);
  const Ran r = run(model() + " --pose 60.08,87 --sine 3Hz");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("model.json: 'alpha_model'"), std::string::npos) << r.err;
  EXPECT_EQ(run(model() + " --pose 60.08,87 --sine 3Hz --linear -q").exit_code, 0);
}

// `omni_fit fit` with known effects (--effects-from, --effect).
class OmniFitFitKnownEffects : public OmniFitBinary {
 protected:
  /// A small dataset from the virtual Omni with Coulomb friction Fc = 0.004 V: one pose, four
  /// sine frequencies, noise-free.
  std::string dataset() {
    const fs::path ds = dir_ / "ds";
    if (!fs::exists(ds / "dataset.json")) {
      ExperimentPlanOptions o;
      o.seed = 3;
      o.plant.effects.coulomb_v = 0.004;
      o.sine_poses = {{45, 90}};
      o.square_poses = {};
      o.sine_freqs_hz = {1.5, 3.0, 3.5, 5.0};
      const GeneratedDataset g = generate_dataset(make_experiment_plan(o));
      write_dataset(ds, g.index, g.runs);
    }
    return "'" + ds.string() + "'";
  }
  Ran fit(const std::string& args) {
    return run_omni_fit("fit " + dataset() + " -o '" + (dir_ / "out").string() + "' -q --no-plots " +
                        args);
  }
};

TEST_F(OmniFitFitKnownEffects, TheModelAndTheReportCarryThem) {
  const Ran r = fit("--effect coulomb_friction:coulomb_v=0.004,coulomb_smoothing_rad_s=0.002");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const ModelFile m = read_model_file(dir_ / "out" / "model.json");
  EXPECT_EQ(m.effects.coulomb_v, 0.004);
  EXPECT_EQ(m.effects.coulomb_smoothing_rad_s, 0.002);
  const std::string report = slurp(dir_ / "out" / "report.md");
  EXPECT_NE(report.find("**Fitted with known effects** (`--effect "
                        "coulomb_friction:coulomb_v=0.004,coulomb_smoothing_rad_s=0.002`): "
                        "coulomb_friction (coulomb_v = 0.004, coulomb_smoothing_rad_s = 0.002)"),
            std::string::npos)
      << report;
  // The written model read back by --effects-from: the same effects, the file named.
  fs::rename(dir_ / "out" / "model.json", dir_ / "diag.json");
  const Ran again = fit("--effects-from '" + (dir_ / "diag.json").string() + "'");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_EQ(read_model_file(dir_ / "out" / "model.json").effects.coulomb_v, 0.004);
  EXPECT_NE(slurp(dir_ / "out" / "report.md").find("from `" + (dir_ / "diag.json").string() + "`"),
            std::string::npos);
  // Without known effects: none in the model.
  ASSERT_EQ(fit("").exit_code, 0);
  EXPECT_TRUE(active_effects(read_model_file(dir_ / "out" / "model.json").effects).empty());
}

TEST_F(OmniFitFitKnownEffects, BadEffectsAreExit2NamingTheFileOrOption) {
  const Ran missing = fit("--effects-from '" + (dir_ / "none.json").string() + "'");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("--effects-from"), std::string::npos) << missing.err;
  EXPECT_NE(missing.err.find("none.json"), std::string::npos) << missing.err;
  // The paper's model.json has no effects.
  const Ran empty = fit("--effects-from " + model());
  EXPECT_EQ(empty.exit_code, 2);
  EXPECT_NE(empty.err.find((dir_ / "model.json").string() + " has no effects"), std::string::npos)
      << empty.err;
  // A malformed effect in the file: the file and the key.
  std::string text = format_model_file(paper_model());
  const std::string from = "\"effects\": []";
  ASSERT_NE(text.find(from), std::string::npos);
  text.replace(text.find(from), from.size(),
               R"("effects": [{"effect": "time_delay", "parameters": {"delay_s": -0.004}}])");
  std::ofstream(dir_ / "bad.json") << text;
  const Ran bad = fit("--effects-from '" + (dir_ / "bad.json").string() + "'");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("bad.json: 'effects[0].parameters.delay_s'"), std::string::npos) << bad.err;
  // --effect: the option (and the offending part) named.
  const std::pair<const char*, const char*> cases[] = {
      {"coulomb_friction:coulomb_v=-1", "'--effect coulomb_friction:coulomb_v'"},
      {"friction:coulomb_v=0.004", "unknown effect \"friction\""},
      {"coulomb_friction", "'--effect coulomb_friction': expected NAME:PARAM=VALUE"},
      {"coulomb_friction:speed=3", "PARAM one of coulomb_v, coulomb_smoothing_rad_s"},
      {"coulomb_friction:coulomb_v=4mV", "expected a number for coulomb_v"},
      {"coulomb_friction:coulomb_v=0", "leave coulomb_friction off"},
      {"none:x=1", "'--effect none:x=1'"},
  };
  for (const auto& [spec, says] : cases) {
    const Ran r = fit(std::string("--effect '") + spec + "'");
    EXPECT_EQ(r.exit_code, 2) << spec;
    EXPECT_NE(r.err.find(says), std::string::npos) << spec << ": " << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "out" / "model.json")) << spec;
  }
}

TEST_F(OmniFitFitKnownEffects, RefineEffectsSettlesTheFrictionOrNeedsOne) {
  // The plumbing: the refined value is written and the report says how it was found. (The
  // accuracy is test_effect_refinement's: this four-point sweep without square runs lets the
  // α-model absorb any friction, so the value here is not pinned.)
  const Ran r = fit("--effect coulomb_friction:coulomb_v=0.006 --refine-effects");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(read_model_file(dir_ / "out" / "model.json").effects.coulomb_v, 0.006);
  EXPECT_NE(slurp(dir_ / "out" / "report.md").find("refined on all runs by --refine-effects"),
            std::string::npos);
  fs::remove(dir_ / "out" / "model.json");
  const Ran none = fit("--refine-effects");
  EXPECT_EQ(none.exit_code, 2);
  EXPECT_NE(none.err.find("--refine-effects needs known effects"), std::string::npos) << none.err;
  EXPECT_FALSE(fs::exists(dir_ / "out" / "model.json"));
}

#endif  // ALPHAINV_OMNI_FIT_EXE

}  // namespace
}  // namespace alphainv
