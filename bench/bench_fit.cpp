// The whole fit of the bundled dataset (issue: "the whole fit of data/omni_yaw_sim in < 10 s on
// 2 cores"): loading the runs, fit_dataset() with and without the validation simulations (on two
// threads), and the report's figures (gnuplot). Wall time.
// Needs data/omni_yaw_sim: ./build/release/apps/omni_gen/omni_gen paper -o data/omni_yaw_sim --seed
// 1 Run: ./build/release/bench/bench_fit --benchmark_repetitions=3
// --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/identify/fit_pipeline.hpp"
#ifdef ALPHAINV_HAVE_PLOTS
#include "plots.hpp"
#endif

namespace {

using namespace alphainv;
namespace fs = std::filesystem;

const fs::path kDataset = fs::path(ALPHAINV_SOURCE_DIR) / "data" / "omni_yaw_sim";
const char* const kMissing =
    "data/omni_yaw_sim is absent: generate it with "
    "./build/release/apps/omni_gen/omni_gen paper -o data/omni_yaw_sim --seed 1";

bool have_dataset() { return fs::exists(kDataset / "dataset.json"); }

/// The dataset and its runs, read once.
struct Loaded {
  Dataset ds;
  std::vector<RunData> data;
};
const Loaded& loaded() {
  static const Loaded l = [] {
    Loaded x;
    x.ds = read_dataset_index(kDataset);
    for (std::size_t i = 0; i < x.ds.runs.size(); ++i) x.data.push_back(read_run(x.ds, i));
    return x;
  }();
  return l;
}

void BM_LoadDataset(benchmark::State& state) {
  if (!have_dataset()) return state.SkipWithError(kMissing);
  for (auto _ : state) {
    Dataset ds = read_dataset_index(kDataset);
    std::size_t rows = 0;
    for (std::size_t i = 0; i < ds.runs.size(); ++i) rows += read_run(ds, i).size();
    benchmark::DoNotOptimize(rows);
  }
}
BENCHMARK(BM_LoadDataset)->Unit(benchmark::kMillisecond)->UseRealTime();

// fit_dataset on the loaded runs: range(0) = 1 with the validation simulations (every run, both
// models), on 2 threads: the "2 cores".
void BM_FitDataset(benchmark::State& state) {
  if (!have_dataset()) return state.SkipWithError(kMissing);
  const Loaded& l = loaded();
  FitPipelineOptions opt;
  opt.run_validation = state.range(0) == 1;
  opt.threads = 2;
  for (auto _ : state) {
    const DatasetFit fit = fit_dataset(l.ds, l.data, opt);
    benchmark::DoNotOptimize(fit.alpha.ok);
  }
  state.counters["runs"] = static_cast<double>(l.ds.runs.size());
}
BENCHMARK(BM_FitDataset)->Arg(0)->ArgName("validate")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_FitDataset)->Arg(1)->ArgName("validate")->Unit(benchmark::kMillisecond)->UseRealTime();

#ifdef ALPHAINV_HAVE_PLOTS
// The report's figures of a finished fit: data, scripts, two re-simulated runs and one gnuplot
// process per figure.
void BM_Plots(benchmark::State& state) {
  if (!have_dataset()) return state.SkipWithError(kMissing);
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) {
    return state.SkipWithError("gnuplot is not installed (Debian: gnuplot-nox)");
  }
  const Loaded& l = loaded();
  FitPipelineOptions fopt;
  fopt.threads = 2;
  static const DatasetFit fit = fit_dataset(l.ds, l.data, fopt);
  omni_fit::PlotOptions opt;
  opt.out_dir = fs::temp_directory_path() / "alphainv_bench_fit";
  std::size_t drawn = 0;
  for (auto _ : state) {
    const omni_fit::PlotSummary s = omni_fit::write_plots(l.ds, l.data, fit, opt);
    drawn = 0;
    for (const auto& f : s.figures) drawn += f.drawn ? 1 : 0;
  }
  state.counters["figures"] = static_cast<double>(drawn);
}
BENCHMARK(BM_Plots)->Unit(benchmark::kMillisecond)->UseRealTime();
#endif

}  // namespace

BENCHMARK_MAIN();
