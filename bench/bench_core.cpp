// Benchmarks of the core: the 1 kHz tick and the closed-loop simulations (issue: core library).
// Run: ./build/release/bench/bench_core --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <cmath>

#include <benchmark/benchmark.h>

#include "alphainv/model/damping_model.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "alphainv/rt/alpha_estimator.hpp"
#include "alphainv/simulate/simulate.hpp"

namespace {

using namespace alphainv;

// One 1 kHz tick: P law, streaming α update, I(γ1, γ2), C(α, I) and β̃(α, I).
void BM_Tick(benchmark::State& state) {
  const InertiaModel inertia = paper_inertia_model();
  const AlphaModel model = paper_alpha_model();
  rt::AlphaEstimator estimator;
  estimator.reset();
  const double kp = 2.0, g1 = deg_to_rad(60.08), g2 = deg_to_rad(87.0);
  double t = 0.0, theta = 0.0, sink = 0.0;
  for (auto _ : state) {
    const double r = 0.07 * std::sin(18.85 * t);
    const double v = kp * (r - theta);  // P law
    const rt::AlphaEstimate e = estimator.update(v);
    const double i = inertia.inertia(g1, g2);
    const double c = model.damping(e.alpha, i);
    const double b = model.beta_tilde(e.alpha, i);
    theta += 1e-3 * (b * v - c * theta) * 1e-3;  // stand-in for the measured angle
    sink += c + b;
    t += 1e-3;
    benchmark::DoNotOptimize(sink);
  }
}
BENCHMARK(BM_Tick);

JointModelAtPose PaperPose(bool use_alpha) {
  return model_at_pose(paper_linear_model(), paper_alpha_model(), deg_to_rad(60.08),
                       deg_to_rad(87.00), use_alpha);
}

// A 4 s square-wave response (0.25 Hz, ±0.07 rad, kp = 2) at 1 kHz, the paper's step experiment.
void BM_SquareWave4s(benchmark::State& state) {
  const JointModelAtPose m = PaperPose(state.range(0) != 2);
  SimulationOptions opt;
  opt.integrator = state.range(0) == 1 ? Integrator::kCvode : Integrator::kFixedPointRk4;
  const SquareReference ref(0.07, 0.25);
  const auto times = uniform_times(4.0, 1e-3);
  double mean_it = 0.0;
  for (auto _ : state) {
    const SimulationResult res = simulate(m, Controller{}, ref, times, {-0.07, 0.0, 0.0}, opt);
    benchmark::DoNotOptimize(res.theta.back());
    mean_it = res.mean_iterations();
  }
  state.counters["fixed_point_iterations_per_eval"] = mean_it;
}
BENCHMARK(BM_SquareWave4s)->Arg(0)->ArgName("alpha_fixed_point")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SquareWave4s)->Arg(1)->ArgName("alpha_cvode")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SquareWave4s)->Arg(2)->ArgName("linear_rk4")->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
