#pragma once
/// \file validation_plots.hpp
/// The figures of a validation (`omni_fit validate`, and the held-out runs of `omni_fit fit
/// --validate-on/--holdout`), as MATLAB's `compare` and `resid` show them, drawn through the
/// gnuplot path of plots.hpp (OUTDIR/plots/<id>.dat, <id>.gp, <id>.png; data and scripts stay when
/// gnuplot is missing or fails):
/// - `<prefix>_fit_per_run`: NRMSE fit % of every validated run, white residuals marked;
/// - per shown run i (dataset index, from 1), `<prefix>_compare_run<i>`: measured θ against the
///   simulated θ_sim over time, and below it the residual e = θ − θ_sim;
/// - per shown run, `<prefix>_resid_run<i>`: the autocorrelation ρ_e(τ) and the cross-correlation
///   ρ_eu(τ) with the input, each with its 99 % band (residual_analysis.hpp), lags in seconds.
/// The shown runs: all validated runs when there are at most `max_runs`, else the `max_runs` with
/// the lowest fit % (the ones a reader must look at); the report says which and why.
/// Offline; gnuplot is run, never linked.

#include <cstddef>
#include <string>
#include <vector>

#include "plots.hpp"

namespace alphainv {
struct ValidationResult;
}

namespace omni_fit {

/// Settings of write_validation_plots().
struct ValidationPlotOptions {
  PlotOptions plot;              ///< out_dir (figures in out_dir/plots), gnuplot, progress
  std::size_t max_runs = 3;      ///< runs shown with their compare and resid figures
  std::string prefix = "validation";  ///< file stem prefix (fit's held-out runs: "heldout")
  std::size_t max_points = 20000;     ///< time samples per compare figure (every k-th beyond)
  unsigned threads = 0;          ///< gnuplot processes at once (0: all cores)
};

/// Writes the validation figures (see file comment) and draws them. `dataset` and `data` are the
/// ones `result` was computed on (result.runs[i] ↔ data[i]). Throws alphainv::Error naming the
/// file when a data or script file cannot be written; gnuplot problems are in the summary.
PlotSummary write_validation_plots(const alphainv::Dataset& dataset,
                                   const std::vector<alphainv::RunData>& data,
                                   const alphainv::ValidationResult& result,
                                   const ValidationPlotOptions& options);

/// write_validation_plots() for a report: its Figures section (`heading`: "##", "###"), never
/// throws (a write error becomes the reason the figures were skipped); `warning` set to one line
/// when figures could not be drawn, cleared otherwise.
std::string draw_validation_figures(const alphainv::Dataset& dataset,
                                    const std::vector<alphainv::RunData>& data,
                                    const alphainv::ValidationResult& result,
                                    const ValidationPlotOptions& options,
                                    const std::string& heading, std::string& warning);

/// The runs write_validation_plots() shows (indices into result.runs, in dataset order).
std::vector<std::size_t> validation_runs_shown(const alphainv::ValidationResult& result,
                                               std::size_t max_runs);

}  // namespace omni_fit
