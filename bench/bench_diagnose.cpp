// `omni_fit diagnose` on a 10-run dataset (issue: "diagnose on a 10-run dataset in < 30 s on 2
// cores"): the sweep's dataset (the paper's 9-frequency sine sweep and a 0.25 Hz square wave at
// one pose, 1 kHz, kp = 2, quantisation 1.5e-4 rad, noise 5e-5 rad) with a hidden deadzone, with
// a hidden gravity spring (the search with the α-model re-identified does the most work there),
// and without an effect. Fit of the α-model included. Wall time, two threads.
// Run: ./build/release/bench/bench_diagnose --benchmark_repetitions=3
//      --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include "alphainv/diagnose/diagnose.hpp"
#include "alphainv/simulate/experiment_plan.hpp"

namespace {

using namespace alphainv;

GeneratedDataset ten_runs(const Effects& hidden) {
  ExperimentPlanOptions plan = paper_plan_options(3);
  plan.plant.effects = hidden;
  const auto poses = paper_sine_poses();
  plan.sine_poses = {poses[3]};
  plan.square_poses = plan.sine_poses;
  return generate_dataset(make_experiment_plan(plan));
}

void run(benchmark::State& state, const Effects& hidden) {
  const GeneratedDataset g = ten_runs(hidden);
  DiagnoseOptions o;
  o.threads = 2;
  std::string named;
  for (auto _ : state) {
    const DiagnoseResult r = diagnose_dataset(g.index, g.runs, o);
    benchmark::DoNotOptimize(r.error_after);
    named = r.effects_named.empty() ? "none" : effect_name(r.effects_named.front());
  }
  state.counters["runs"] = static_cast<double>(g.runs.size());
  state.SetLabel("named " + named);
}

void BM_DiagnoseTenRunsDeadzone(benchmark::State& state) {
  Effects e;
  e.deadzone_v = 0.01;
  run(state, e);
}
BENCHMARK(BM_DiagnoseTenRunsDeadzone)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

void BM_DiagnoseTenRunsGravity(benchmark::State& state) {
  Effects e;
  e.gravity_v = 0.3;
  run(state, e);
}
BENCHMARK(BM_DiagnoseTenRunsGravity)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

void BM_DiagnoseTenRunsEffectFree(benchmark::State& state) { run(state, Effects{}); }
BENCHMARK(BM_DiagnoseTenRunsEffectFree)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
