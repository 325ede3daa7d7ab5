// RunRecorder on synthetic tick records: the rows, columns and values of the dataset it writes,
// dataset.json's run and extra keys, the run's timing statistics, and RunResult's verdict and
// reports (recorded, not recorded, too short, a fault, dropped rows); the dataset on disk while
// the run goes on (what a kill leaves), non-finite derived cells, long runs in several files,
// and prepare_recording_folder()'s checks.
#include "alphainv/device/recording.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>

#include "alphainv/data/dataset.hpp"
#include "alphainv/error.hpp"
#include "support/files.hpp"

using namespace alphainv;
using namespace alphainv::device;
using alphainv::test::slurp;
namespace fs = std::filesystem;

namespace {

constexpr double kStartS = 2.5;  // loop time of the run's start [s]

fs::path temp_dir(const std::string& name) { return test::fresh_temp_dir("recording", name); }

/// Tick k of a run that started at kStartS: every field a distinct function of k.
rt::TickRecord tick(int k) {
  rt::TickRecord r;
  r.t_s = kStartS + 1e-3 * k;
  r.r_rad = 0.01 * k;
  r.theta_rad = 0.008 * k;
  r.gamma1_rad = 1.0 + 1e-4 * k;
  r.gamma2_rad = 1.5 - 1e-4 * k;
  r.command_v = 0.004 * k - 0.01;
  r.alpha = 0.5 * k;
  r.damping = 10.0 + k;
  r.beta_tilde = 250.0 - k;
  r.theta_pred_rad = 0.008 * k + 1e-5;
  r.p_command_v = 0.005 * k - 0.01;
  r.comp_command_v = -0.001 * k;
  r.enable = k != 4;
  r.wake_latency_s = (10.0 * k + 10.5) * 1e-6;  // 10.5 … 50.5 µs, mid-bin
  r.period_jitter_s = (2.0 * k + 2.5) * 1e-6;   // the first tick's is not counted
  r.read_s = 1.5e-6;
  r.write_s = 3.5e-6;
  r.deadline_missed = k == 2 || k == 3;
  r.deadlines_skipped = k == 2 ? 1 : (k == 3 ? 3 : 0);
  return r;
}

RunRecording sine_recording(const fs::path& dir) {
  return {dir, rt::Waveform{rt::WaveKind::kSine, 0.07, 3.0, 0.0}, "omni_ctl --sine 3Hz", "sim",
          "paper"};
}

/// A recorder with ticks 0 … n−1 added.
std::unique_ptr<RunRecorder> recorder_with(int n, std::optional<RunRecording> recording) {
  auto rec = std::make_unique<RunRecorder>(7, std::move(recording));
  for (int k = 0; k < n; ++k) rec->add(tick(k), kStartS);
  return rec;
}

}  // namespace

TEST(RunRecorder, WritesTheRowsColumnsAndValuesOfTheTicks) {
  const fs::path dir = temp_dir("rows");
  const auto rec = recorder_with(5, sine_recording(dir));
  const RunResult result = rec->finish(RunEnd{}, rt::ControlLoopConfig{}, 2.5);
  ASSERT_TRUE(result.usable()) << result.brief_report();
  EXPECT_EQ(result.rows, 5);
  EXPECT_EQ(result.dir, dir);

  const Dataset ds = read_dataset_index(dir);
  const RunData run = read_run(ds, 0);
  ASSERT_EQ(run.size(), 5u);
  for (const char* col : {"gamma1", "gamma2", "alpha", "C", "beta_tilde", "theta_pred",
                          "torque_enable", "v_p", "v_comp"}) {
    ASSERT_NE(run.column(col), nullptr) << col;
  }
  EXPECT_EQ(run.extra_columns.size(), 9u);
  for (int k = 0; k < 5; ++k) {
    const std::size_t i = static_cast<std::size_t>(k);
    const rt::TickRecord r = tick(k);
    SCOPED_TRACE(k);
    // The CSV keeps every double exactly; t counts from the run's start.
    EXPECT_EQ(run.t[i], r.t_s - kStartS);
    EXPECT_EQ(run.r[i], r.r_rad);
    EXPECT_EQ(run.theta[i], r.theta_rad);
    EXPECT_EQ(run.v[i], r.command_v);
    EXPECT_EQ((*run.column("gamma1"))[i], r.gamma1_rad);
    EXPECT_EQ((*run.column("gamma2"))[i], r.gamma2_rad);
    EXPECT_EQ((*run.column("alpha"))[i], 0.5 * k);
    EXPECT_EQ((*run.column("C"))[i], 10.0 + k);
    EXPECT_EQ((*run.column("beta_tilde"))[i], 250.0 - k);
    EXPECT_EQ((*run.column("theta_pred"))[i], r.theta_pred_rad);
    EXPECT_EQ((*run.column("torque_enable"))[i], k == 4 ? 0.0 : 1.0);
    EXPECT_EQ((*run.column("v_p"))[i], r.p_command_v);
    EXPECT_EQ((*run.column("v_comp"))[i], r.comp_command_v);
  }
  EXPECT_NEAR(run.t[4], 0.004, 1e-15);

  // dataset.json: the loop's rate and controller, the run and the pose of its first row.
  EXPECT_EQ(ds.joint, "yaw");
  EXPECT_EQ(ds.sample_rate_hz.value(), 1000.0);
  EXPECT_EQ(ds.controller.kp, 2.5);
  ASSERT_EQ(ds.runs.size(), 1u);
  EXPECT_EQ(ds.runs[0].file, "run.csv");
  EXPECT_EQ(ds.runs[0].kind, "sine");
  EXPECT_EQ(ds.runs[0].freq_hz.value(), 3.0);
  EXPECT_EQ(ds.runs[0].amplitude_rad.value(), 0.07);
  EXPECT_DOUBLE_EQ(ds.runs[0].gamma1_deg.value(), 57.295779513082323);
  EXPECT_DOUBLE_EQ(ds.runs[0].gamma2_deg.value(), 1.5 * 180.0 / kPi);
  const std::string json = slurp(dir / "dataset.json");
  for (const char* key :
       {"\"v_limit\": 1.0", "\"source\": \"omni_ctl\"", "\"command_line\": \"omni_ctl --sine 3Hz\"",
        "\"device\": \"sim\"", "\"model\": \"paper\"", "\"ended\": \"completed\"", "\"rows\": 5",
        "\"dropped_rows\": 0", "\"max_slew_v_per_s\": 200.0", "\"ticks\": 5",
        "\"deadline_misses\": 2", "\"skipped_ticks\": 4", "\"theta_pred\": \"the model's"}) {
    EXPECT_NE(json.find(key), std::string::npos) << key << "\n" << json;
  }
  fs::remove_all(dir);
}

TEST(RunRecorder, GathersTheRunsTimingStatistics) {
  const auto rec = recorder_with(5, std::nullopt);
  rt::ControlLoopConfig config;
  config.period_s = 2e-3;
  const TimingStats t = rec->finish(RunEnd{}, config, 2.0).timing;
  EXPECT_EQ(t.ticks, 5);
  EXPECT_EQ(t.deadline_misses, 2);
  EXPECT_EQ(t.skipped_ticks, 4);
  EXPECT_EQ(t.period_s, 2e-3);
  EXPECT_EQ(t.latency.count, 5);
  EXPECT_DOUBLE_EQ(t.latency.max_s, 50.5e-6);
  EXPECT_NEAR(t.latency.mean_s, 30.5e-6, 1e-12);
  EXPECT_NEAR(t.latency.p50_s, 31e-6, 1e-12);  // upper edge of the 1 µs bin of the third
  EXPECT_EQ(t.period_jitter.count, 4);         // from the second tick on
  EXPECT_NEAR(t.period_jitter.mean_s, 7.5e-6, 1e-12);
  EXPECT_NEAR(t.period_jitter.p50_s, 7e-6, 1e-12);
  EXPECT_DOUBLE_EQ(t.period_jitter.p99_s, 10.5e-6);  // in the last bin: the maximum
  EXPECT_EQ(t.read.count, 5);
  EXPECT_DOUBLE_EQ(t.read.max_s, 1.5e-6);
  EXPECT_DOUBLE_EQ(t.write.max_s, 3.5e-6);
}

TEST(RunRecorder, TheWaveformNamesTheRun) {
  const fs::path dir = temp_dir("names");
  const auto rec = recorder_with(3, sine_recording(dir));
  const rt::ControlLoopConfig config;
  const RunResult result;
  const Dataset sine = rec->dataset(result, config, 2.0);
  EXPECT_EQ(sine.runs[0].kind, "sine");

  RunRecording step = sine_recording(dir);
  step.wave = rt::Waveform{rt::WaveKind::kStep, 0.05, 0.0, 0.0};
  const RunInfo s = recorder_with(3, step)->dataset(result, config, 2.0).runs[0];
  EXPECT_EQ(s.kind, "step");
  EXPECT_FALSE(s.freq_hz.has_value());
  EXPECT_EQ(s.amplitude_rad.value(), 0.05);

  RunRecording square = sine_recording(dir);
  square.wave = rt::Waveform{rt::WaveKind::kSquare, 0.06, 0.25, 0.0};
  const RunInfo q = recorder_with(3, square)->dataset(result, config, 2.0).runs[0];
  EXPECT_EQ(q.kind, "square");
  EXPECT_EQ(q.freq_hz.value(), 0.25);
  EXPECT_EQ(q.amplitude_rad.value(), 0.06);

  RunRecording hold = sine_recording(dir);
  hold.wave = rt::Waveform{rt::WaveKind::kHold, 0.07, 3.0, 0.0};
  const RunInfo h = recorder_with(3, hold)->dataset(result, config, 2.0).runs[0];
  EXPECT_EQ(h.kind, "other");
  EXPECT_FALSE(h.freq_hz.has_value());
  EXPECT_FALSE(h.amplitude_rad.has_value());
  fs::remove_all(dir);
}

// Finding 9 of issue #13: SIGKILL or a crash left nothing on disk. Now the folder holds, while the
// run goes on, a dataset.json saying "interrupted" and every row up to the last flush; a row cut
// short by the kill is dropped by the reader.
TEST(RunRecorder, WhileTheRunGoesOnTheDiskHoldsADatasetOfEveryRowUpToTheLastFlush) {
  const fs::path dir = temp_dir("interrupted");
  RunRecording recording = sine_recording(dir);
  recording.flush_period_s = 1.0;
  prepare_recording_folder(recording);
  RunRecorder rec(7, recording, rt::ControlLoopConfig{}, 2.0);
  const int n = 2500;  // 2.5 s of ticks
  for (int k = 0; k < n; ++k) {
    rec.add(tick(k), kStartS);
    if (k == 0) {  // the first row is on disk with the index naming it
      EXPECT_EQ(rec.rows_flushed(), 1);
      EXPECT_EQ(read_run(read_dataset_index(dir), 0).size(), 1u);
    }
  }
  // "Killed" now: no finish(). What is on disk is a dataset omni_fit reads.
  const Dataset ds = read_dataset_index(dir);
  EXPECT_TRUE(ds.interrupted);
  EXPECT_NE(slurp(dir / "dataset.json").find("\"ended\": \"interrupted\""), std::string::npos);
  const RunData run = read_run(ds, 0);
  EXPECT_EQ(static_cast<long>(run.size()), rec.rows_flushed());
  EXPECT_GE(static_cast<long>(run.size()), n - 1000);  // at most one flush period lost
  EXPECT_LT(static_cast<long>(run.size()), n);          // the rows since the flush are not
  for (std::size_t i = 0; i < run.size(); ++i) ASSERT_EQ(run.theta[i], tick(static_cast<int>(i)).theta_rad);

  // A kill inside a write leaves a last line without its end: dropped, the rows before kept.
  { std::ofstream(dir / "run.csv", std::ios::app) << "2.9,0.1,0.0"; }
  EXPECT_EQ(read_run(read_dataset_index(dir), 0).size(), run.size());

  // A clean end: every row, and dataset.json rewritten with how the run ended.
  fs::resize_file(dir / "run.csv", fs::file_size(dir / "run.csv") - 11);
  const RunResult result = rec.finish(RunEnd{}, rt::ControlLoopConfig{}, 2.0);
  ASSERT_TRUE(result.usable()) << result.brief_report();
  EXPECT_EQ(result.rows, n);
  const Dataset done = read_dataset_index(dir);
  EXPECT_FALSE(done.interrupted);
  EXPECT_EQ(read_run(done, 0).size(), static_cast<std::size_t>(n));
  EXPECT_NE(slurp(dir / "dataset.json").find("\"ended\": \"completed\""), std::string::npos);
  fs::remove_all(dir);
}

// Finding 9: a model the reader accepts whose prediction overflows (C_n1 = 1e308) made
// theta_pred NaN and the whole recording was lost (rc 5). Now only the derived column is.
TEST(RunRecorder, NonFiniteDerivedCellsNeverCostTheMeasuredColumns) {
  const fs::path dir = temp_dir("nonfinite");
  RunRecorder rec(7, sine_recording(dir), rt::ControlLoopConfig{}, 2.0);
  for (int k = 0; k < 50; ++k) {
    rt::TickRecord r = tick(k);
    if (k >= 10) r.theta_pred_rad = k % 2 ? std::nan("") : HUGE_VAL;
    if (k >= 40) r.damping = -HUGE_VAL;
    rec.add(r, kStartS);
  }
  const RunResult result = rec.finish(RunEnd{}, rt::ControlLoopConfig{}, 2.0);
  ASSERT_TRUE(result.usable()) << result.brief_report();
  EXPECT_EQ(result.non_finite_note, "C: 10, theta_pred: 40");
  EXPECT_NE(result.brief_report().find("written as nan"), std::string::npos);
  const RunData run = read_run(read_dataset_index(dir), 0);
  ASSERT_EQ(run.size(), 50u);
  EXPECT_EQ(run.column("theta_pred"), nullptr);
  EXPECT_EQ(run.column("C"), nullptr);
  EXPECT_EQ(run.ignored_columns, (std::vector<std::string>{"C", "theta_pred"}));
  for (std::size_t i = 0; i < run.size(); ++i) {
    const rt::TickRecord r = tick(static_cast<int>(i));
    ASSERT_EQ(run.theta[i], r.theta_rad);
    ASSERT_EQ(run.v[i], r.command_v);
    ASSERT_EQ((*run.column("alpha"))[i], r.alpha);
  }
  EXPECT_NE(slurp(dir / "dataset.json").find("\"non_finite_cells\": \"C: 10, theta_pred: 40\""),
            std::string::npos);
  fs::remove_all(dir);
}

// Finding 9: a run over ~13.9 h could never be written (50 M-row writer limit). Now a run goes on
// in run_2.csv, run_3.csv, … of rows_per_file rows, each within the reader's limits.
TEST(RunRecorder, ALongRunGoesOnInFurtherRunFiles) {
  const fs::path dir = temp_dir("parts");
  RunRecording recording = sine_recording(dir);
  recording.rows_per_file = 1000;
  RunRecorder rec(7, recording, rt::ControlLoopConfig{}, 2.0);
  for (int k = 0; k < 2500; ++k) rec.add(tick(k), kStartS);
  EXPECT_EQ(read_dataset_index(dir).runs.size(), 3u);  // the index names each file as it starts
  const RunResult result = rec.finish(RunEnd{}, rt::ControlLoopConfig{}, 2.0);
  ASSERT_TRUE(result.usable()) << result.brief_report();
  EXPECT_EQ(result.rows, 2500);
  const Dataset ds = read_dataset_index(dir);
  ASSERT_EQ(ds.runs.size(), 3u);
  const std::vector<std::string> files = {"run.csv", "run_2.csv", "run_3.csv"};
  const std::vector<std::size_t> rows = {1000, 1000, 500};
  std::size_t k = 0;
  for (std::size_t p = 0; p < 3; ++p) {
    EXPECT_EQ(ds.runs[p].file, files[p]);
    EXPECT_EQ(ds.runs[p].kind, "sine");
    EXPECT_EQ(ds.runs[p].freq_hz.value(), 3.0);
    const RunData run = read_run(ds, p);
    ASSERT_EQ(run.size(), rows[p]);
    EXPECT_DOUBLE_EQ(ds.runs[p].gamma1_deg.value(), rad_to_deg(tick(static_cast<int>(k)).gamma1_rad));
    for (std::size_t i = 0; i < run.size(); ++i, ++k) {
      ASSERT_EQ(run.theta[i], tick(static_cast<int>(k)).theta_rad);
    }
  }
  fs::remove_all(dir);
}

// Finding 9: an unwritable --record folder was found only after the run, and --record into an
// existing dataset replaced it silently. prepare_recording_folder() runs before the motor moves.
TEST(PrepareRecordingFolder, RefusesAnExistingDatasetWithoutForceAndAFolderItCannotWrite) {
  const fs::path dir = temp_dir("prepare");
  RunRecording recording = sine_recording(dir);
  prepare_recording_folder(recording);  // created
  EXPECT_TRUE(fs::is_directory(dir));
  EXPECT_TRUE(fs::is_empty(dir));  // the probe file is gone
  prepare_recording_folder(recording);  // an empty folder is fine

  { std::ofstream(dir / "dataset.json") << "{}"; }
  try {
    prepare_recording_folder(recording);
    ADD_FAILURE() << "an existing dataset was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.file(), dir.string());
    EXPECT_NE(std::string(e.what()).find("already holds a dataset (dataset.json)"),
              std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--force"), std::string::npos);
  }
  recording.force = true;
  EXPECT_NO_THROW(prepare_recording_folder(recording));
  recording.force = false;
  fs::remove(dir / "dataset.json");
  { std::ofstream(dir / "notes.txt") << "mine"; }
  EXPECT_THROW(prepare_recording_folder(recording), Error);  // not empty
  EXPECT_EQ(slurp(dir / "notes.txt"), "mine");

  recording.dir = dir / "notes.txt";
  EXPECT_THROW(prepare_recording_folder(recording), Error);  // a file
  recording.dir = "/proc/alphainv_cannot_be_created";
  EXPECT_THROW(prepare_recording_folder(recording), Error);
  if (::geteuid() != 0) {  // root writes anywhere
    const fs::path locked = dir / "locked";
    fs::create_directories(locked);
    fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec);
    recording.dir = locked;
    EXPECT_THROW(prepare_recording_folder(recording), Error);
    fs::permissions(locked, fs::perms::owner_all);
  }
  recording.dir = dir / "new";
  recording.flush_period_s = 0.0;
  EXPECT_THROW(prepare_recording_folder(recording), Error);
  fs::remove_all(dir);
}

TEST(RunResult, SaysWhetherTheRunIsUsableAndWhy) {
  const rt::ControlLoopConfig config;
  const fs::path dir = temp_dir("reports");
  RunEnd dropped;
  dropped.dropped_rows = 3;
  const RunResult ok = recorder_with(5, sine_recording(dir))->finish(dropped, config, 2.0);
  EXPECT_TRUE(ok.usable());
  EXPECT_EQ(ok.ended(), "completed");
  EXPECT_EQ(ok.brief_report(), "run 7: completed, 5 rows recorded to " + dir.string() +
                                   " (3 rows dropped: the writer fell behind)");
  EXPECT_EQ(ok.full_report(),
            ok.brief_report() + "\ntiming: ticks 5, deadline misses 2 (4 deadlines skipped)\n" +
                "wake-up latency [us]: p50 31.0  p99 50.5  p99.9 50.5  max 50.5\n" +
                "period jitter [us]:   p50 7.0  p99 10.5  p99.9 10.5  max 10.5\n" +
                "read [us]:            p50 1.5  p99 1.5  max 1.5\n" +
                "write [us]:           p50 3.5  p99 3.5  max 3.5\n");
  fs::remove_all(dir);

  RunEnd stop;
  stop.stopped = true;
  const RunResult unrecorded = recorder_with(5, std::nullopt)->finish(stop, config, 2.0);
  EXPECT_TRUE(unrecorded.usable());
  EXPECT_TRUE(unrecorded.dir.empty());
  EXPECT_EQ(unrecorded.rows, 0);
  EXPECT_EQ(unrecorded.brief_report(), "run 7: stopped, not recorded");

  // One tick is too short for a dataset: not written, and the reason says so.
  const RunResult short_run = recorder_with(1, sine_recording(dir))->finish(stop, config, 2.0);
  EXPECT_FALSE(short_run.usable());
  EXPECT_FALSE(fs::exists(dir / "dataset.json"));
  EXPECT_NE(short_run.recording_error.find("fewer than 2 ticks"), std::string::npos);
  EXPECT_EQ(short_run.brief_report(), "run 7: stopped; recording not written: " +
                                          dir.string() + ": fewer than 2 ticks were recorded");

  // A fault: the rows up to it are written, dataset.json says why the run ended.
  RunEnd fault;
  fault.fault = rt::Fault::kEncoderJump;
  const RunResult faulted = recorder_with(5, sine_recording(dir))->finish(fault, config, 2.0);
  EXPECT_FALSE(faulted.usable());
  EXPECT_EQ(faulted.ended(), "fault: encoder jump (theta changed too much in one tick)");
  EXPECT_EQ(faulted.brief_report(),
            "run 7: fault: encoder jump (theta changed too much in one tick), 5 rows recorded "
            "to " +
                dir.string());
  EXPECT_NE(slurp(dir / "dataset.json").find("\"ended\": \"fault: encoder jump (theta"),
            std::string::npos);
  EXPECT_EQ(read_run(read_dataset_index(dir), 0).size(), 5u);
  fs::remove_all(dir);
}
