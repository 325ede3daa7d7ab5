#pragma once
/// \file device/loop_runner.hpp
/// The 1 kHz loop around rt::ControlLoop: absolute deadlines (clock_nanosleep, TIMER_ABSTIME),
/// SCHED_FIFO and mlockall when permitted (a warning and a fallback when not), the transport's
/// read and write each tick, commands into the loop and tick records out of it through lock-free
/// SPSC rings, a writer thread that makes the model's one-step prediction of every tick
/// (one_step_predictor.hpp, off the real-time thread), hands the records of a run to its
/// RunRecorder (recording.hpp: the alphainv-dataset/1 folder) and streams the newest, and the timing statistics (wake-up latency p50/p99/p99.9/max, deadline misses, read/write
/// times).
///
/// Each tick: read_latest() → ControlLoop::tick() → write() → push the record (every tick, in a
/// run or not: the prediction needs them all) → pop commands.
/// No allocation, no locks and no I/O other than the device's in the tick (run()'s loop body).
/// On a fault the tick writes a zero, disabled report at once; on exit (fault, stop request, end
/// of the run) a second one; then the writer thread flushes the recording (dataset.json last,
/// atomically) before run() returns.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "alphainv/device/control_loop.hpp"
#include "alphainv/device/one_step_predictor.hpp"
#include "alphainv/device/recording.hpp"
#include "alphainv/device/timing_stats.hpp"
#include "alphainv/device/transport.hpp"
#include "alphainv/rt/latency_histogram.hpp"
#include "alphainv/rt/spsc_ring.hpp"

namespace alphainv::device {

/// A command into the loop.
struct LoopCommand {
  enum class Kind : std::uint8_t { kRun, kStop, kSetKp };
  Kind kind = Kind::kRun;
  rt::Waveform wave;         ///< kRun: the waveform (offset relative to the current θ)
  double duration_s = 0.0;   ///< kRun: how long [s]; ≤ 0: until a kStop
  double kp = 0.0;           ///< kSetKp: the new gain [V/rad]
  std::uint32_t run_id = 0;  ///< kRun: the run's id (its recording, if registered)
};

/// What request_realtime() obtained.
struct RealtimeSetup {
  bool fifo = false;                  ///< SCHED_FIFO granted
  bool locked = false;                ///< mlockall succeeded
  bool cpu_dma_latency_zero = false;  ///< /dev/cpu_dma_latency held at 0 µs (as cyclictest does)
  std::vector<std::string> warnings;  ///< one line per refusal, with the fix

  /// What was obtained, for a log line: "SCHED_FIFO, memory locked, cpu_dma_latency 0", or
  /// "normal scheduler" and what else was granted.
  std::string describe() const;
};

/// Asks for SCHED_FIFO at `priority` (0: don't ask) for the calling thread and, with
/// `lock_memory`, mlockall(MCL_CURRENT | MCL_FUTURE); with a priority, it also holds
/// /dev/cpu_dma_latency at 0 µs as cyclictest does. Never fails: refusals become warnings and
/// the loop runs under the normal scheduler. Not real-time; call on the loop's thread before run().
RealtimeSetup request_realtime(int priority, bool lock_memory);

/// Settings of the runner.
struct LoopRunnerOptions {
  std::size_t ring_capacity = 1 << 15;  ///< ticks the record ring holds (32 s at 1 kHz)
  bool exit_when_idle = false;          ///< run() returns when a run ends (single-run mode)
  /// Called on the writer thread when a run's recording is finished (may be empty), before
  /// run() can return: whoever acts on run()'s return already has every run's result.
  std::function<void(const RunResult&)> on_run_done;
};

/// What run() returns.
struct LoopOutcome {
  rt::Fault fault = rt::Fault::kNone;
  std::string fault_detail;     ///< e.g. the transport's error text
  bool stop_requested = false;  ///< ended by the stop flag (a signal)
  double fault_t_s = 0.0;       ///< loop time of the fault [s]
  TimingStats timing;           ///< the whole loop

  /// True when the loop ended without a fault (a stop request or, exit_when_idle, its run's end).
  bool usable() const noexcept { return fault == rt::Fault::kNone; }
  /// One line: how the loop ended and that the motor was zeroed and disabled, e.g.
  /// "FAULT: encoder jump at t = 0.200 s; the motor command was zeroed and the motor disabled".
  std::string brief_report() const;
  /// brief_report() and the whole loop's timing (TimingStats::to_text()), one item a line.
  std::string full_report() const;
};

/// The loop (see the file comment).
class LoopRunner {
 public:
  /// Allocates the rings and the ControlLoop (throws alphainv::Error naming a bad field) and
  /// starts the writer thread.
  LoopRunner(Transport& transport, const rt::ControlLoopConfig& config, LoopRunnerOptions options);
  ~LoopRunner();
  LoopRunner(const LoopRunner&) = delete;
  LoopRunner& operator=(const LoopRunner&) = delete;

  /// Registers the recording of run `run_id`; call before posting its kRun. Any thread. Checks
  /// the recording's folder first (prepare_recording_folder(): new or empty, or `force`;
  /// writable) and throws alphainv::Error naming it, so a refused folder never starts a run.
  void add_recording(std::uint32_t run_id, RunRecording recording);
  /// Sends a command to the loop; false when the command ring is full. One producer thread.
  bool post(const LoopCommand& command);
  /// Runs the loop on the calling thread (see the file comment) until `stop` becomes true, a
  /// fault, or (exit_when_idle) the end of a run. Call request_realtime() on this thread first.
  LoopOutcome run(const std::atomic<bool>& stop);
  /// Pops the newest tick records the writer thread streamed (with their prediction; a few ms
  /// behind the loop) into `out` (keeps the last); false when none arrived since the last call.
  /// One consumer thread.
  bool latest(rt::TickRecord& out);
  /// Waits up to timeout_s for run `run_id`'s result and hands it over (a second call for the same
  /// run waits in vain). Any thread.
  bool wait_run(std::uint32_t run_id, double timeout_s, RunResult& out);
  /// Results kept for wait_run() (at most kKeptResults: the newest; a daemon that takes its
  /// results from on_run_done and never waits keeps no more than that). Any thread.
  std::size_t kept_results();
  static constexpr std::size_t kKeptResults = 16;
  /// The loop's gain now (as of the last tick). Any thread.
  double kp() const noexcept { return kp_.load(std::memory_order_relaxed); }
  bool running_waveform() const noexcept { return run_active_.load(std::memory_order_relaxed); }
  /// Ticks so far (updated every tick). Any thread.
  long ticks() const noexcept { return ticks_.load(std::memory_order_relaxed); }
  /// Deadline misses so far (updated every tick). Any thread.
  long deadline_misses() const noexcept { return misses_.load(std::memory_order_relaxed); }
  const rt::ControlLoopConfig& config() const noexcept { return loop_.config(); }

 private:
  struct RecordItem {
    rt::TickRecord record;
    std::uint32_t run_id = 0;
    double run_start_s = 0.0;  ///< loop time at which the run's waveform starts (t = 0) [s]
    std::uint8_t end = 0;      ///< 1: end of run (record.fault says why), 2: stopped by request
    bool in_run = false;       ///< the tick belongs to run run_id (else the loop was idle)
    long tick = 0;             ///< the tick's index since the loop started (a gap: rows dropped)
    long dropped = 0;          ///< at end: rows dropped for a full ring
  };
  void writer_main();
  void finish_run(std::uint32_t run_id, const RecordItem& end_item);

  Transport& transport_;
  rt::ControlLoop loop_;
  LoopRunnerOptions options_;
  rt::SpscRing<LoopCommand> commands_;
  rt::SpscRing<RecordItem> records_;
  rt::SpscRing<rt::TickRecord> stream_;  ///< pushed by the writer thread
  rt::OneStepPredictor predictor_;        ///< used by the writer thread only
  std::atomic<double> kp_{0.0};
  std::atomic<bool> run_active_{false};
  std::atomic<long> ticks_{0}, misses_{0};

  // Writer thread state.
  std::thread writer_;
  std::atomic<bool> writer_stop_{false};
  std::mutex mutex_;  // guards recordings_, partial_, results_ (never taken by the loop)
  std::condition_variable done_cv_;
  std::map<std::uint32_t, RunRecording> recordings_;
  /// The recorder of run `run_id` in partial_, made (with its registered recording, if any) on
  /// its first record. Call with mutex_ held.
  RunRecorder& recorder(std::uint32_t run_id);
  std::map<std::uint32_t, std::unique_ptr<RunRecorder>> partial_;  ///< runs not yet finished
  std::map<std::uint32_t, RunResult> results_;
};

}  // namespace alphainv::device
