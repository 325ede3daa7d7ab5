#include "alphainv/device/loop_runner.hpp"

#include "alphainv/device/emergency_stop.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>

namespace alphainv::device {
namespace {

constexpr long kNsPerS = 1'000'000'000L;

timespec add_ns(timespec t, long ns) noexcept {
  t.tv_nsec += ns;
  while (t.tv_nsec >= kNsPerS) {
    t.tv_nsec -= kNsPerS;
    ++t.tv_sec;
  }
  return t;
}
double diff_s(const timespec& a, const timespec& b) noexcept {  // a − b
  return static_cast<double>(a.tv_sec - b.tv_sec) +
         1e-9 * static_cast<double>(a.tv_nsec - b.tv_nsec);
}
timespec now_mono() noexcept {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t;
}

}  // namespace

std::string LoopOutcome::brief_report() const {
  if (fault != rt::Fault::kNone) {
    char at[64];
    std::snprintf(at, sizeof at, " at t = %.3f s", fault_t_s);
    return std::string("FAULT: ") + rt::to_string(fault) + at +
           "; the motor command was zeroed and the motor disabled" +
           (fault_detail.empty() ? "" : " (" + fault_detail + ")");
  }
  if (stop_requested) return "stopped by signal or stop request; motor zeroed and disabled";
  return "the run ended; motor zeroed and disabled";
}

std::string LoopOutcome::full_report() const {
  return brief_report() + "\ntiming: " + timing.to_text() + "\n";
}

LoopRunner::LoopRunner(Transport& transport, const rt::ControlLoopConfig& config,
                       LoopRunnerOptions options)
    : transport_(transport),
      loop_(config),
      options_(std::move(options)),
      commands_(64),
      records_(options_.ring_capacity),
      stream_(256),
      predictor_(loop_.config()) {
  kp_.store(loop_.kp());
  writer_ = std::thread([this] { writer_main(); });
}

LoopRunner::~LoopRunner() {
  writer_stop_.store(true);
  if (writer_.joinable()) writer_.join();
}

void LoopRunner::add_recording(std::uint32_t run_id, RunRecording recording) {
  prepare_recording_folder(recording);  // before the run is posted: throws naming the folder
  std::lock_guard<std::mutex> lock(mutex_);
  recordings_[run_id] = std::move(recording);
}

bool LoopRunner::post(const LoopCommand& command) { return commands_.push(command); }

bool LoopRunner::latest(rt::TickRecord& out) {
  bool any = false;
  while (stream_.pop(out)) any = true;
  return any;
}

bool LoopRunner::wait_run(std::uint32_t run_id, double timeout_s, RunResult& out) {
  std::unique_lock<std::mutex> lock(mutex_);
  const bool ok = done_cv_.wait_for(lock, std::chrono::duration<double>(timeout_s),
                                    [&] { return results_.count(run_id) != 0; });
  if (ok) {
    const auto it = results_.find(run_id);
    out = std::move(it->second);
    results_.erase(it);
  }
  return ok;
}

std::size_t LoopRunner::kept_results() {
  std::lock_guard<std::mutex> lock(mutex_);
  return results_.size();
}

RealtimeSetup request_realtime(int priority, bool lock_memory) {
  RealtimeSetup setup;
  if (lock_memory) {
    setup.locked = mlockall(MCL_CURRENT | MCL_FUTURE) == 0;
    if (!setup.locked) {
      setup.warnings.push_back(std::string("mlockall failed (") + std::strerror(errno) +
                               "): page faults may delay ticks; run as root or raise "
                               "RLIMIT_MEMLOCK (ulimit -l)");
    }
  }
  if (priority > 0) {
    // Like cyclictest: hold /dev/cpu_dma_latency at 0 µs for the process's life so the CPU does
    // not enter deep idle states between ticks (their exit latency adds to every wake-up).
    static int dma_fd = -1;
    if (dma_fd < 0) {
      dma_fd = open("/dev/cpu_dma_latency", O_WRONLY | O_CLOEXEC);
      const std::int32_t zero = 0;
      if (dma_fd < 0 || write(dma_fd, &zero, sizeof zero) != static_cast<ssize_t>(sizeof zero)) {
        setup.warnings.push_back(std::string("cannot hold /dev/cpu_dma_latency at 0 (") +
                                 std::strerror(errno) +
                                 "): deep CPU idle states may add wake-up latency");
        if (dma_fd >= 0) close(dma_fd);
        dma_fd = -1;
      }
    }
    setup.cpu_dma_latency_zero = dma_fd >= 0;
    sched_param sp{};
    sp.sched_priority = priority;
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
    setup.fifo = rc == 0;
    if (!setup.fifo) {
      setup.warnings.push_back(std::string("SCHED_FIFO priority ") + std::to_string(priority) +
                               " refused (" + std::strerror(rc) +
                               "): running under the normal scheduler, expect more jitter; "
                               "grant CAP_SYS_NICE or an rtprio limit (ulimit -r)");
    }
  }
  return setup;
}

std::string RealtimeSetup::describe() const {
  return std::string(fifo ? "SCHED_FIFO" : "normal scheduler") + (locked ? ", memory locked" : "") +
         (cpu_dma_latency_zero ? ", cpu_dma_latency 0" : "");
}

// Longer than the house's ~120 lines on purpose: the loop thread's whole cycle (wait for the
// deadline, tick, timing, hand-off to the writer, stop and fault handling) is kept in one function
// that a real-time review reads top to bottom; its parts share the cycle's local state.
LoopOutcome LoopRunner::run(const std::atomic<bool>& stop) {
  LoopOutcome outcome;
  const double period_s = loop_.config().period_s;
  const long period_ns = std::lround(period_s * 1e9);
  // Whole-loop statistics, allocated before the first tick.
  const auto lat_ptr = std::make_unique<rt::LatencyHistogram>();
  const auto rd_ptr = std::make_unique<rt::LatencyHistogram>();
  const auto wr_ptr = std::make_unique<rt::LatencyHistogram>();
  rt::LatencyHistogram& lat = *lat_ptr;
  const auto pj_ptr = std::make_unique<rt::LatencyHistogram>();
  rt::LatencyHistogram& pj = *pj_ptr;
  timespec prev_wake{};
  rt::LatencyHistogram& rd = *rd_ptr;
  rt::LatencyHistogram& wr = *wr_ptr;
  long ticks = 0, misses = 0, skipped_total = 0, dropped = 0;
  bool run_active = false;
  std::uint32_t run_id = 0;
  double run_end_s = 0.0;
  double run_start_s = 0.0;
  bool pending_valid = false;
  LoopCommand pending;
  bool missed = false;
  std::uint32_t skipped = 0;  // deadlines the last overrun passed
  bool stop_requested = false;
  double last_t_s = 0.0;

  // From the first tick to the last report, a crash of the process zeroes the motor first
  // (emergency_stop.hpp); this thread gets its own stack for the handler.
  const AlternateSignalStack signal_stack;
  arm_emergency_stop(transport_);
  const timespec start = now_mono();
  timespec deadline = start;
  // --- the tick: no allocation, no locks, no I/O but the device's -----------------------------
  for (;;) {
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr) == EINTR) {
    }
    const timespec wake = now_mono();
    const double t_s = diff_s(deadline, start);
    last_t_s = t_s;
    const double latency_s = diff_s(wake, deadline);

    const ReadResult in = transport_.read_latest();
    const timespec after_read = now_mono();
    OutputReport out;
    rt::TickRecord rec = loop_.tick(t_s, in, missed, out);
    rec.deadlines_skipped = skipped;
    const IoStatus ws = transport_.write(out);
    note_sequence(out.sequence);
    const timespec after_write = now_mono();
    if (ws != IoStatus::kOk) loop_.latch(rt::Fault::kDisconnected);

    rec.wake_latency_s = latency_s;
    if (ticks > 0) {
      rec.period_jitter_s = std::abs(diff_s(wake, prev_wake) - period_s);
      pj.add(rec.period_jitter_s);
    }
    prev_wake = wake;
    rec.read_s = diff_s(after_read, wake);
    rec.write_s = diff_s(after_write, after_read);
    if (rec.fault == rt::Fault::kNone) rec.fault = loop_.fault();
    lat.add(latency_s);
    rd.add(rec.read_s);
    wr.add(rec.write_s);
    ++ticks;
    ticks_.store(ticks, std::memory_order_relaxed);
    misses_.store(misses, std::memory_order_relaxed);
    {  // every tick, for the prediction and the stream; the run's rows for its recording
      RecordItem item;
      item.record = rec;
      item.tick = ticks;
      item.in_run = run_active;
      item.run_id = run_id;
      item.run_start_s = run_start_s;
      if (!records_.push(item) && run_active) ++dropped;
    }

    // Commands: a pending run starts once there is a measurement to centre it on.
    if (!pending_valid) pending_valid = commands_.pop(pending);
    const bool faulted = loop_.fault() != rt::Fault::kNone;
    bool end_run = false;
    std::uint8_t end_kind = 1;
    if (pending_valid && !faulted) {
      switch (pending.kind) {
        case LoopCommand::Kind::kSetKp:
          (void)loop_.set_kp(pending.kp);  // the server checked the range
          kp_.store(loop_.kp(), std::memory_order_relaxed);
          pending_valid = false;
          break;
        case LoopCommand::Kind::kStop:
          if (run_active) {
            end_run = true;
            end_kind = 2;
          }
          pending_valid = false;
          break;
        case LoopCommand::Kind::kRun:
          if (loop_.has_measurement() && !run_active) {
            const double t_next = t_s + period_s;
            loop_.set_reference(pending.wave, t_next, true);
            run_active = true;
            run_active_.store(true, std::memory_order_relaxed);
            run_id = pending.run_id;
            run_start_s = t_next;
            run_end_s =
                pending.duration_s > 0.0 ? t_next + pending.duration_s - 0.5 * period_s : INFINITY;
            dropped = 0;
            pending_valid = false;
          } else if (run_active) {
            end_run = true;  // a new run replaces the current one: end it first
            end_kind = 2;
          }
          break;
      }
    }
    if (run_active && t_s + period_s > run_end_s) end_run = true;
    if (stop.load(std::memory_order_relaxed)) {
      stop_requested = true;
      if (run_active) {
        end_run = true;
        end_kind = 2;
      }
    }
    if (faulted && run_active) end_run = true;
    if (end_run) {
      RecordItem item;
      item.record = rec;
      item.record.fault = loop_.fault();
      item.run_id = run_id;
      item.end = end_kind;
      item.dropped = dropped;
      while (!records_.push(item)) {  // the end marker must arrive: wait for the writer
        timespec ts{0, 100'000};
        nanosleep(&ts, nullptr);
      }
      run_active = false;
      run_active_.store(false, std::memory_order_relaxed);
      loop_.hold();
      if (options_.exit_when_idle) break;
    }
    if (faulted || stop_requested) break;

    // Next deadline; when the work overran it, the next tick reports a miss and the loop skips
    // to the first deadline still ahead.
    deadline = add_ns(deadline, period_ns);
    const timespec done = now_mono();
    missed = diff_s(done, deadline) > 0.0;
    skipped = 0;
    if (missed) {
      ++misses;
      while (diff_s(done, deadline) > 0.0) {
        deadline = add_ns(deadline, period_ns);
        ++skipped;
      }
      skipped_total += skipped;
    }
  }
  // --- end of the tick ---------------------------------------------------------------------
  (void)transport_.write(loop_.safe_report());  // zero, disabled: a second time on every exit
  disarm_emergency_stop();

  outcome.fault = loop_.fault();
  outcome.fault_t_s = last_t_s;
  outcome.stop_requested = stop_requested;
  if (outcome.fault == rt::Fault::kDisconnected) outcome.fault_detail = transport_.last_error();
  outcome.timing.ticks = ticks;
  outcome.timing.deadline_misses = misses;
  outcome.timing.skipped_ticks = skipped_total;
  outcome.timing.period_s = period_s;
  outcome.timing.latency = lat.summary();
  outcome.timing.period_jitter = pj.summary();
  outcome.timing.read = rd.summary();
  outcome.timing.write = wr.summary();
  // Let the writer finish what it has (the recording is complete before run() returns).
  while (records_.size() != 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  {
    std::unique_lock<std::mutex> lock(mutex_);
    done_cv_.wait_for(lock, std::chrono::seconds(30), [&] { return partial_.empty(); });
  }
  return outcome;
}

RunRecorder& LoopRunner::recorder(std::uint32_t run_id) {
  auto& slot = partial_[run_id];
  if (!slot) {
    std::optional<RunRecording> recording;
    if (auto it = recordings_.find(run_id); it != recordings_.end()) {
      recording = std::move(it->second);
      recordings_.erase(it);
    }
    slot = std::make_unique<RunRecorder>(run_id, std::move(recording), loop_.config(), kp_.load());
  }
  return *slot;
}

void LoopRunner::writer_main() {
  RecordItem item;
  long last_tick = 0;  // ticks count from 1
  for (;;) {
    bool any = false;
    while (records_.pop(item)) {
      any = true;
      if (item.end == 0) {
        // The model's prediction (off the real-time thread): from every tick in order; after
        // rows dropped for a full ring it starts afresh.
        if (item.tick != last_tick + 1) predictor_.reset();
        last_tick = item.tick;
        predictor_.add(item.record);
        (void)stream_.push(item.record);
        if (!item.in_run) continue;
        RunRecorder* rec = nullptr;  // only this thread changes partial_: it outlives the lock
        {
          std::lock_guard<std::mutex> lock(mutex_);
          rec = &recorder(item.run_id);
        }
        rec->add(item.record, item.run_start_s);  // may write to disk: outside the lock
      } else {
        finish_run(item.run_id, item);
      }
    }
    if (!any) {
      if (writer_stop_.load()) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
}

void LoopRunner::finish_run(std::uint32_t run_id, const RecordItem& end_item) {
  // The recorder stays in partial_ until the dataset is written: run() waits for partial_ to
  // empty. Only this (writer) thread changes partial_, so the recorder outlives the lock.
  RunRecorder* rec = nullptr;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    rec = &recorder(run_id);
  }
  RunEnd end;
  end.fault = end_item.record.fault;
  end.stopped = end_item.end == 2;
  end.dropped_rows = end_item.dropped;
  const RunResult result = rec->finish(end, loop_.config(), kp_.load());
  // Told before the run leaves partial_: run() returns once partial_ is empty, and a caller that
  // acts on its return (the daemon closes its clients) must already hold this result. Called the
  // other way round, a fault's run_done was lost when the daemon closed first (a flaky
  // OmniCtlDaemon.AFaultStopsTheDaemonAndTellsTheClient under load).
  if (options_.on_run_done) options_.on_run_done(result);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    results_[run_id] = result;
    // Bounded: the oldest results nobody waited for go (a daemon's runs are told through
    // on_run_done; before this bound each one stayed for the process's life).
    while (results_.size() > kKeptResults) results_.erase(results_.begin());
    partial_.erase(run_id);
  }
  done_cv_.notify_all();
}

}  // namespace alphainv::device
