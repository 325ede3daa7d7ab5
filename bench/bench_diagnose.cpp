// `omni_fit diagnose` on a 10-run dataset (issue: "diagnose on a 10-run dataset in < 30 s on 2
// cores"): the sweep's dataset (the paper's 9-frequency sine sweep and a 0.25 Hz square wave at
// one pose, 1 kHz, kp = 2, quantisation 1.5e-4 rad, noise 5e-5 rad) with a hidden deadzone, with
// a hidden gravity spring (the search with the α-model re-identified does the most work there),
// and without an effect. Fit of the α-model included. Wall time, two threads. The scale case
// (issue: "< 5 minutes for 50 runs, growing at most linearly with the runs"): the same plan at
// five poses (45 sine runs, 5 square waves), effect-free, with diagnose's default 20 fit runs,
// and with all 50 fitted.
// Run: ./build/release/bench/bench_diagnose --benchmark_repetitions=3
//      --benchmark_report_aggregates_only=true
#include <algorithm>

#include <benchmark/benchmark.h>

#include "alphainv/diagnose/diagnose.hpp"
#include "alphainv/simulate/experiment_plan.hpp"

namespace {

using namespace alphainv;

/// The sweep's plan with `hidden` effects at the first `n_poses` poses from the sweep's (index 3):
/// 10 runs per pose (9 sines, 1 square wave).
GeneratedDataset runs_at_poses(const Effects& hidden, std::size_t n_poses) {
  ExperimentPlanOptions plan = paper_plan_options(3);
  plan.plant.effects = hidden;
  const auto poses = paper_sine_poses();
  plan.sine_poses.clear();
  for (std::size_t k = 0; k < n_poses; ++k) {
    plan.sine_poses.push_back(poses[(3 + k) % poses.size()]);
  }
  plan.square_poses = plan.sine_poses;
  return generate_dataset(make_experiment_plan(plan));
}

void run(benchmark::State& state, const Effects& hidden, std::size_t n_poses = 1,
         std::size_t max_fit_runs = DiagnoseOptions{}.max_fit_runs) {
  const GeneratedDataset g = runs_at_poses(hidden, n_poses);
  DiagnoseOptions o;
  o.threads = 2;
  o.max_fit_runs = max_fit_runs;
  std::string named;
  for (auto _ : state) {
    const DiagnoseResult r = diagnose_dataset(g.index, g.runs, o);
    benchmark::DoNotOptimize(r.error_after);
    named = r.effects_named.empty() ? "none" : effect_name(r.effects_named.front());
  }
  state.counters["runs"] = static_cast<double>(g.runs.size());
  state.counters["fit_runs"] = static_cast<double>(std::min(g.runs.size(), max_fit_runs));
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

void BM_DiagnoseFiftyRunsEffectFree(benchmark::State& state) { run(state, Effects{}, 5); }
BENCHMARK(BM_DiagnoseFiftyRunsEffectFree)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

// All 50 runs fitted and scored (omni_fit diagnose --fit-runs 50): the time per fitted run.
void BM_DiagnoseFiftyRunsAllFittedEffectFree(benchmark::State& state) {
  run(state, Effects{}, 5, 50);
}
BENCHMARK(BM_DiagnoseFiftyRunsAllFittedEffectFree)
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
