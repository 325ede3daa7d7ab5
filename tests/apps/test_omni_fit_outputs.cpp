// omni_fit's outputs end to end (issue #13, findings 4, 11, 12, 13): the real binary. A failed fit
// leaves the previous output untouched; `-o` naming a folder of other files is refused before the
// work; output written to a full stdout makes the exit non-zero; a model file that is /dev/zero, a
// FIFO or a folder, or that holds a negative gain or limit, is a clear error (exit 2), no hang.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "alphainv/data/dataset.hpp"
#include "support/files.hpp"
#include "support/model_dataset.hpp"
#include "support/subprocess.hpp"

using alphainv::test::names_in;
using alphainv::test::ProcessResult;
using alphainv::test::run_process;
using alphainv::test::slurp;
namespace fs = std::filesystem;

namespace {

const std::string kFit = OMNI_FIT_BIN;
const std::string kPaperModel = std::string(ALPHAINV_SOURCE_DIR) + "/tests/fixtures/paper_model.json";

class OmniFitOutputs : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = alphainv::test::fresh_temp_dir(
        "omni_fit_outputs", ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  /// A one-run dataset nothing can be fitted from (the joint never moves: no physical point).
  fs::path unfittable_dataset() {
    const fs::path ds = dir_ / "still";
    fs::create_directories(ds);
    std::ofstream csv(ds / "run.csv");
    csv << "t,r,theta,v\n";
    for (int k = 0; k < 2000; ++k) {
      const double t = 1e-3 * k, r = 0.05 * std::sin(2.0 * M_PI * t);
      csv << t << "," << r << ",0," << 2.0 * r << "\n";
    }
    std::ofstream(ds / "dataset.json")
        << R"({"format": "alphainv-dataset/1", "kp": 2, "runs": [{"file": "run.csv",
           "kind": "sine", "freq_hz": 1, "amplitude_rad": 0.05}]})";
    return ds;
  }

  /// Runs of the paper's α-model at one pose (sines at `freqs`, 4 s, and a square run) written as
  /// a dataset folder <dir>/<name> (tests/support/model_dataset.hpp): something to fit.
  fs::path model_dataset(const std::string& name, const std::vector<double>& freqs) {
    alphainv::Dataset ds;
    std::vector<alphainv::RunData> data;
    alphainv::test::ModelDatasetPlan plan;
    plan.poses_deg = {{40.68, 68.52}};
    plan.freqs_hz = freqs;
    plan.duration_s = 4.0;
    plan.file_prefix = "runs/";
    plan.separator = "_";
    alphainv::test::append_model_runs(plan, ds, data);
    alphainv::write_dataset(dir_ / name, ds, data);
    return dir_ / name;
  }

  /// paper_model.json with `from` replaced by `to` (once), written to <dir>/<name>.
  fs::path model_with(const std::string& from, const std::string& to, const std::string& name) {
    std::string text = slurp(kPaperModel);
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
    std::ofstream(dir_ / name) << text;
    return dir_ / name;
  }

  fs::path dir_;
};

// Finding 11: a failed fit (exit 3) into a folder holding a good model replaced it with an empty
// one (alpha_model null).
TEST_F(OmniFitOutputs, AFailedFitLeavesThePreviousOutputUntouched) {
  const fs::path out = dir_ / "fit";
  fs::create_directories(out / "plots");
  fs::copy_file(kPaperModel, out / "model.json");
  std::ofstream(out / "report.md") << "the good fit's report\n";
  const ProcessResult r = run_process({kFit, "fit", unfittable_dataset().string(), "-o",
                                       out.string(), "--no-plots"});
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("the previous output in " + out.string() + " is kept"), std::string::npos)
      << r.err;
  EXPECT_EQ(slurp(out / "model.json"), slurp(kPaperModel));
  EXPECT_EQ(slurp(out / "report.md"), "the good fit's report\n");
  EXPECT_EQ(names_in(dir_), (std::vector<std::string>{"fit", "still"}));  // no sibling left

  // Into a new folder the failed fit's report is written: it says why.
  const ProcessResult fresh = run_process({kFit, "fit", (dir_ / "still").string(), "-o",
                                           (dir_ / "new").string(), "--no-plots", "-q"});
  EXPECT_EQ(fresh.exit_code, 3);
  EXPECT_EQ(names_in(dir_ / "new"), (std::vector<std::string>{"model.json", "report.md"}));
}

// Transactional outputs: `-o` naming a folder that holds other files (a home folder) would be
// replaced whole; it is refused before the fit, with the file named.
TEST_F(OmniFitOutputs, AnOutputFolderOfOtherFilesIsRefusedBeforeTheWork) {
  fs::create_directories(dir_ / "home");
  std::ofstream(dir_ / "home" / "thesis.tex") << "mine";
  const ProcessResult r = run_process({kFit, "fit", unfittable_dataset().string(), "-o",
                                       (dir_ / "home").string(), "--no-plots"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("holds 'thesis.tex', which this command does not write"),
            std::string::npos) << r.err;
  EXPECT_EQ(names_in(dir_ / "home"), std::vector<std::string>{"thesis.tex"});
}

// Finding 12: `omni_fit simulate … > /dev/full` and `fit --json > /dev/full` exited 0.
TEST_F(OmniFitOutputs, AWriteErrorOnStdoutMakesTheExitNonZero) {
  const std::string simulate = kFit + " simulate " + kPaperModel +
                               " --pose 60.08,87 --sine 3Hz --duration 0.2s -q > /dev/full";
  const ProcessResult sim = run_process({"/bin/sh", "-c", "exec " + simulate});
  EXPECT_EQ(sim.exit_code, 2) << sim.err;
  EXPECT_NE(sim.err.find("No space left on device"), std::string::npos) << sim.err;
  const ProcessResult demo = run_process({"/bin/sh", "-c", "exec " + kFit + " demo > /dev/full"});
  EXPECT_NE(demo.exit_code, 0) << demo.err;
  EXPECT_NE(demo.err.find("cannot write to standard output"), std::string::npos) << demo.err;
  const ProcessResult fit = run_process(
      {"/bin/sh", "-c", "exec " + kFit + " fit " + unfittable_dataset().string() + " -o " +
                            (dir_ / "fit").string() + " --no-plots --json > /dev/full"});
  EXPECT_NE(fit.exit_code, 0);
  const ProcessResult ok = run_process({"/bin/sh", "-c", "exec " + kFit + " demo > /dev/null"});
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
}

// Finding 4: a model file that is /dev/zero was read without bound (bad_alloc, rc 134); a FIFO
// hung `simulate`. Finding 13: a model with kp -2 or v_limit -1 simulated (theta 3.5e5 rad).
TEST_F(OmniFitOutputs, AModelFileMustBeARegularFileOfPhysicalValues) {
  const fs::path fifo = dir_ / "model.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string kp_neg = model_with("\"kp\": 2.0", "\"kp\": -2.0", "kp.json").string();
  const std::string vl_neg =
      model_with("\"v_limit\": null", "\"v_limit\": -1", "v_limit.json").string();
  const std::string huge = model_with("13.509", "1e400", "huge.json").string();
  struct Case {
    std::string model, needle;
  } cases[] = {{"/dev/zero", "/dev/zero: expected a regular file"},
               {fifo.string(), "model.fifo: expected a regular file"},
               {dir_.string(), "expected a file, found a folder"},
               {kp_neg, "'controller.kp': expected the P gain of the identification runs, >= 0"},
               {vl_neg, "'controller.v_limit': expected null (no limit) or a command limit > 0"},
               {huge, "huge.json"}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.model);
    const ProcessResult r = run_process({kFit, "simulate", c.model, "--pose", "60.08,87",
                                         "--sine", "3Hz", "--duration", "0.2s", "-q", "-o",
                                         (dir_ / "out.csv").string()},
                                        {}, 20.0);
    EXPECT_EQ(r.exit_code, 2) << r.err;  // -1 would be the timeout: a hang
    EXPECT_NE(r.err.find(c.needle), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "out.csv"));
  }
}

// Finding 13: a run whose declared freq_hz (30) is not what the data hold (3 Hz) was used: a point
// with C_data 3.2e12 was marked physical. Now the run is skipped with a note naming both.
TEST_F(OmniFitOutputs, ADeclaredFrequencyTheDataDoNotHoldIsSkippedWithTheMeasuredOne) {
  const fs::path ds = dir_ / "freq";
  fs::create_directories(ds);
  {
    std::ofstream csv(ds / "run.csv");
    csv << "t,r,theta,v\n";
    for (int k = 0; k < 4000; ++k) {
      const double t = 1e-3 * k, r = 0.05 * std::sin(2.0 * M_PI * 3.0 * t);
      const double theta = 0.04 * std::sin(2.0 * M_PI * 3.0 * t - 0.5);
      csv << t << "," << r << "," << theta << "," << 2.0 * (r - theta) << "\n";
    }
  }
  auto index = [&](const char* freq) {
    std::ofstream(ds / "dataset.json")
        << R"({"format": "alphainv-dataset/1", "kp": 2, "runs": [{"file": "run.csv", "kind":
           "sine", "freq_hz": )" << freq << R"(, "amplitude_rad": 0.05}]})";
  };
  index("30");
  const ProcessResult wrong =
      run_process({kFit, "fit", ds.string(), "-o", (dir_ / "f30").string(), "--no-plots"});
  EXPECT_EQ(wrong.exit_code, 3) << wrong.err;
  EXPECT_NE(wrong.out.find("run run.csv: declared freq_hz 30 is not the reference's frequency"),
            std::string::npos) << wrong.out;
  EXPECT_NE(wrong.out.find("r crosses its mean at about 3 Hz"), std::string::npos) << wrong.out;
  index("3");  // the same data declared right: no such note
  const ProcessResult right =
      run_process({kFit, "fit", ds.string(), "-o", (dir_ / "f3").string(), "--no-plots"});
  EXPECT_EQ(right.out.find("declared freq_hz"), std::string::npos) << right.out;
}

}  // namespace

// Finding 2 (omni_fit): a Latin-1 (not UTF-8) dataset path failed only after the whole work, with
// nlohmann's type_error 316, when the path went into the JSON output. It is now written with the
// byte replaced by U+FFFD: the work's output stands, and it is valid UTF-8.
TEST_F(OmniFitOutputs, ANonUtf8DatasetPathDoesNotCostTheResult) {
  const fs::path latin1 = dir_ / "caf\xe9";
  fs::rename(unfittable_dataset(), latin1);
  std::ofstream(latin1 / "dataset.json")  // the same run at a pose, so the paper model simulates it
      << R"({"format": "alphainv-dataset/1", "kp": 2, "runs": [{"file": "run.csv",
         "kind": "sine", "freq_hz": 1, "amplitude_rad": 0.05, "gamma1_deg": 60, "gamma2_deg": 87}]})";
  const ProcessResult r =
      run_process({kFit, "validate", kPaperModel, latin1.string(), "--json", "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"dataset\""), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("caf\xef\xbf\xbd"), std::string::npos) << r.out;  // U+FFFD
  EXPECT_EQ(r.out.find("caf\xe9"), std::string::npos);
}

// #14: `validate -o` writes the compare and resid figures into OUT/plots and report.md links
// each of them; --no-plots writes none and says so.
TEST_F(OmniFitOutputs, ValidateWritesItsFiguresAndTheReportLinksThem) {
  const fs::path ds = model_dataset("runs", {2.0, 3.5, 6.0});
  const fs::path out = dir_ / "val";
  const ProcessResult r = run_process({kFit, "validate", kPaperModel, ds.string(), "-o",
                                       out.string(), "-q", "--plot-runs", "2"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string md = slurp(out / "report.md");
  std::size_t compare = 0, resid = 0;
  for (const std::string& f : names_in(out / "plots")) {
    if (f.size() < 4 || f.substr(f.size() - 4) != ".png") continue;
    EXPECT_NE(md.find("](plots/" + f + ")"), std::string::npos) << f << " not in report.md";
    compare += f.rfind("validation_compare_run", 0) == 0;
    resid += f.rfind("validation_resid_run", 0) == 0;
  }
  const bool gnuplot = std::system("command -v gnuplot > /dev/null 2>&1") == 0;
  if (gnuplot) {
    EXPECT_EQ(compare, 2u);  // --plot-runs 2 of the 4 runs
    EXPECT_EQ(resid, 2u);
    EXPECT_TRUE(fs::exists(out / "plots" / "validation_fit_per_run.png"));
  }
  EXPECT_TRUE(fs::exists(out / "plots" / "validation_fit_per_run.gp"));
  EXPECT_NE(md.find("## Validation figures"), std::string::npos) << md;

  const ProcessResult np = run_process({kFit, "validate", kPaperModel, ds.string(), "-o",
                                        out.string(), "-q", "--no-plots"});
  ASSERT_EQ(np.exit_code, 0) << np.err;
  EXPECT_FALSE(fs::exists(out / "plots"));
  EXPECT_NE(slurp(out / "report.md").find("Plots were skipped: --no-plots was given"),
            std::string::npos);
}

// #14: `fit --holdout` draws the held-out runs' figures beside the fit's (heldout_*), linked from
// report.md; --no-plots draws neither.
TEST_F(OmniFitOutputs, FitHoldoutFiguresAreLinkedFromTheReport) {
  const fs::path ds = model_dataset("runs", {2.0, 3.0, 3.5, 4.0, 5.0});
  const fs::path out = dir_ / "fit";
  const ProcessResult r =
      run_process({kFit, "fit", ds.string(), "-o", out.string(), "-q", "--holdout", "3"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string md = slurp(out / "report.md");
  EXPECT_NE(md.find("### Validation figures"), std::string::npos) << md;
  EXPECT_TRUE(fs::exists(out / "plots" / "heldout_fit_per_run.gp"));
  if (std::system("command -v gnuplot > /dev/null 2>&1") == 0) {
    std::size_t heldout = 0;
    for (const std::string& f : names_in(out / "plots")) {
      if (f.rfind("heldout_", 0) != 0 || f.substr(f.size() - 4) != ".png") continue;
      ++heldout;
      EXPECT_NE(md.find("](plots/" + f + ")"), std::string::npos) << f;
    }
    EXPECT_EQ(heldout, 1u + 2u * 2u);  // 2 of the 6 runs held out (the 3rd and 6th)
  }
  const ProcessResult np = run_process(
      {kFit, "fit", ds.string(), "-o", out.string(), "-q", "--holdout", "3", "--no-plots"});
  ASSERT_EQ(np.exit_code, 0) << np.err;
  EXPECT_FALSE(fs::exists(out / "plots" / "heldout_fit_per_run.gp"));
  EXPECT_NE(slurp(out / "report.md").find("### Validation figures\n\nPlots were skipped"),
            std::string::npos);
}

// #14: `fit DIR1 DIR2`: model.json names both folders and its hash covers both dataset.json
// files (it covered only the first): a change to the second's changes the hash.
TEST_F(OmniFitOutputs, TheHashOfSeveralDatasetsCoversEveryDatasetJson) {
  const fs::path a = model_dataset("a", {2.0, 3.5});
  const fs::path b = model_dataset("b", {3.0, 5.0});
  auto fit_hash = [&](const std::string& name, nlohmann::json* dataset) {
    const fs::path out = dir_ / name;
    const ProcessResult r = run_process(
        {kFit, "fit", a.string(), b.string(), "-o", out.string(), "-q", "--no-plots"});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(slurp(out / "model.json"));
    if (dataset != nullptr) *dataset = j["dataset"];
    return j["dataset"]["hash_fnv1a64"].get<std::string>();
  };
  nlohmann::json dataset;
  const std::string h1 = fit_hash("fit1", &dataset);
  ASSERT_EQ(dataset["paths"].size(), 2u) << dataset.dump();
  EXPECT_EQ(dataset["paths"][0], fs::absolute(a).string());
  EXPECT_EQ(dataset["paths"][1], fs::absolute(b).string());
  EXPECT_NE(dataset["hash_covers"].get<std::string>().find("every folder"), std::string::npos);
  EXPECT_EQ(fit_hash("fit1_again", nullptr), h1);
  // The second folder's dataset.json only (a free-text field the fit does not read).
  std::string text = slurp(b / "dataset.json");
  const std::size_t at = text.find('{');
  ASSERT_NE(at, std::string::npos);
  text.insert(at + 1, "\"joint\": \"yaw, second recording\", ");
  std::ofstream(b / "dataset.json") << text;
  EXPECT_NE(fit_hash("fit2", nullptr), h1);
  EXPECT_NE(slurp(dir_ / "fit2" / "report.md").find("Datasets fitted together"), std::string::npos);
}
