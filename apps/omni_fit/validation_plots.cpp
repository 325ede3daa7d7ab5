#include "validation_plots.hpp"

#include <algorithm>
#include <limits>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "alphainv/data/dataset.hpp"
#include "alphainv/error.hpp"
#include "alphainv/identify/validation.hpp"
#include "common/format.hpp"
#include "common/parallel_for.hpp"

namespace omni_fit {

namespace {

using namespace alphainv;
namespace fs = std::filesystem;

std::string dat_num(double x) { return std::isfinite(x) ? common::sig(x, 10) : "NaN"; }

struct Draft {
  std::string id, caption, dat, gp;
};

/// The median sample step of `t` [s] (0 for fewer than 2 samples).
double median_step_s(const std::vector<double>& t) {
  if (t.size() < 2) return 0.0;
  std::vector<double> dt(t.size() - 1);
  for (std::size_t k = 1; k < t.size(); ++k) dt[k - 1] = t[k] - t[k - 1];
  std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
  return dt[dt.size() / 2];
}

std::string fit_text(const FitFigures& f) {
  return "fit " + (std::isfinite(f.fit_percent) ? common::fixed(f.fit_percent, 1) : "–") +
         " %, RMS " + common::sig(f.rms, 3);
}

/// Fit % of every validated run (bars), white residuals marked.
Draft fit_per_run(const Dataset& ds, const ValidationResult& r, const std::string& prefix) {
  Draft f{prefix + "_fit_per_run", "", "", ""};
  f.caption = "NRMSE fit % of θ for each of the " + std::to_string(r.runs.size()) +
              " runs (dataset order; filled: residual white, open: not white; missing: not "
              "validated)";
  std::ostringstream s;
  s << "# run (1-based)  fit_percent  fit_if_white  fit_if_not_white  file\n";
  bool any_white = false, any_not_white = false;
  for (std::size_t i = 0; i < r.runs.size(); ++i) {
    const ValidatedRun& v = r.runs[i];
    const double fit = v.ok ? v.position.fit_percent : std::nan("");
    const bool white = v.ok && v.residual.valid && v.residual.white;
    if (std::isfinite(fit)) (white ? any_white : any_not_white) = true;
    s << i + 1 << " " << dat_num(fit) << " " << dat_num(white ? fit : std::nan("")) << " "
      << dat_num(white ? std::nan("") : fit) << " " << gnuplot_quote(ds.runs[i].file) << "\n";
  }
  f.dat = s.str();
  std::ostringstream g;
  g << gnuplot_preamble(f.id, f.caption, 900, 420)
    << "set title " << gnuplot_quote("validated on " + std::to_string(r.runs.size()) +
                                     " runs: pooled " + fit_text(r.position))
    << " noenhanced\n"
    << "set xlabel 'run (dataset order)'\nset ylabel 'NRMSE fit [%]'\n"
    << "set xrange [0:" << r.runs.size() + 1 << "]\nset key bottom right\n"
    << "plot '" << f.id << ".dat' using 1:2 with impulses lc rgb '#888888' notitle";
  // Only the series that have points (gnuplot warns about an all-missing one).
  if (any_white) g << ", \\\n     '' using 1:3 with points pt 7 ps 1.0 lc rgb '#1f5fbf' title 'residual white'";
  if (any_not_white) g << ", \\\n     '' using 1:4 with points pt 6 ps 1.0 lc rgb '#cc2222' title 'residual not white'";
  g << "\n";
  f.gp = g.str();
  return f;
}

/// compare: θ and θ_sim over time, the residual below.
Draft compare_draft(const Dataset& ds, const RunData& d, const ValidatedRun& v, std::size_t i,
                    const std::string& prefix, std::size_t max_points) {
  Draft f{prefix + "_compare_run" + std::to_string(i + 1), "", "", ""};
  const std::string unit = ds.position_unit;
  f.caption = "compare, " + v.file + ": measured θ and the model's θ_sim simulated from " +
              (v.first_sample > 0 ? "a state fitted on the first " +
                                        std::to_string(v.first_sample) + " samples (left of the line)"
                                  : std::string("the measured initial state")) +
              "; below, the residual θ − θ_sim (" + fit_text(v.position) + " " + unit + ")";
  const std::size_t n = std::min(d.size(), v.theta_simulated.size());
  const std::size_t step = std::max<std::size_t>(1, (n + max_points - 1) / std::max<std::size_t>(max_points, 1));
  std::ostringstream s;
  s << "# " << v.file << ": t [s]  theta_measured [" << unit << "]  theta_simulated [" << unit
    << "]  residual [" << unit << "]";
  if (step > 1) s << "  (every " << step << "th sample)";
  s << "\n";
  for (std::size_t k = 0; k < n; k += step) {
    s << dat_num(d.t[k]) << " " << dat_num(d.theta[k]) << " " << dat_num(v.theta_simulated[k])
      << " " << dat_num(d.theta[k] - v.theta_simulated[k]) << "\n";
  }
  f.dat = s.str();
  std::ostringstream g;
  g << gnuplot_preamble(f.id, f.caption, 900, 640)
    << "set multiplot layout 2,1 title " << gnuplot_quote(v.file + ": " + fit_text(v.position) +
                                                          " " + unit)
    << " noenhanced\n"
    << "set autoscale xfix\nset offsets 0, 0, graph 0.05, graph 0.05\nset key top right\n";
  if (v.first_sample > 0 && v.first_sample < n) {
    g << "set arrow 1 from " << dat_num(d.t[v.first_sample]) << ", graph 0 to "
      << dat_num(d.t[v.first_sample]) << ", graph 1 nohead lc rgb '#888888' dt 2\n";
  }
  g << "set ylabel 'θ [" << unit << "]'\nset format x ''\n"
    << "plot '" << f.id << ".dat' using 1:2 with lines lc rgb 'black' lw 2 title 'measured', \\\n"
    << "     '' using 1:3 with lines lc rgb '#cc2222' lw 1.5 title 'simulated'\n"
    << "set format x '%g'\nset xlabel 'time [s]'\nset ylabel 'θ − θ_{sim} [" << unit << "]'\n"
    << "plot '" << f.id << ".dat' using 1:4 with lines lc rgb '#1f5fbf' title 'residual'\n"
    << "unset multiplot\n";
  f.gp = g.str();
  return f;
}

/// resid: ρ_e(τ) and ρ_eu(τ) with their 99 % bands.
Draft resid_draft(const RunData& d, const ValidatedRun& v, std::size_t i, const std::string& prefix,
                  double confidence) {
  const ResidualTests& t = v.residual;
  Draft f{prefix + "_resid_run" + std::to_string(i + 1), "", "", ""};
  const std::string conf = common::sig(100.0 * confidence, 3) + " %";
  f.caption = "resid, " + v.file + ": autocorrelation of the residual and its cross-correlation "
              "with the input, " + conf + " bands (" + t.verdict() + ")";
  const double lag_s = median_step_s(d.t) * static_cast<double>(t.decimation);
  const int m = static_cast<int>(t.autocorrelation.size()) - 1;
  std::ostringstream s;
  s << "# " << v.file << ", every " << t.decimation << " sample(s), n = " << t.n
    << "\n# block 0: lag [s]  lag [steps]  rho_e  band (+-)\n";
  for (int k = 0; k <= m; ++k) {
    s << dat_num(k * lag_s) << " " << k << " " << dat_num(t.autocorrelation[static_cast<std::size_t>(k)])
      << " " << dat_num(t.autocorrelation_bound) << "\n";
  }
  s << "\n\n# block 1: lag [s]  lag [steps]  rho_eu  band (+-)\n";
  const int mc = static_cast<int>(t.cross_correlation.size() / 2);
  for (int k = -mc; k <= mc && !t.cross_correlation.empty(); ++k) {
    s << dat_num(k * lag_s) << " " << k << " "
      << dat_num(t.cross_correlation[static_cast<std::size_t>(k + mc)]) << " "
      << dat_num(t.cross_correlation_bound) << "\n";
  }
  f.dat = s.str();
  std::ostringstream g;
  g << gnuplot_preamble(f.id, f.caption, 900, 640)
    << "set multiplot layout 2,1 title " << gnuplot_quote(v.file) << " noenhanced\n"
    << "set key top right\nset xzeroaxis\nset offsets graph 0.02, graph 0.02, 0, 0\n"
    << "set title " << gnuplot_quote("autocorrelation of the residual: " +
                                     std::string(t.white ? "white" : "not white"))
    << "\nset xlabel 'lag [s]'\nset ylabel 'ρ_e'\n"
    << "plot '" << f.id << ".dat' index 0 using 1:3 with impulses lc rgb '#1f5fbf' lw 2 notitle, \\\n"
    << "     '' index 0 using 1:4 with lines lc rgb '#cc2222' dt 2 title " << gnuplot_quote(conf + " band")
    << ", \\\n     '' index 0 using 1:(-$4) with lines lc rgb '#cc2222' dt 2 notitle\n";
  if (t.cross_correlation.empty()) {
    g << "set title 'no input'\nunset key\nplot 0 notitle\n";
  } else {
    g << "set title " << gnuplot_quote("cross-correlation with the input: " +
                                       std::string(t.input_correlated ? "correlated" : "uncorrelated"))
      << "\nset ylabel 'ρ_{eu}'\n"
      << "plot '" << f.id << ".dat' index 1 using 1:3 with impulses lc rgb '#1f5fbf' lw 2 notitle, \\\n"
      << "     '' index 1 using 1:4 with lines lc rgb '#cc2222' dt 2 title " << gnuplot_quote(conf + " band")
      << ", \\\n     '' index 1 using 1:(-$4) with lines lc rgb '#cc2222' dt 2 notitle\n";
  }
  g << "unset multiplot\n";
  f.gp = g.str();
  return f;
}

}  // namespace

std::vector<std::size_t> validation_runs_shown(const ValidationResult& result, std::size_t max_runs) {
  std::vector<std::size_t> ok;
  for (std::size_t i = 0; i < result.runs.size(); ++i) {
    if (result.runs[i].ok) ok.push_back(i);
  }
  if (ok.size() > max_runs) {
    // The lowest fit % first (a run whose θ is constant, fit % NaN, by its RMS after those).
    auto key = [&](std::size_t i) {
      const double f = result.runs[i].position.fit_percent;
      return std::isfinite(f) ? f : std::numeric_limits<double>::infinity();
    };
    std::stable_sort(ok.begin(), ok.end(), [&](std::size_t a, std::size_t b) {
      if (key(a) != key(b)) return key(a) < key(b);
      return result.runs[a].position.rms > result.runs[b].position.rms;
    });
    ok.resize(max_runs);
    std::sort(ok.begin(), ok.end());
  }
  return ok;
}

PlotSummary write_validation_plots(const Dataset& dataset, const std::vector<RunData>& data,
                                   const ValidationResult& result,
                                   const ValidationPlotOptions& options) {
  PlotSummary summary;
  std::vector<Draft> drafts;
  if (result.runs.size() != data.size() || data.size() != dataset.runs.size()) {
    summary.skipped.push_back("validation figures: the result does not match the dataset");
    return summary;
  }
  if (!result.ok) {
    summary.skipped.push_back("validation figures: no run was validated");
    return summary;
  }
  drafts.push_back(fit_per_run(dataset, result, options.prefix));
  for (std::size_t i : validation_runs_shown(result, options.max_runs)) {
    const ValidatedRun& v = result.runs[i];
    drafts.push_back(compare_draft(dataset, data[i], v, i, options.prefix, options.max_points));
    if (v.residual.valid) {
      drafts.push_back(resid_draft(data[i], v, i, options.prefix, 0.99));
    } else {
      summary.skipped.push_back("resid of " + v.file + ": " + v.residual.message);
    }
  }
  const fs::path dir = options.plot.out_dir / "plots";
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error("cannot create the plots folder: " + ec.message(), dir.string());
  for (const Draft& d : drafts) {
    write_text_atomic(dir / (d.id + ".dat"), d.dat);
    write_text_atomic(dir / (d.id + ".gp"), d.gp);
    summary.figures.push_back(Figure{d.id, d.caption, false, ""});
  }
  if (!options.plot.run_gnuplot) {
    summary.gnuplot_problem = "drawing was not asked for";
    return summary;
  }
  if (!program_on_path(options.plot.gnuplot)) {
    summary.gnuplot_problem =
        "`" + options.plot.gnuplot + "` was not found on PATH (Debian: apt-get install gnuplot-nox)";
    return summary;
  }
  // One gnuplot per figure, several at once (each writes only its own files).
  const std::size_t n = summary.figures.size();
  if (options.plot.progress) options.plot.progress("validation plots", 0, n);
  common::parallel_for(n, options.threads, [&](std::size_t k) {
    Figure& f = summary.figures[k];
    f.error = draw_gnuplot_figure(options.plot.gnuplot, dir, f.id);
    f.drawn = f.error.empty();
  });
  if (options.plot.progress) options.plot.progress("validation plots", n, n);
  std::size_t drawn = 0;
  for (const Figure& f : summary.figures) drawn += f.drawn ? 1 : 0;
  if (drawn == 0 && n > 0) {
    summary.gnuplot_problem = "gnuplot failed on every figure; first: " + summary.figures[0].error;
  }
  return summary;
}

std::string draw_validation_figures(const Dataset& dataset, const std::vector<RunData>& data,
                                    const ValidationResult& result,
                                    const ValidationPlotOptions& options,
                                    const std::string& heading, std::string& warning) {
  warning.clear();
  std::size_t validated = 0;
  for (const ValidatedRun& v : result.runs) validated += v.ok ? 1 : 0;
  const std::size_t shown = std::min(validated, options.max_runs);
  std::string intro = "The NRMSE fit of every run, then `compare` (measured against simulated θ, "
                      "the residual below) and `resid` (the residual's autocorrelation and its "
                      "cross-correlation with the input, 99 % bands) for ";
  intro += shown == validated
               ? "each of the " + std::to_string(validated) + " validated runs"
               : "the " + std::to_string(shown) + " of the " + std::to_string(validated) +
                     " validated runs with the lowest fit % (`--plot-runs N` shows more)";
  intro += ".\n\n";
  std::string md;
  try {
    const PlotSummary s = write_validation_plots(dataset, data, result, options);
    if (!s.gnuplot_problem.empty()) warning = "validation plots skipped: " + s.gnuplot_problem;
    md = s.markdown();
  } catch (const std::exception& e) {
    warning = std::string("validation plots skipped: ") + e.what();
    md = plots_skipped_markdown(e.what());
  }
  // PlotSummary::markdown() opens with "\n## Figures\n\n": retitled for this section.
  const std::string generic = "\n## Figures\n\n";
  if (md.rfind(generic, 0) == 0) md = md.substr(generic.size());
  return "\n" + heading + " Validation figures\n\n" + intro + md;
}

}  // namespace omni_fit
