#pragma once
/// \file device/timing_stats.hpp
/// The timing statistics of a run or of the whole 1 kHz loop (LoopRunner, RunRecorder): ticks,
/// deadline misses, and the wake-up latency, period jitter, read and write durations as
/// percentiles of rt::LatencyHistogram. As text for a terminal, and as a JSON object for
/// dataset.json's `timing` and the daemon's replies (docs/omni_ctl-protocol.md). Not real-time.

#include <string>

#include "alphainv/rt/latency_histogram.hpp"

namespace alphainv::device {

/// Timing statistics of a run or of the whole loop.
struct TimingStats {
  long ticks = 0;            ///< ticks run
  long deadline_misses = 0;  ///< ticks whose work ended after the next deadline
  /// Deadlines passed without a tick after those overruns (one overrun can pass several): a
  /// run of duration D has D/period − skipped_ticks ticks.
  long skipped_ticks = 0;
  rt::LatencySummary latency;        ///< wake-up time minus the deadline
  rt::LatencySummary period_jitter;  ///< |time between wake-ups − period|
  rt::LatencySummary read;           ///< read_latest() durations
  rt::LatencySummary write;          ///< write() durations
  double period_s = 0.0;             ///< nominal period [s]

  /// Five lines: ticks, misses and skipped deadlines; latency, jitter, read, write in µs.
  std::string to_text() const;
};

/// `timing` as one JSON object: `period_s, ticks, deadline_misses, skipped_ticks` and
/// `wake_latency, period_jitter, read, write`, each `{count, p50_us, p99_us, p999_us, max_us,
/// mean_us}` [µs]. `Json` is the caller's nlohmann::json: a template, so that this header (and
/// alphainv::device's interface) does not depend on the JSON library.
template <class Json>
Json timing_json(const TimingStats& timing) {
  const auto summary = [](const rt::LatencySummary& s) {
    Json j;
    j["count"] = s.count;
    j["p50_us"] = s.p50_s * 1e6;
    j["p99_us"] = s.p99_s * 1e6;
    j["p999_us"] = s.p999_s * 1e6;
    j["max_us"] = s.max_s * 1e6;
    j["mean_us"] = s.mean_s * 1e6;
    return j;
  };
  Json j;
  j["period_s"] = timing.period_s;
  j["ticks"] = timing.ticks;
  j["deadline_misses"] = timing.deadline_misses;
  j["skipped_ticks"] = timing.skipped_ticks;
  j["wake_latency"] = summary(timing.latency);
  j["period_jitter"] = summary(timing.period_jitter);
  j["read"] = summary(timing.read);
  j["write"] = summary(timing.write);
  return j;
}

}  // namespace alphainv::device
