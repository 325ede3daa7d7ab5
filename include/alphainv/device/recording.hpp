#pragma once
/// \file device/recording.hpp
/// The recording of one loop run: RunRecorder takes the run's tick records (rt::TickRecord) as
/// the loop's writer thread pops them, streams them to an alphainv-dataset/1 folder as they come
/// (docs/omni_ctl.md, "Recording" and "Durability of recordings") and gathers the run's timing
/// statistics: run.csv with t, r, theta, v and the loop's columns, appended and fdatasync'ed every
/// RunRecording::flush_period_s; dataset.json written atomically with the first row, saying
/// `"ended": "interrupted"`, and rewritten atomically at the end with how the run ended and its
/// timing. A kill or crash therefore leaves a dataset omni_fit reads, holding every row up to the
/// last flush. Memory is bounded by one flush period's rows, whatever the run's length; a run
/// longer than rows_per_file continues in run_2.csv, run_3.csv, … (each a run of the dataset).
/// The run's RunResult says whether the run is usable and why not, with a one-line and a full
/// report (like Ceres' Solver::Summary).
///
/// Not real-time: everything here allocates and does I/O off the tick (LoopRunner's writer thread).

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/data/run_csv_appender.hpp"
#include "alphainv/device/control_loop.hpp"
#include "alphainv/device/timing_stats.hpp"
#include "alphainv/rt/latency_histogram.hpp"

namespace alphainv::device {

/// Where and how a run is recorded.
struct RunRecording {
  /// Dataset folder: created, or an empty one (prepare_recording_folder() checks it).
  std::filesystem::path dir;
  /// The run's waveform: its kind names the run ("sine", "square", "step"; hold: "other"), its
  /// frequency (sine, square) and amplitude (sine, square, step) go into dataset.json.
  rt::Waveform wave;
  std::string command_line;  ///< for dataset.json's `command_line`
  std::string device;        ///< Transport::describe()
  std::string model_source;  ///< "paper" or the model file
  bool force = false;        ///< record into a folder that holds a dataset, replacing it
  double flush_period_s = 0.5;  ///< rows are appended and synced to disk this often [s of run]
  /// Rows of one run file (1 h at 1 kHz, about 0.7 GB: well inside ReadLimits); the run goes on
  /// in run_2.csv, run_3.csv, …
  std::size_t rows_per_file = 3'600'000;
};

/// Checks, before the run starts (before the motor moves), that the recording can be written:
/// `recording.dir` is missing (it is created) or an empty folder, or `force` is set; a file is
/// created and removed in it to prove it writable; flush_period_s > 0, rows_per_file >= 2.
/// Throws alphainv::Error naming the folder and why (e.g. "the folder already holds a dataset
/// (dataset.json); give a new folder, or --force to replace it").
void prepare_recording_folder(const RunRecording& recording);

/// How a run ended (the loop's end-of-run marker).
struct RunEnd {
  rt::Fault fault = rt::Fault::kNone;  ///< the fault in force at the end
  bool stopped = false;                ///< ended by a stop request rather than its duration
  long dropped_rows = 0;               ///< rows lost because the record ring was full
};

/// What a finished run reports (to LoopRunnerOptions::on_run_done and LoopRunner::wait_run()).
struct RunResult {
  std::uint32_t run_id = 0;
  rt::Fault fault = rt::Fault::kNone;
  bool stopped = false;         ///< ended by a stop request rather than its duration
  long rows = 0;                ///< rows recorded
  long dropped_rows = 0;        ///< rows lost because the record ring was full
  TimingStats timing;           ///< of this run's ticks
  std::string recording_error;  ///< why the dataset could not be (wholly) written, or empty
  /// Derived cells that were not finite (e.g. theta_pred of a model that overflows), written as
  /// `nan` (readers ignore such a column; the measured ones are kept), as "name: count", or empty.
  std::string non_finite_note;
  std::filesystem::path dir;    ///< the dataset folder, or empty when not recorded

  /// True when the run ended without a fault and, when it was recorded, its dataset was written
  /// (dropped rows leave gaps in t, which the format allows: still usable).
  bool usable() const noexcept { return fault == rt::Fault::kNone && recording_error.empty(); }
  /// "completed", "stopped" or "fault: <rt::to_string(fault)>" (dataset.json's `ended`).
  std::string ended() const;
  /// One line: the run, how it ended, and where its rows went or why they were not written, e.g.
  /// "run 1: completed, 2000 rows recorded to /tmp/run".
  std::string brief_report() const;
  /// brief_report() and the run's timing (TimingStats::to_text()), one item a line.
  std::string full_report() const;
};

/// The recording of one run (see the file comment). One thread (the writer) calls it.
class RunRecorder {
 public:
  /// A run `run_id` of a loop configured with `config` and gain `kp` [V/rad] (for dataset.json);
  /// with `recording` its rows are streamed to the recording's folder (which
  /// prepare_recording_folder() should have checked), without it only its timing is gathered.
  RunRecorder(std::uint32_t run_id, std::optional<RunRecording> recording,
              const rt::ControlLoopConfig& config = {}, double kp = 0.0);
  ~RunRecorder();

  /// Adds the run's next tick. `run_start_s` [s]: the loop time at which the run's waveform
  /// starts (t = 0 of the recording), taken from the first tick. With a recording, the row goes
  /// into run.csv's buffer (t from the run's start [s], r, theta [rad], v [V], and the extra
  /// columns C [1/s], alpha [V²/s²], beta_tilde [rad/s² per V], gamma1, gamma2 [rad],
  /// theta_pred [rad], torque_enable (0/1)); the first row creates the files, then every
  /// flush_period_s of run time the buffer is appended and synced. Never throws: a write error
  /// stops the recording (finish() reports it), not the run.
  void add(const rt::TickRecord& record, double run_start_s);

  /// dataset.json of the rows so far: 1 kHz sample rate from `config.period_s`, the controller
  /// (`kp` [V/rad], v_limit = the clamp), the runs (run.csv, run_2.csv, …: kind, frequency,
  /// amplitude, the pose of the first row) and, as extra keys, the recording's source, command
  /// line, device, model, how `result` ended, its rows, dropped rows, the slew limit, the
  /// columns' meaning and its timing.
  Dataset dataset(const RunResult& result, const rt::ControlLoopConfig& config, double kp) const;

  /// Ends the run: its result (timing with `config.period_s`) and, when recorded, the last rows
  /// synced and dataset.json rewritten with how the run ended. Never throws: why the dataset
  /// could not be written goes into the result's recording_error.
  RunResult finish(const RunEnd& end, const rt::ControlLoopConfig& config, double kp);

  bool recorded() const noexcept { return recording_.has_value(); }
  long ticks() const noexcept { return ticks_; }
  /// Rows synced to disk so far (all files).
  long rows_flushed() const noexcept;

 private:
  void write_row(const rt::TickRecord& record);
  void start_file();
  void write_index(const std::string& ended, const RunResult* result) const;
  std::string file_name(std::size_t part) const;

  std::uint32_t run_id_;
  std::optional<RunRecording> recording_;
  rt::ControlLoopConfig config_;
  double kp_ = 0.0;
  std::unique_ptr<RunCsvAppender> csv_;  ///< the run file being written
  std::vector<rt::TickRecord> first_rows_;  ///< the first row of each run file (its pose)
  std::vector<long> part_non_finite_;       ///< non-finite cells of closed files, per column
  long rows_ = 0, rows_closed_ = 0;         ///< rows added; rows of closed files
  double last_flush_t_s_ = 0.0;
  std::string write_error_;
  rt::LatencyHistogram latency_, period_jitter_, read_, write_;
  long ticks_ = 0, misses_ = 0, skipped_ = 0;
  double run_start_s_ = 0.0;
};

}  // namespace alphainv::device
