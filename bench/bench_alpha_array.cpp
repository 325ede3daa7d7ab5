// The α-invariant of a whole sampled command in C++: the loop alphainv.alpha (python/) runs, over
// 10⁶ samples, for the Python-vs-C++ figure of bench/bench_python.py (issue #17).
// Run: ./build/release/bench/bench_alpha_array --benchmark_repetitions=7 --benchmark_report_aggregates_only=true
#include <cmath>
#include <vector>

#include <benchmark/benchmark.h>

#include "alphainv/rt/alpha_estimator.hpp"

namespace {

void BM_AlphaOfArray(benchmark::State& state) {
  const std::size_t n = static_cast<std::size_t>(state.range(0));
  std::vector<double> v(n), alpha(n);
  for (std::size_t k = 0; k < n; ++k) v[k] = 0.2 * std::sin(2.0 * 3.14159265358979 * 3.0 * 1e-3 * static_cast<double>(k));
  for (auto _ : state) {
    alphainv::rt::AlphaEstimator est({1e-3, 25.0});
    est.reset(v[0]);
    for (std::size_t k = 0; k < n; ++k) alpha[k] = est.update(v[k]).alpha;
    benchmark::DoNotOptimize(alpha.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
}
BENCHMARK(BM_AlphaOfArray)->Arg(1000000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
