#pragma once
/// \file device/recording.hpp
/// The recording of one loop run: RunRecorder takes the run's tick records (rt::TickRecord) as
/// the loop's writer thread pops them, gathers the run's timing statistics, and at the end turns
/// the rows into an alphainv-dataset/1 folder (docs/omni_ctl.md, "Recording"): run.csv with
/// t, r, theta, v and the loop's columns, dataset.json (written last, atomically) with the
/// controller, the run, how it ended and its timing. The run's RunResult says whether the run is
/// usable and why not, with a one-line and a full report (like Ceres' Solver::Summary).
///
/// Not real-time: everything here allocates and runs off the tick (LoopRunner's writer thread).

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/device/control_loop.hpp"
#include "alphainv/device/timing_stats.hpp"
#include "alphainv/rt/latency_histogram.hpp"

namespace alphainv::device {

/// Where and how a run is recorded.
struct RunRecording {
  std::filesystem::path dir;  ///< dataset folder (created; its dataset.json replaced)
  /// The run's waveform: its kind names the run ("sine", "square", "step"; hold: "other"), its
  /// frequency (sine, square) and amplitude (sine, square, step) go into dataset.json.
  rt::Waveform wave;
  std::string command_line;  ///< for dataset.json's `command_line`
  std::string device;        ///< Transport::describe()
  std::string model_source;  ///< "paper" or the model file
};

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
  std::string recording_error;  ///< why the dataset could not be written, or empty
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
  /// A run `run_id`; with `recording`, its rows are kept and written by finish(), without it
  /// only its timing is gathered.
  RunRecorder(std::uint32_t run_id, std::optional<RunRecording> recording);

  /// Adds the run's next tick. `run_start_s` [s]: the loop time at which the run's waveform
  /// starts (t = 0 of the recording), taken from the first tick.
  void add(const rt::TickRecord& record, double run_start_s);

  /// The rows so far as a run of the format: t (from the run's start) [s], r, theta [rad], v [V],
  /// and the extra columns gamma1, gamma2 [rad], alpha [V²/s²], C [1/s], beta_tilde
  /// [rad/s² per V], theta_pred [rad], torque_enable (0/1).
  RunData run_data() const;
  /// dataset.json of the rows so far: 1 kHz sample rate from `config.period_s`, the controller
  /// (`kp` [V/rad], v_limit = the clamp), the run (kind, frequency, amplitude, the pose of its
  /// first row) and, as extra keys, the recording's source, command line, device, model, how
  /// `result` ended, its rows, dropped rows, the slew limit, the columns' meaning and its timing.
  Dataset dataset(const RunResult& result, const rt::ControlLoopConfig& config, double kp) const;

  /// Ends the run: its result (timing with `config.period_s`) and, when recorded, the dataset
  /// written to the recording's folder. Never throws: why the dataset could not be written goes
  /// into the result's recording_error.
  RunResult finish(const RunEnd& end, const rt::ControlLoopConfig& config, double kp) const;

  bool recorded() const noexcept { return recording_.has_value(); }
  long ticks() const noexcept { return ticks_; }

 private:
  std::uint32_t run_id_;
  std::optional<RunRecording> recording_;
  std::vector<rt::TickRecord> rows_;  ///< only when recorded
  rt::LatencyHistogram latency_, period_jitter_, read_, write_;
  long ticks_ = 0, misses_ = 0, skipped_ = 0;
  double run_start_s_ = 0.0;
};

}  // namespace alphainv::device
