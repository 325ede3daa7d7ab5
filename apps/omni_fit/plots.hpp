#pragma once
/// \file plots.hpp
/// The figures of `omni_fit fit`'s report (the paper's Figs 4-14), drawn by gnuplot. For each
/// figure the plot data go to OUTDIR/plots/<id>.dat (whitespace columns, a `#` header naming them
/// with units) and a gnuplot script to OUTDIR/plots/<id>.gp; then `gnuplot <id>.gp` is run in
/// OUTDIR/plots and writes <id>.png (first to a temporary name, renamed when gnuplot succeeded, so
/// a PNG on disk is always complete). Without gnuplot, or when it fails, the data and scripts stay
/// for a later `cd OUTDIR/plots && gnuplot <id>.gp`, and the summary says why there are no PNGs.
/// Offline; gnuplot is never part of the alphainv libraries.

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace alphainv {
struct Dataset;
struct RunData;
struct DatasetFit;
}  // namespace alphainv

namespace omni_fit {

/// Settings of write_plots().
struct PlotOptions {
  std::filesystem::path out_dir;    ///< OUTDIR; figures go to OUTDIR/plots
  std::string gnuplot = "gnuplot";  ///< program run for each script (looked up on PATH)
  bool run_gnuplot = true;          ///< false: write data and scripts only
  /// Progress ("plots", figures done, total); may be empty.
  std::function<void(std::string_view stage, std::size_t done, std::size_t total)> progress;
};

/// One figure whose data and script were written.
struct Figure {
  std::string id;       ///< e.g. "fig11_bode_pose1": the stem of the .dat, .gp and .png files
  std::string caption;  ///< one sentence for the report
  bool drawn = false;   ///< the PNG exists (gnuplot succeeded)
  std::string error;    ///< gnuplot's complaint when it failed on this figure
};

/// What write_plots() did.
struct PlotSummary {
  std::vector<Figure> figures;       ///< in report order
  std::vector<std::string> skipped;  ///< figures the data cannot support, and why
  std::string gnuplot_problem;       ///< why no figure was drawn (gnuplot missing, disabled, …)
  /// The report's "Figures" section: links `plots/<id>.png` with captions, or says why not.
  std::string markdown() const;
};

/// Writes the figures' data and scripts and runs gnuplot (see file comment). Simulates at most two
/// runs again (the time-domain overlays) with the fitted models, as fit_dataset()'s validation
/// does. Throws alphainv::Error naming the file when a data or script file cannot be written;
/// gnuplot problems never throw, they are recorded in the summary.
PlotSummary write_plots(const alphainv::Dataset& dataset,
                        const std::vector<alphainv::RunData>& data, const alphainv::DatasetFit& fit,
                        const PlotOptions& options);

/// The report section for a fit whose plots were not attempted (`--no-plots`) or threw.
std::string plots_skipped_markdown(std::string_view why);

/// write_plots() for `omni_fit fit`: returns the report's Figures section and never throws (a write
/// error becomes the reason the plots were skipped). `warning` is set to one line when figures
/// could not be drawn, and cleared otherwise.
std::string draw_report_figures(const alphainv::Dataset& dataset,
                                const std::vector<alphainv::RunData>& data,
                                const alphainv::DatasetFit& fit, const PlotOptions& options,
                                std::string& warning);

/// The script preamble every figure uses: a PNG terminal (pngcairo when available) writing to
/// `outfile` (default <id>.png), NaN as missing data.
std::string gnuplot_preamble(const std::string& id, const std::string& caption, int width,
                             int height);

/// A gnuplot string literal of `s`.
std::string gnuplot_quote(std::string_view s);

/// Runs `gnuplot` on dir/<id>.gp, writing dir/<id>.png atomically (temporary name, renamed when
/// gnuplot succeeded and wrote a PNG). Returns "" or why not.
std::string draw_gnuplot_figure(const std::string& gnuplot, const std::filesystem::path& dir,
                                const std::string& id);

/// Whether `program` can be run: a name with a '/' as is, else looked up along PATH (as execvp).
bool program_on_path(const std::string& program);

/// Writes `text` to `path` through a temporary name in the same folder, fsync'ed and renamed (the
/// folder fsync'ed too), so a reader sees the old file or the whole new one, also after a crash.
/// Throws alphainv::Error naming the file (src/common/atomic_file.hpp, the library's writer).
void write_text_atomic(const std::filesystem::path& path, const std::string& text);

}  // namespace omni_fit
