// omni_ctl --record end to end on the virtual device (issue #13, finding 9, "Durability of
// recordings"): the folder is checked before the run (an existing dataset needs --force, an
// unwritable folder is refused), a SIGKILL leaves a dataset of every row up to the last flush
// marked "interrupted", and a model whose prediction overflows costs only the derived columns.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "alphainv/data/dataset.hpp"
#include "support/files.hpp"
#include "support/subprocess.hpp"

using namespace alphainv;
using alphainv::test::ProcessResult;
using alphainv::test::run_process;
using alphainv::test::slurp;
using alphainv::test::Subprocess;
namespace fs = std::filesystem;

namespace {

std::vector<std::string> run_args(const fs::path& record, const std::string& duration) {
  // --max-missed: a loaded test machine may wake the loop late ten times in a row (the deadline
  // fault), which is not what these tests are about.
  return {OMNI_CTL_BIN, "--joint",  "yaw",  "--local",    "--no-mlock", "--rt-priority",
          "0",          "--device", "sim",  "--sine",     "3Hz",        "--duration",
          duration,     "--record", record.string(),      "--max-missed", "100000"};
}

class OmniCtlRecording : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fresh_temp_dir("omni_ctl_recording",
                                ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

// Finding 9: `--record` into an existing dataset silently replaced its dataset.json and
// overwrote run.csv; an unwritable folder was found only after the run.
TEST_F(OmniCtlRecording, TheFolderIsCheckedBeforeTheRunAndADatasetIsReplacedOnlyWithForce) {
  const fs::path rec = dir_ / "run";
  ASSERT_EQ(run_process(run_args(rec, "300ms")).exit_code, 0);
  const std::string index = slurp(rec / "dataset.json"), csv = slurp(rec / "run.csv");
  ASSERT_NE(index.find("\"ended\": \"completed\""), std::string::npos) << index;

  const auto start = std::chrono::steady_clock::now();
  const ProcessResult again = run_process(run_args(rec, "5s"));
  const double took_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(again.exit_code, 2) << again.err;
  EXPECT_NE(again.err.find("--record: " + rec.string() +
                           ": the folder already holds a dataset (dataset.json); give a new "
                           "folder, or --force"),
            std::string::npos) << again.err;
  EXPECT_EQ(again.err.find(" on sim"), std::string::npos) << "the run started: " << again.err;
  EXPECT_LT(took_s, 4.0);  // refused before the 5 s run, not after it
  EXPECT_EQ(slurp(rec / "dataset.json"), index);
  EXPECT_EQ(slurp(rec / "run.csv"), csv);

  std::vector<std::string> forced = run_args(rec, "200ms");
  forced.push_back("--force");
  ASSERT_EQ(run_process(forced).exit_code, 0);
  EXPECT_NE(slurp(rec / "run.csv"), csv);
  EXPECT_LT(read_run(read_dataset_index(rec), 0).size(), 260u);  // the 200 ms run's rows

  const ProcessResult locked = run_process(run_args("/proc/alphainv_no_such_folder", "5s"));
  EXPECT_EQ(locked.exit_code, 2) << locked.err;
  EXPECT_NE(locked.err.find("--record: /proc/alphainv_no_such_folder: cannot create"),
            std::string::npos) << locked.err;
}

// Finding 9: SIGKILL (or a crash) left nothing on disk. Now: a dataset omni_fit reads, marked
// "interrupted", holding every row up to the last flush (0.5 s).
TEST_F(OmniCtlRecording, ASigkillLeavesADatasetOfTheRowsUpToTheLastFlush) {
  const fs::path rec = dir_ / "killed";
  Subprocess p(run_args(rec, "60s"));
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  p.signal(SIGKILL);
  EXPECT_EQ(p.wait(10.0).exit_code, 128 + SIGKILL);
  const Dataset ds = read_dataset_index(rec);
  EXPECT_TRUE(ds.interrupted);
  EXPECT_NE(slurp(rec / "dataset.json").find("\"ended\": \"interrupted\""), std::string::npos);
  const RunData run = read_run(ds, 0);
  // 2.5 s since the process started: at most 2500 ticks, at most 0.5 s of them unflushed (a
  // loaded machine skips ticks too: the bound below leaves room for them).
  EXPECT_GE(run.size(), 1000u);
  EXPECT_LE(run.size(), 2500u);
  // The rows are the 1 kHz ticks: each step of t is a whole number of 1 ms periods (a loaded
  // machine skips deadlines, loop_runner.cpp, and so leaves steps of 2 ms, 3 ms, ...; CI saw
  // t[1] - t[0] = 3 ms), and most of them are one period.
  std::vector<double> steps_ms;
  for (std::size_t i = 1; i < run.size(); ++i) steps_ms.push_back((run.t[i] - run.t[i - 1]) * 1e3);
  for (std::size_t i = 0; i < steps_ms.size(); ++i) {
    ASSERT_GE(steps_ms[i], 0.9) << "row " << i + 1;
    ASSERT_NEAR(steps_ms[i], std::round(steps_ms[i]), 1e-3) << "row " << i + 1;
  }
  std::nth_element(steps_ms.begin(), steps_ms.begin() + steps_ms.size() / 2, steps_ms.end());
  EXPECT_NEAR(steps_ms[steps_ms.size() / 2], 1.0, 1e-3);
}

// Finding 9: a model the reader accepts (C_n1 = 1e308) made theta_pred NaN and the whole
// recorded run was lost (rc 5). Now the measured columns are kept; the derived ones say nan.
TEST_F(OmniCtlRecording, AModelWhosePredictionOverflowsCostsOnlyTheDerivedColumns) {
  std::string model = slurp(std::string(ALPHAINV_SOURCE_DIR) + "/tests/fixtures/paper_model.json");
  for (const char* c : {"13.509", "21.57", "35.316", "61.733"}) {
    model.replace(model.find(c), std::string(c).size(), "1e308");
  }
  std::ofstream(dir_ / "overflow.json") << model;
  std::vector<std::string> args = run_args(dir_ / "rec", "300ms");
  args.insert(args.end(), {"--model", (dir_ / "overflow.json").string()});
  const ProcessResult r = run_process(args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("written as nan"), std::string::npos) << r.err;
  const RunData run = read_run(read_dataset_index(dir_ / "rec"), 0);
  EXPECT_GT(run.size(), 200u);
  EXPECT_EQ(run.column("theta_pred"), nullptr);
  EXPECT_NE(run.column("gamma1"), nullptr);
  double max_abs_r = 0.0;
  for (double x : run.r) max_abs_r = std::max(max_abs_r, std::abs(x));
  EXPECT_NEAR(max_abs_r, 0.07, 0.005);  // the measured run is whole
}

}  // namespace
