// Cost of omni_ctl's tick: rt::ControlLoop::tick alone, and with the virtual device's read and
// write (which include one RK4 plant step). Run:
//   ./build/release/bench/bench_control_loop --benchmark_repetitions=5
//   --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include "alphainv/device/sim_transport.hpp"
#include "alphainv/device/control_loop.hpp"
#include "alphainv/rt/spsc_ring.hpp"

using namespace alphainv;

static void BM_ControlLoopTick(benchmark::State& state) {
  rt::ControlLoop loop{rt::ControlLoopConfig{}};
  device::ReadResult in;
  in.status = device::IoStatus::kOk;
  in.reports_read = 1;
  device::OutputReport out;
  double t = 0.0;
  (void)loop.tick(t, in, false, out);
  loop.set_reference(rt::Waveform{rt::WaveKind::kSine, 0.07, 3.0, 0.0}, 0.0, true);
  for (auto _ : state) {
    t += 1e-3;
    ++in.report.sequence;
    in.report.encoder_counts[0] = static_cast<std::int32_t>(400.0 * std::sin(6.0 * t));
    benchmark::DoNotOptimize(loop.tick(t, in, false, out));
  }
}
BENCHMARK(BM_ControlLoopTick);

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
