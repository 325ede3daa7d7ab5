// Cost of omni_ctl's tick: rt::ControlLoop::tick alone (/0: the paper's model; /1: a model with
// Coulomb friction, offset, cogging and a deadzone; /2: the same with --compensate all; /3: with
// --compensate effects), and with the virtual device's read and write (which include one RK4 plant
// step); and the one-step prediction the runner's writer thread makes from each record, off the
// real-time thread (OneStepPredictor, same configurations). Run:
//   ./build/release/bench/bench_control_loop --benchmark_repetitions=5
//   --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "alphainv/device/sim_transport.hpp"
#include "alphainv/device/control_loop.hpp"
#include "alphainv/device/one_step_predictor.hpp"
#include "alphainv/rt/spsc_ring.hpp"

using namespace alphainv;

/// The loop's configuration: 0 the paper's model; 1 with the effects of docs/compensation.md's
/// plant in the model (the prediction evaluates them); 2 the same with --compensate all; 3 with
/// --compensate effects.
rt::ControlLoopConfig bench_config(std::int64_t variant) {
  rt::ControlLoopConfig c;
  if (variant >= 1) {
    c.effects.coulomb_v = 0.02;
    c.effects.offset_v = -0.01;
    c.effects.cogging_v = 0.01;
    c.effects.deadzone_v = 0.01;
  }
  if (variant == 2) c.compensation.mode = rt::CompensationMode::kAll;
  if (variant == 3) c.compensation.mode = rt::CompensationMode::kEffects;
  return c;
}

/// The measured joint: a 0.95 Hz sine of 400 encoder counts, one period of ticks precomputed
/// (the bench times the tick, not the making of its input).
std::vector<std::int32_t> encoder_trace() {
  std::vector<std::int32_t> counts(static_cast<std::size_t>(std::lround(2.0 * 3.14159265358979 / 6.0 / 1e-3)));
  for (std::size_t k = 0; k < counts.size(); ++k) {
    counts[k] = static_cast<std::int32_t>(400.0 * std::sin(6.0 * 1e-3 * static_cast<double>(k)));
  }
  return counts;
}

static void BM_ControlLoopTick(benchmark::State& state) {
  rt::ControlLoop loop{bench_config(state.range(0))};
  const std::vector<std::int32_t> counts = encoder_trace();
  device::ReadResult in;
  in.status = device::IoStatus::kOk;
  in.reports_read = 1;
  device::OutputReport out;
  double t = 0.0;
  (void)loop.tick(t, in, false, out);
  loop.set_reference(rt::Waveform{rt::WaveKind::kSine, 0.07, 3.0, 0.0}, 0.0, true);
  std::size_t k = 0;
  for (auto _ : state) {
    t += 1e-3;
    ++in.report.sequence;
    if (++k == counts.size()) k = 0;
    in.report.encoder_counts[0] = counts[k];
    benchmark::DoNotOptimize(loop.tick(t, in, false, out));
  }
}
BENCHMARK(BM_ControlLoopTick)->ArgName("effects_compensated")->Arg(0)->Arg(1)->Arg(2)->Arg(3);

/// OneStepPredictor::add() on the records of the tick above (one period of them, precomputed):
/// the cost moved off the real-time thread.
static void BM_OneStepPrediction(benchmark::State& state) {
  const rt::ControlLoopConfig config = bench_config(state.range(0));
  rt::ControlLoop loop{config};
  const std::vector<std::int32_t> counts = encoder_trace();
  device::ReadResult in;
  in.status = device::IoStatus::kOk;
  in.reports_read = 1;
  device::OutputReport out;
  std::vector<rt::TickRecord> records;
  for (std::size_t k = 0; k < counts.size(); ++k) {
    ++in.report.sequence;
    in.report.encoder_counts[0] = counts[k];
    records.push_back(loop.tick(1e-3 * static_cast<double>(k), in, false, out));
    if (k == 0) loop.set_reference(rt::Waveform{rt::WaveKind::kSine, 0.07, 3.0, 0.0}, 0.0, true);
  }
  rt::OneStepPredictor predictor(config);
  std::size_t k = 0;
  for (auto _ : state) {
    rt::TickRecord rec = records[k];
    if (++k == records.size()) k = 0;  // a jump in θ once per period: as a dropped row
    predictor.add(rec);
    benchmark::DoNotOptimize(rec.theta_pred_rad);
  }
}
BENCHMARK(BM_OneStepPrediction)->ArgName("effects_compensated")->Arg(0)->Arg(1)->Arg(2)->Arg(3);

static void BM_TickWithSimDeviceAndRing(benchmark::State& state) {
  rt::ControlLoop loop{rt::ControlLoopConfig{}};
  device::SimTransport sim(VirtualOmniParams{}, device::ReportScaling{});
  rt::SpscRing<rt::TickRecord> ring(1024);
  rt::TickRecord sink;
  double t = 0.0;
  bool started = false;
  for (auto _ : state) {
    const device::ReadResult in = sim.read_latest();
    device::OutputReport out;
    const rt::TickRecord rec = loop.tick(t, in, false, out);
    benchmark::DoNotOptimize(sim.write(out));
    if (!ring.push(rec)) (void)ring.pop(sink);
    if (!started) {
      loop.set_reference(rt::Waveform{rt::WaveKind::kSine, 0.07, 3.0, 0.0}, t, true);
      started = true;
    }
    t += 1e-3;
    if (loop.fault() != rt::Fault::kNone) state.SkipWithError("fault");
  }
}
BENCHMARK(BM_TickWithSimDeviceAndRing);

BENCHMARK_MAIN();
