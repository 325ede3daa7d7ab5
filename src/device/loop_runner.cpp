#include "alphainv/device/loop_runner.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <optional>

#include "alphainv/error.hpp"

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

nlohmann::json summary_json(const rt::LatencySummary& s) {
  return {{"count", s.count},          {"p50_us", s.p50_s * 1e6}, {"p99_us", s.p99_s * 1e6},
          {"p999_us", s.p999_s * 1e6}, {"max_us", s.max_s * 1e6}, {"mean_us", s.mean_s * 1e6}};
}

}  // namespace

std::string TimingStats::to_json() const {
  nlohmann::json j = {{"period_s", period_s},
                      {"ticks", ticks},
                      {"deadline_misses", deadline_misses},
                      {"skipped_ticks", skipped_ticks},
                      {"wake_latency", summary_json(latency)},
                      {"period_jitter", summary_json(period_jitter)},
                      {"read", summary_json(read)},
                      {"write", summary_json(write)}};
  return j.dump();
}

std::string TimingStats::to_text() const {
  char buf[768];
  std::snprintf(buf, sizeof buf,
                "ticks %ld, deadline misses %ld (%ld deadlines skipped)\n"
                "wake-up latency [us]: p50 %.1f  p99 %.1f  p99.9 %.1f  max %.1f\n"
                "period jitter [us]:   p50 %.1f  p99 %.1f  p99.9 %.1f  max %.1f\n"
                "read [us]:            p50 %.1f  p99 %.1f  max %.1f\n"
                "write [us]:           p50 %.1f  p99 %.1f  max %.1f",
                ticks, deadline_misses, skipped_ticks, latency.p50_s * 1e6, latency.p99_s * 1e6,
                latency.p999_s * 1e6, latency.max_s * 1e6, period_jitter.p50_s * 1e6,
                period_jitter.p99_s * 1e6, period_jitter.p999_s * 1e6, period_jitter.max_s * 1e6,
                read.p50_s * 1e6, read.p99_s * 1e6, read.max_s * 1e6, write.p50_s * 1e6,
                write.p99_s * 1e6, write.max_s * 1e6);
  return buf;
}

LoopRunner::LoopRunner(Transport& transport, const rt::ControlLoopConfig& config,
                       LoopRunnerOptions options)
    : transport_(transport),
      loop_(config),
      options_(std::move(options)),
      commands_(64),
      records_(options_.ring_capacity),
      stream_(256) {
  kp_.store(loop_.kp());
  writer_ = std::thread([this] { writer_main(); });
}

LoopRunner::~LoopRunner() {
  writer_stop_.store(true);
  if (writer_.joinable()) writer_.join();
}

void LoopRunner::add_recording(std::uint32_t run_id, RunRecording recording) {
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
  if (ok) out = results_[run_id];
  return ok;
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
    (void)stream_.push(rec);
    if (run_active) {
      RecordItem item;
      item.record = rec;
      item.run_id = run_id;
      item.run_start_s = run_start_s;
      if (!records_.push(item)) ++dropped;
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

void LoopRunner::writer_main() {
  RecordItem item;
  for (;;) {
    bool any = false;
    while (records_.pop(item)) {
      any = true;
      std::unique_lock<std::mutex> lock(mutex_);
      auto& p = partial_[item.run_id];
      if (!p) {
        p = std::make_unique<Partial>();
        if (recordings_.count(item.run_id)) p->rows.reserve(1 << 16);
      }
      if (item.end == 0) {
        if (p->ticks == 0) p->run_start_s = item.run_start_s;
        if (recordings_.count(item.run_id)) p->rows.push_back(item.record);
        p->latency.add(item.record.wake_latency_s);
        if (p->ticks > 0) p->period_jitter.add(item.record.period_jitter_s);
        p->read.add(item.record.read_s);
        p->write.add(item.record.write_s);
        ++p->ticks;
        p->misses += item.record.deadline_missed ? 1 : 0;
        p->skipped += item.record.deadlines_skipped;
      } else {
        lock.unlock();
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
  // The entry stays in partial_ until the dataset is written: run() waits for partial_ to empty.
  Partial* p = nullptr;
  std::optional<RunRecording> recording;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto& slot = partial_[run_id];
    if (!slot) slot = std::make_unique<Partial>();
    p = slot.get();  // only this (writer) thread changes partial_
    if (auto it = recordings_.find(run_id); it != recordings_.end()) {
      recording = it->second;
      recordings_.erase(it);
    }
  }
  RunResult result;
  result.run_id = run_id;
  result.fault = end_item.record.fault;
  result.stopped = end_item.end == 2;
  result.rows = static_cast<long>(p->rows.size());
  result.dropped_rows = end_item.dropped;
  result.timing.ticks = p->ticks;
  result.timing.deadline_misses = p->misses;
  result.timing.skipped_ticks = p->skipped;
  result.timing.period_s = loop_.config().period_s;
  result.timing.latency = p->latency.summary();
  result.timing.period_jitter = p->period_jitter.summary();
  result.timing.read = p->read.summary();
  result.timing.write = p->write.summary();

  if (recording) {
    result.dir = recording->dir;
    try {
      const auto& rows = p->rows;
      if (rows.size() < 2) throw Error("fewer than 2 ticks were recorded", recording->dir.string());
      RunData data;
      const std::size_t n = rows.size();
      const char* extra_names[] = {"gamma1",     "gamma2",     "alpha",        "C",
                                   "beta_tilde", "theta_pred", "torque_enable"};
      for (const char* name : extra_names) data.extra_columns[name].reserve(n);
      data.t.reserve(n);
      const double t0 = p->run_start_s;  // t = 0 where the waveform starts
      for (const rt::TickRecord& r : rows) {
        data.t.push_back(r.t_s - t0);
        data.r.push_back(r.r_rad);
        data.theta.push_back(r.theta_rad);
        data.v.push_back(r.command_v);
        data.extra_columns["gamma1"].push_back(r.gamma1_rad);
        data.extra_columns["gamma2"].push_back(r.gamma2_rad);
        data.extra_columns["alpha"].push_back(r.alpha);
        data.extra_columns["C"].push_back(r.damping);
        data.extra_columns["beta_tilde"].push_back(r.beta_tilde);
        data.extra_columns["theta_pred"].push_back(r.theta_pred_rad);
        data.extra_columns["torque_enable"].push_back(r.enable ? 1.0 : 0.0);
      }
      Dataset ds;
      ds.joint = "yaw";
      ds.sample_rate_hz = 1.0 / loop_.config().period_s;
      ds.controller.kp = kp_.load();
      ds.controller.v_limit = loop_.config().safety.max_command_v;
      RunInfo info;
      info.file = "run.csv";
      info.kind = recording->kind;
      if (recording->kind == "sine" || recording->kind == "square") {
        info.freq_hz = recording->freq_hz;
        info.amplitude_rad = recording->amplitude_rad;
      } else if (recording->kind == "step") {
        info.amplitude_rad = recording->amplitude_rad;
      }
      info.controller = ds.controller;
      info.gamma1_deg = rad_to_deg(rows.front().gamma1_rad);
      info.gamma2_deg = rad_to_deg(rows.front().gamma2_rad);
      ds.runs.push_back(info);
      std::string ended = result.fault != rt::Fault::kNone
                              ? std::string("fault: ") + rt::to_string(result.fault)
                              : (result.stopped ? "stopped" : "completed");
      nlohmann::json extra = {
          {"source", "omni_ctl"},
          {"command_line", recording->command_line},
          {"device", recording->device},
          {"model", recording->model_source},
          {"ended", ended},
          {"rows", result.rows},
          {"dropped_rows", result.dropped_rows},
          {"max_slew_v_per_s", loop_.config().safety.max_slew_v_per_s},
          {"columns",
           {{"theta_pred",
             "the model's prediction of this row's theta made one tick earlier "
             "(eq. (37) held over a tick); equal to theta when none was possible"},
            {"alpha", "streaming alpha-hat of the command history, eq. (33) [V^2/s^2]"},
            {"C", "C(alpha, I) [1/s], eqs. (38)-(40)"},
            {"beta_tilde", "beta~(alpha, I) [rad/s^2/V], eqs. (41)-(42)"}}},
          {"timing", nlohmann::json::parse(result.timing.to_json())}};
      ds.extra_json = extra.dump();
      write_dataset(recording->dir, ds, {data});
    } catch (const std::exception& e) {
      result.recording_error = e.what();
    }
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    results_[run_id] = result;
    partial_.erase(run_id);
  }
  done_cv_.notify_all();
  if (options_.on_run_done) options_.on_run_done(result);
}

}  // namespace alphainv::device
