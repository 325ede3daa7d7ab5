#include "plots.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "alphainv/data/dataset.hpp"
#include "alphainv/error.hpp"
#include "alphainv/identify/fit_pipeline.hpp"
#include "alphainv/identify/output_error.hpp"
#include "alphainv/simulate/reference.hpp"
#include "alphainv/simulate/simulate.hpp"
#include "common/atomic_file.hpp"
#include "common/format.hpp"

extern char** environ;

namespace omni_fit {

namespace {

using namespace alphainv;
namespace fs = std::filesystem;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// A number in a .dat file: 10 significant digits, "NaN" (declared missing in every script) when
/// not finite.
std::string dat_num(double x) { return std::isfinite(x) ? common::sig(x, 10) : "NaN"; }

/// A gnuplot single-quoted string: a quote is written twice, nothing else is special.
std::string gp_quote(std::string_view s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

/// Unit strings of a dataset, in gnuplot's enhanced-text syntax (labels) and in Markdown.
struct Units {
  std::string pos, cmd;
  std::string alpha() const { return cmd + "^2/s^2"; }
  std::string beta_tilde() const { return pos + "/(s^2·" + cmd + ")"; }
  std::string inertia() const { return cmd + "·s^2/" + pos; }
  std::string alpha_md() const { return cmd + "²/s²"; }
  std::string beta_tilde_md() const { return pos + "/(s²·" + cmd + ")"; }
};

/// The pose as a panel or series title (enhanced text).
std::string pose_title(const PoseFit& p) {
  if (!p.gamma1_deg || !p.gamma2_deg) return "all runs (no pose)";
  return "γ_1 = " + common::fixed(*p.gamma1_deg, 2) + "°, γ_2 = " +
         common::fixed(*p.gamma2_deg, 2) + "°";
}

/// The pose in Markdown.
std::string pose_md(const PoseFit& p) {
  if (!p.gamma1_deg || !p.gamma2_deg) return "all runs (no pose)";
  return "γ1 = " + common::fixed(*p.gamma1_deg, 2) + "°, γ2 = " + common::fixed(*p.gamma2_deg, 2) +
         "°";
}

bool is_step(const RunInfo& r) { return r.kind == "square" || r.kind == "step"; }

/// log-spaced values from lo to hi (lo, hi > 0).
std::vector<double> log_grid(double lo, double hi, std::size_t n) {
  std::vector<double> g(n);
  for (std::size_t k = 0; k < n; ++k) {
    g[k] = lo * std::pow(hi / lo, static_cast<double>(k) / static_cast<double>(n - 1));
  }
  return g;
}

/// Unwraps a phase sequence [deg] along its order so that steps stay within ±180°.
void unwrap_deg(std::vector<double>& phase) {
  double prev = kNaN;
  for (double& p : phase) {
    if (!std::isfinite(p)) continue;
    if (std::isfinite(prev)) {
      while (p - prev > 180.0) p -= 360.0;
      while (p - prev < -180.0) p += 360.0;
    } else if (p > 90.0) {
      p -= 360.0;  // a lagging plant: start in (−270, 90]
    }
    prev = p;
  }
}

/// Script preamble: PNG terminal (pngcairo when this gnuplot has it), output to `outfile`, which
/// the caller may set with -e (omni_fit writes to a temporary name), NaN as missing.
std::string preamble(const std::string& id, const std::string& caption, int width, int height) {
  std::ostringstream s;
  s << "# " << id << ".gp, written by omni_fit: " << caption << "\n"
    << "# Run in this folder: gnuplot " << id << ".gp  (writes " << id << ".png)\n"
    << "if (!exists(\"outfile\")) outfile = " << gp_quote(id + ".png") << "\n"
    << "set encoding utf8\n"
    << "if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) {\n"
    << "  set terminal pngcairo enhanced size " << width << "," << height
    << " font 'Sans,10' linewidth 1.5\n"
    << "} else {\n"
    << "  set terminal png enhanced size " << width << "," << height << "\n"
    << "}\n"
    << "set output outfile\n"
    << "set datafile missing 'NaN'\n"
    << "set grid lc rgb '#dddddd'\n"
    << "set key box opaque samplen 2 spacing 1.3\n";  // spacing: room for accents (C̄, β̃)
  return s.str();
}

// Line styles shared by the figures: measured black points, linear blue dashed, α red.
const char* const kStyles =
    "set style line 1 lc rgb 'black' pt 7 ps 0.9\n"
    "set style line 2 lc rgb '#1f5fbf' dt 2 lw 1.5 pt 4 ps 0.9\n"
    "set style line 3 lc rgb '#cc2222' lw 1.5 pt 6 ps 0.9\n"
    "set style line 4 lc rgb '#888888' dt 3 lw 1\n";

// Distinct series colours (Tableau 10) and point types for series beyond ten.
const char* const kSeriesColours[10] = {"#4e79a7", "#f28e2b", "#e15759", "#76b7b2", "#59a14f",
                                        "#edc948", "#b07aa1", "#ff9da7", "#9c755f", "#333333"};
const int kSeriesPoints[4] = {7, 5, 9, 13};

/// Columns × rows of a multiplot with n panels.
std::pair<int, int> grid_of(std::size_t n) {
  const int cols = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n))));
  const int rows =
      static_cast<int>((n + static_cast<std::size_t>(cols) - 1) / static_cast<std::size_t>(cols));
  return {cols, rows};
}

/// One figure being built: its .dat and .gp text.
struct Draft {
  std::string id, caption, dat, gp;
};

class Plotter {
 public:
  Plotter(const Dataset& ds, const std::vector<RunData>& data, const DatasetFit& fit)
      : ds_(ds), data_(data), fit_(fit), u_{ds.position_unit, ds.command_unit} {
    for (std::size_t p = 0; p < fit.poses.size(); ++p) {
      for (std::size_t i : fit.poses[p].runs) run_pose_[i] = p;
    }
  }

  std::vector<Draft> drafts;
  std::vector<std::string> skipped;

  void make_all() {
    inertia_figures();
    alpha_frequency();
    c_beta_alpha();
    bode();
    time_overlays();
  }

 private:
  const Dataset& ds_;
  const std::vector<RunData>& data_;
  const DatasetFit& fit_;
  Units u_;
  std::map<std::size_t, std::size_t> run_pose_;

  /// Sine points of pose p, by frequency.
  std::vector<const SineRunPoint*> points_of(std::size_t p) const {
    std::vector<const SineRunPoint*> v;
    for (const auto& sp : fit_.sine_points) {
      if (sp.pose == p) v.push_back(&sp);
    }
    std::sort(v.begin(), v.end(),
              [](auto* a, auto* b) { return a->point.freq_hz < b->point.freq_hz; });
    return v;
  }

  // --- Figs 4-7: C and β̃ against the inertia, linear and α-model ---------------------------------
  void inertia_figures() {
    if (!fit_.has_inertia_model) {
      skipped.push_back(
          "Figs 4-7 (C and β̃ against inertia): no inertia model was fitted (see the "
          "notes above)");
      return;
    }
    const LinearModel& lin = fit_.inertia.model;
    std::vector<std::size_t> ps;
    double i_lo = std::numeric_limits<double>::infinity(), i_hi = 0.0;
    for (std::size_t p = 0; p < fit_.poses.size(); ++p) {
      const PoseFit& pose = fit_.poses[p];
      if (!pose.gamma1_deg || !pose.linear.valid) continue;
      ps.push_back(p);
      i_lo = std::min(i_lo, pose.inertia);
      i_hi = std::max(i_hi, pose.inertia);
    }
    if (ps.empty() || !(i_lo > 0.0)) return;
    const std::vector<double> grid = log_grid(0.85 * i_lo, 1.15 * i_hi, 60);
    const std::string xlabel = "set xlabel 'inertia I (model (6)) [" + u_.inertia() + "]'\n";

    {  // Fig 4 and 5: the global linear fits (22) per pose against the inertia model (28)-(29)
      std::ostringstream d;
      d << "# index 0: one row per pose: I [" << u_.inertia()
        << "]  C_linear [1/s]  beta_tilde_linear [" << u_.beta_tilde()
        << "]  gamma1 [deg]  gamma2 [deg]\n";
      for (std::size_t p : ps) {
        const PoseFit& pose = fit_.poses[p];
        d << dat_num(pose.inertia) << " " << dat_num(pose.linear.c_linear) << " "
          << dat_num(pose.linear.beta_tilde_linear) << " " << dat_num(*pose.gamma1_deg) << " "
          << dat_num(*pose.gamma2_deg) << "\n";
      }
      d << "\n\n# index 1: inertia model: I  C = 1/(C0_bar I) (29)  beta_tilde = 1/I (28)\n";
      for (double i : grid) {
        d << dat_num(i) << " " << dat_num(lin.damping(i)) << " " << dat_num(lin.beta_tilde(i))
          << "\n";
      }
      const std::string c0 = common::sig(lin.c0_bar, 4);
      Draft f4{
          "fig04_c_linear_inertia",
          "Fig 4: global linear damping C_linear (eq. 22) per pose against the pose's inertia, "
          "with the inertia model C = 1/(C̄0·I), C̄0 = " +
              c0 + " (eq. 29)",
          d.str(), ""};
      f4.gp =
          preamble(f4.id, f4.caption, 800, 560) + kStyles + xlabel +
          "set ylabel 'C [1/s]'\nset title 'C_{linear} against inertia'\nset key top right\n"
          "plot '" +
          f4.id + ".dat' index 1 using 1:2 with lines ls 2 title 'model 1/(C̄_0 I), C̄_0 = " + c0 +
          "', \\\n     '' index 0 using 1:2 with points ls 1 title 'C_{linear} per pose (22)'\n";
      drafts.push_back(f4);
      Draft f5{
          "fig05_beta_linear_inertia",
          "Fig 5: global linear β̃_linear (eq. 22) per pose against the pose's inertia, with the "
          "inertia model β̃ = 1/I (eq. 28)",
          d.str(), ""};
      f5.gp = preamble(f5.id, f5.caption, 800, 560) + kStyles + xlabel + "set ylabel 'β̃ [" +
              u_.beta_tilde() +
              "]'\nset title 'β̃_{linear} against inertia'\nset key top right\n"
              "plot '" +
              f5.id +
              ".dat' index 1 using 1:3 with lines ls 2 title 'model 1/I', \\\n"
              "     '' index 0 using 1:3 with points ls 1 title 'β̃_{linear} per pose (22)'\n";
      drafts.push_back(f5);
    }

    if (!fit_.alpha.ok) {
      skipped.push_back("Figs 6-7 (α-model against inertia): the α-model was not fitted");
      return;
    }
    // Stage 1 of the α fit has one entry per pose with sine points, in pose order (fit_dataset).
    std::vector<std::size_t> stage1_pose;
    for (std::size_t p = 0; p < fit_.poses.size(); ++p) {
      if (!points_of(p).empty()) stage1_pose.push_back(p);
    }
    if (stage1_pose.size() != fit_.alpha.pose_c.size() ||
        stage1_pose.size() != fit_.alpha.pose_beta_tilde.size()) {
      skipped.push_back(
          "Figs 6-7 (α-model against inertia): the per-pose stage-1 values do not "
          "match the poses");
      return;
    }
    const AlphaModel& a = fit_.alpha.model;
    const std::size_t n = a.n_breakpoints;
    std::ostringstream d;
    d << "# index 0: one row per pose, stage 1 of the alpha fit: I [" << u_.inertia() << "]";
    for (std::size_t k = 0; k < n; ++k) d << "  C_" << k << " [1/s]";
    d << "  beta_tilde_0  beta_tilde_1 [" << u_.beta_tilde() << "]\n";
    for (std::size_t j = 0; j < stage1_pose.size(); ++j) {
      d << dat_num(fit_.poses[stage1_pose[j]].inertia);
      for (std::size_t k = 0; k < n; ++k) d << " " << dat_num(fit_.alpha.pose_c[j][k]);
      d << " " << dat_num(fit_.alpha.pose_beta_tilde[j][0]) << " "
        << dat_num(fit_.alpha.pose_beta_tilde[j][1]) << "\n";
    }
    d << "\n\n# index 1: models: I";
    for (std::size_t k = 0; k < n; ++k) d << "  1/(C_" << k << "1 I)";
    d << "  1/(beta_01 I)  1/(beta_11 I)  C_linear(I)  beta_tilde_linear(I)\n";
    for (double i : grid) {
      d << dat_num(i);
      for (std::size_t k = 0; k < n; ++k) d << " " << dat_num(1.0 / (a.c_n1[k] * i));
      d << " " << dat_num(1.0 / (a.beta_n1[0] * i)) << " " << dat_num(1.0 / (a.beta_n1[1] * i))
        << " " << dat_num(lin.damping(i)) << " " << dat_num(lin.beta_tilde(i)) << "\n";
    }
    const char* colours[] = {"#cc2222", "#e07b00", "#2a9d2a", "#7b3fb5",
                             "#008b8b", "#b5007b", "#666600", "#444444"};
    {
      Draft f{"fig06_c_alpha_inertia",
              "Fig 6: α-model damping C_n = 1/(C_n1·I) at each breakpoint α_n (eq. 40) against "
              "inertia, "
              "with the per-pose stage-1 values and the global linear model for comparison",
              d.str(), ""};
      std::ostringstream g;
      g << preamble(f.id, f.caption, 800, 600) << kStyles << xlabel
        << "set ylabel 'C [1/s]'\nset logscale y\nset title 'α-model damping against inertia'\n"
           "set key outside right top\nplot ";
      for (std::size_t k = 0; k < n; ++k) {
        const std::string c = colours[k % 8];
        g << "'" << f.id << ".dat' index 1 using 1:" << k + 2 << " with lines lc rgb '" << c
          << "' lw 1.5 title 'C_" << k << ", α_" << k << " = " << common::sig(a.alpha[k], 3) << " "
          << u_.alpha() << "', \\\n     '' index 0 using 1:" << k + 2 << " with points lc rgb '"
          << c << "' pt 7 ps 0.8 notitle, \\\n     ";
      }
      g << "'' index 1 using 1:" << n + 4 << " with lines ls 2 title 'linear 1/(C̄_0 I)'\n";
      f.gp = g.str();
      drafts.push_back(f);
    }
    {
      Draft f{"fig07_beta_alpha_inertia",
              "Fig 7: α-model β̃_n = 1/(β̃_n1·I) at ᾱ0 and ᾱ1 (eq. 42) against inertia, with the "
              "per-pose "
              "stage-1 values and the global linear model 1/I for comparison",
              d.str(), ""};
      std::ostringstream g;
      g << preamble(f.id, f.caption, 800, 600) << kStyles << xlabel << "set ylabel 'β̃ ["
        << u_.beta_tilde()
        << "]'\nset title 'α-model β̃ against inertia'\nset key outside right top\nplot ";
      for (std::size_t k = 0; k < 2; ++k) {
        const std::string c = colours[k == 0 ? 0 : 3];
        g << "'" << f.id << ".dat' index 1 using 1:" << n + 2 + k << " with lines lc rgb '" << c
          << "' lw 1.5 title 'β̃_" << k << ", ᾱ_" << k << " = " << common::sig(a.beta_alpha[k], 3)
          << " " << u_.alpha() << "', \\\n     '' index 0 using 1:" << n + 2 + k
          << " with points lc rgb '" << c << "' pt 7 ps 0.8 notitle, \\\n     ";
      }
      g << "'' index 1 using 1:" << n + 5 << " with lines ls 2 title 'linear 1/I'\n";
      f.gp = g.str();
      drafts.push_back(f);
    }
  }

  // --- Fig 8: α_data against frequency, one series per pose
  // ---------------------------------------
  void alpha_frequency() {
    if (fit_.sine_points.empty()) {
      skipped.push_back("Fig 8 (α against frequency): no sine runs");
      return;
    }
    Draft f{
        "fig08_alpha_frequency",
        "Fig 8: α-invariant of the sinusoidal steady state α_data (eq. 36) against frequency, one "
        "series per pose",
        "", ""};
    std::ostringstream d, g;
    g << preamble(f.id, f.caption, 900, 600)
      << "set autoscale xfix\nset offsets graph 0.03, graph 0.03, 0, 0\n"
      << "set xlabel 'frequency [Hz]'\nset ylabel 'α_{data} [" << u_.alpha()
      << "]'\nset logscale y\nset title 'α-invariant against frequency'\n"
      << "set key outside right top\nplot ";
    std::size_t block = 0;
    for (std::size_t p = 0; p < fit_.poses.size(); ++p) {
      const auto pts = points_of(p);
      if (pts.empty()) continue;
      if (block > 0) d << "\n\n";
      d << "# index " << block << ": " << pose_md(fit_.poses[p]) << ": freq [Hz]  alpha_data ["
        << u_.alpha() << "]  physical (1/0)\n";
      for (const auto* sp : pts) {
        d << dat_num(sp->point.freq_hz) << " " << dat_num(sp->point.alpha_data) << " "
          << (sp->point.physical ? 1 : 0) << "\n";
      }
      g << (block > 0 ? ", \\\n     '' " : "'" + f.id + ".dat' ") << "index " << block
        << " using 1:($2 > 0 ? $2 : NaN) with linespoints lc rgb '" << kSeriesColours[block % 10]
        << "' pt " << kSeriesPoints[(block / 10) % 4] << " ps 0.8 title "
        << gp_quote(pose_title(fit_.poses[p]));
      ++block;
    }
    g << "\n";
    f.dat = d.str();
    f.gp = g.str();
    drafts.push_back(f);
  }

  // --- Figs 9-10: C(α) and β̃(α) at each pose, data points, α-model and global linear -----------
  void c_beta_alpha() {
    if (fit_.sine_points.empty()) {
      skipped.push_back("Figs 9-10 (C and β̃ against α): no sine runs");
      return;
    }
    std::vector<std::size_t> ps;
    double a_lo = std::numeric_limits<double>::infinity(), a_hi = 0.0;
    std::size_t excluded = 0;
    for (std::size_t p = 0; p < fit_.poses.size(); ++p) {
      bool any = false;
      for (const auto* sp : points_of(p)) {
        if (!sp->point.physical || !(sp->point.alpha_data > 0.0)) {
          ++excluded;
          continue;
        }
        any = true;
        a_lo = std::min(a_lo, sp->point.alpha_data);
        a_hi = std::max(a_hi, sp->point.alpha_data);
      }
      if (any) ps.push_back(p);
    }
    if (ps.empty()) {
      skipped.push_back("Figs 9-10 (C and β̃ against α): no physical sine points");
      return;
    }
    const double kp = fit_.kp > 0.0 ? fit_.kp : 1.0;
    const std::vector<double> grid = log_grid(a_lo / 3.0, a_hi * 3.0, 120);
    std::ostringstream d;
    std::size_t block = 0;
    for (std::size_t p : ps) {
      const PoseFit& pose = fit_.poses[p];
      if (block > 0) d << "\n\n";
      d << "# index " << block << ": " << pose_md(pose) << ", data (eqs. 19, 20, 36): alpha_data ["
        << u_.alpha() << "]  C_data [1/s]  beta_tilde_data = beta_data/kp [" << u_.beta_tilde()
        << "]  freq [Hz]\n";
      for (const auto* sp : points_of(p)) {
        if (!sp->point.physical || !(sp->point.alpha_data > 0.0)) continue;
        d << dat_num(sp->point.alpha_data) << " " << dat_num(sp->point.c_data) << " "
          << dat_num(sp->point.beta_data / kp) << " " << dat_num(sp->point.freq_hz) << "\n";
      }
      d << "\n\n# index " << block + 1 << ": " << pose_md(pose) << ", I = " << dat_num(pose.inertia)
        << ": alpha  C(alpha, I) (38-40)  beta_tilde(alpha, I) (41-42)  C_linear  "
           "beta_tilde_linear (22)\n";
      for (double a : grid) {
        d << dat_num(a) << " "
          << (fit_.alpha.ok ? dat_num(fit_.alpha.model.damping(a, pose.inertia)) : "NaN") << " "
          << (fit_.alpha.ok ? dat_num(fit_.alpha.model.beta_tilde(a, pose.inertia)) : "NaN") << " "
          << (pose.linear.valid ? dat_num(pose.linear.c_linear) : "NaN") << " "
          << (pose.linear.valid ? dat_num(pose.linear.beta_tilde_linear) : "NaN") << "\n";
      }
      block += 2;
    }
    const auto [cols, rows] = grid_of(ps.size());
    const std::string note = excluded > 0 ? " (" + std::to_string(excluded) +
                                                " non-physical point(s) not shown, as in the fit)"
                                          : "";
    for (int which = 0; which < 2; ++which) {
      const bool c = which == 0;
      Draft f{
          c ? "fig09_c_alpha" : "fig10_beta_alpha",
          c ? "Fig 9: damping C against α per pose: C_data (eq. 19) at each sine frequency, the "
              "α-model C(α, I) (eqs. 38-40) and the global linear C_linear (eq. 22)" +
                  note
            : "Fig 10: β̃ against α per pose: β_data/kp (eq. 20) at each sine frequency, the "
              "α-model β̃(α, I) (eqs. 41-42) and the global linear β̃_linear (eq. 22)" +
                  note,
          d.str(), ""};
      std::ostringstream g;
      g << preamble(f.id, f.caption, 420 * cols, 330 * rows + 40) << kStyles
        << "set logscale x\nset format x '10^{%L}'\nset key top right font ',8' samplen 1.5\n"
        << "set multiplot layout " << rows << "," << cols << " title "
        << gp_quote(c ? "Damping C against α (log scale), per pose"
                      : "β̃ against α (log scale), per pose")
        << "\n";
      for (std::size_t j = 0; j < ps.size(); ++j) {
        const int col = c ? 2 : 3;
        g << "set title " << gp_quote(pose_title(fit_.poses[ps[j]])) << "\n"
          << "set xlabel 'α [" << u_.alpha() << "]'\nset ylabel '"
          << (c ? "C [1/s]" : "β̃ [" + u_.beta_tilde() + "]") << "'\n"
          << "plot '" << f.id << ".dat' index " << 2 * j + 1 << " using 1:" << col + 2
          << " with lines ls 2 title 'linear', \\\n     '' index " << 2 * j + 1
          << " using 1:" << col << " with lines ls 3 title 'α-model', \\\n     '' index " << 2 * j
          << " using 1:" << col << " with points ls 1 title 'data'\n";
      }
      g << "unset multiplot\n";
      f.gp = g.str();
      drafts.push_back(f);
    }
  }

  // --- Figs 11-12: Bode magnitude and phase per pose
  // ----------------------------------------------
  void bode() {
    if (fit_.sine_points.empty()) {
      skipped.push_back("Figs 11-12 (Bode): no sine runs");
      return;
    }
    const bool have_sim = !fit_.validation.empty();
    for (std::size_t p = 0; p < fit_.poses.size(); ++p) {
      const auto pts = points_of(p);
      if (pts.empty()) continue;
      std::vector<double> f_hz, gm, pm, gl, pl, ga, pa;
      for (const auto* sp : pts) {
        f_hz.push_back(sp->point.freq_hz);
        gm.push_back(sp->gain);
        pm.push_back(sp->phase_deg);
        const RunValidation* v =
            have_sim && sp->run < fit_.validation.size() ? &fit_.validation[sp->run] : nullptr;
        auto sim = [&](const RunErrors* e, std::vector<double>& g, std::vector<double>& ph) {
          const bool ok = v && e->simulated && e->fundamental.valid;
          g.push_back(ok ? e->fundamental.gain_simulated : kNaN);
          ph.push_back(ok ? e->fundamental.phase_simulated_deg : kNaN);
        };
        sim(v ? &v->linear : nullptr, gl, pl);
        sim(v ? &v->alpha : nullptr, ga, pa);
      }
      unwrap_deg(pm);
      unwrap_deg(pl);
      unwrap_deg(pa);
      const PoseFit& pose = fit_.poses[p];
      Draft f{
          "fig11_bode_pose" + std::to_string(p + 1),
          "Figs 11-12, pose " + std::to_string(p + 1) + " (" + pose_md(pose) +
              "): fundamental gain |θ/r| and phase of θ relative to r against frequency, measured "
              "vs the linear and the α-model simulated under the run's controller",
          "", ""};
      std::ostringstream d;
      d << "# " << pose_md(pose)
        << ": freq [Hz]  gain_measured [1]  phase_measured [deg]  "
           "gain_linear  phase_linear [deg]  gain_alpha  phase_alpha [deg]  (phases unwrapped "
           "along "
           "frequency; NaN: not simulated)\n";
      for (std::size_t k = 0; k < f_hz.size(); ++k) {
        d << dat_num(f_hz[k]) << " " << dat_num(gm[k]) << " " << dat_num(pm[k]) << " "
          << dat_num(gl[k]) << " " << dat_num(pl[k]) << " " << dat_num(ga[k]) << " "
          << dat_num(pa[k]) << "\n";
      }
      f.dat = d.str();
      std::ostringstream g;
      g << preamble(f.id, f.caption, 800, 820) << kStyles << "set multiplot layout 2,1 title "
        << gp_quote("Fundamental response, " + pose_title(pose)) << "\n"
        << "set key top right\nset xlabel 'frequency [Hz]'\n"
        << "set autoscale xfix\nset offsets graph 0.03, graph 0.03, graph 0.05, 0\n"
        << "set title 'magnitude (Fig 11)'\nset ylabel '|θ/r| [" << u_.pos << "/" << u_.pos
        << "]'\nset yrange [0:*]  # a gain: no offset below 0\n"
        << "plot '" << f.id << ".dat' using 1:4 with linespoints ls 2 title 'linear model', \\\n"
        << "     '' using 1:6 with linespoints ls 3 title 'α-model', \\\n"
        << "     '' using 1:2 with points ls 1 title 'measured'\n"
        << "set autoscale y\nset offsets graph 0.03, graph 0.03, graph 0.05, graph 0.05\n"
        << "set title 'phase (Fig 12)'\nset ylabel 'phase of θ relative to r [deg]'\nset key "
           "bottom left\n"
        << "plot '" << f.id << ".dat' using 1:5 with linespoints ls 2 title 'linear model', \\\n"
        << "     '' using 1:7 with linespoints ls 3 title 'α-model', \\\n"
        << "     '' using 1:3 with points ls 1 title 'measured'\n"
        << "unset multiplot\n";
      f.gp = g.str();
      drafts.push_back(f);
    }
    if (!have_sim)
      skipped.push_back("Figs 11-12: the fit ran without validation; only measured points");
  }

  // --- Figs 13-14: time-domain overlays of one sine and one square/step run ----------------------
  /// Re-simulates run i with both models as fit_dataset()'s validation does. False when the pose
  /// has no linear model or the linear simulation fails.
  bool simulate_run(std::size_t i, std::vector<double>& lin, std::vector<double>& alp,
                    std::string& why) const {
    const RunData& d = data_[i];
    const auto it = run_pose_.find(i);
    if (it == run_pose_.end() || d.t.empty()) {
      why = "run has no pose or no samples";
      return false;
    }
    JointModelAtPose m = fit_.model_for_pose(it->second);
    if (!(m.c_linear > 0.0) || !(m.beta_tilde_linear > 0.0)) {
      why = "no linear model at this run's pose";
      return false;
    }
    const Controller ctl = ds_.runs[i].controller;
    const InitialState x0 = initial_state_of(d);  // as the validation does
    m.use_alpha = false;
    const SimulationResult l = simulate_recorded_run(m, ctl, d, x0, fit_.simulation);
    if (!l.ok) {
      why = "linear simulation failed: " + l.message;
      return false;
    }
    lin = l.theta;
    alp.assign(d.size(), kNaN);
    if (fit_.alpha.ok) {
      m.use_alpha = true;
      const SimulationResult a = simulate_recorded_run(m, ctl, d, x0, fit_.simulation);
      if (a.ok) alp = a.theta;
    }
    return true;
  }

  Draft time_draft(std::size_t i, std::size_t k0, std::size_t k1, const std::vector<double>& lin,
                   const std::vector<double>& alp, std::string id, std::string caption) const {
    const RunData& d = data_[i];
    Draft f{std::move(id), std::move(caption), "", ""};
    std::ostringstream s;
    s << "# " << ds_.runs[i].file << ": t [s]  r [" << u_.pos << "]  theta_measured  theta_linear  "
      << "theta_alpha [" << u_.pos << "]\n";
    for (std::size_t k = k0; k < k1; ++k) {
      s << dat_num(d.t[k]) << " " << dat_num(d.r[k]) << " " << dat_num(d.theta[k]) << " "
        << dat_num(lin[k]) << " " << dat_num(alp[k]) << "\n";
    }
    f.dat = s.str();
    std::ostringstream g;
    g << preamble(f.id, f.caption, 900, 560) << kStyles << "set title "
      << gp_quote(ds_.runs[i].file + " (" + pose_md(fit_.poses[run_pose_.at(i)]) + ")")
      << " noenhanced\n"
      << "set xlabel 'time [s]'\nset ylabel 'θ [" << u_.pos << "]'\nset key outside right top\n"
      << "set autoscale xfix\nset offsets 0, 0, graph 0.05, graph 0.05\n"
      << "plot '" << f.id << ".dat' using 1:2 with lines ls 4 title 'reference r', \\\n"
      << "     '' using 1:3 with lines lc rgb 'black' lw 2 title 'measured', \\\n"
      << "     '' using 1:4 with lines ls 2 title 'linear model', \\\n"
      << "     '' using 1:5 with lines ls 3 title 'α-model'\n";
    f.gp = g.str();
    return f;
  }

  void time_overlays() {
    // The pose: most sine points among those with a linear model, preferring one with a step run.
    std::size_t best = fit_.poses.size();
    auto score = [&](std::size_t p) {
      std::size_t s = points_of(p).size() * 2;
      for (std::size_t i : fit_.poses[p].runs) s += is_step(ds_.runs[i]) ? 1000 : 0;
      return fit_.model_for_pose(p).c_linear > 0.0 ? s : 0;
    };
    for (std::size_t p = 0; p < fit_.poses.size(); ++p) {
      if (score(p) > 0 && (best == fit_.poses.size() || score(p) > score(best))) best = p;
    }
    // Fig 13: the sine run nearest 0.75 f_res (the paper shows 2.5 Hz at a 3.4 Hz resonance).
    const SineRunPoint* sine = nullptr;
    if (best < fit_.poses.size()) {
      const auto pts = points_of(best);
      double f_res = 0.0, g_max = -1.0;
      for (const auto* sp : pts) {
        if (sp->gain > g_max) g_max = sp->gain, f_res = sp->point.freq_hz;
      }
      for (const auto* sp : pts) {
        if (!sine || std::abs(sp->point.freq_hz - 0.75 * f_res) <
                         std::abs(sine->point.freq_hz - 0.75 * f_res)) {
          sine = sp;
        }
      }
    }
    std::vector<double> lin, alp;
    std::string why;
    if (!sine) {
      skipped.push_back("Fig 13 (time response to a sine): no sine run with a fitted linear model");
    } else if (!simulate_run(sine->run, lin, alp, why)) {
      skipped.push_back("Fig 13 (time response to a sine): " + ds_.runs[sine->run].file + ": " +
                        why);
    } else {
      const RunData& d = data_[sine->run];
      const double t0 = d.t.back() - 3.0 / sine->point.freq_hz;  // the last three periods
      const std::size_t k0 =
          static_cast<std::size_t>(std::lower_bound(d.t.begin(), d.t.end(), t0) - d.t.begin());
      drafts.push_back(time_draft(
          sine->run, k0, d.size(), lin, alp, "fig13_time_sine",
          "Fig 13: the last three periods of " + ds_.runs[sine->run].file + " (" +
              common::sig(sine->point.freq_hz, 3) + " Hz, " + pose_md(fit_.poses[sine->pose]) +
              "), measured θ vs the linear and the α-model simulated from the run's start"));
    }
    // Fig 14: a square/step run at that pose (else the first one with a model), around its first
    // upward jump (the paper shows the first second after the negative-to-positive transition).
    std::size_t step = ds_.runs.size();
    for (int pass = 0; pass < 2 && step == ds_.runs.size(); ++pass) {
      for (std::size_t i = 0; i < ds_.runs.size() && step == ds_.runs.size(); ++i) {
        if (!is_step(ds_.runs[i]) || data_[i].size() < 2) continue;
        const auto it = run_pose_.find(i);
        if (it == run_pose_.end() || !(fit_.model_for_pose(it->second).c_linear > 0.0)) continue;
        if (pass == 0 && it->second != best) continue;
        step = i;
      }
    }
    if (step == ds_.runs.size()) {
      skipped.push_back(
          "Fig 14 (step response): no square or step run at a pose with a fitted model");
      return;
    }
    if (!simulate_run(step, lin, alp, why)) {
      skipped.push_back("Fig 14 (step response): " + ds_.runs[step].file + ": " + why);
      return;
    }
    const RunData& d = data_[step];
    const auto [r_lo, r_hi] = std::minmax_element(d.r.begin(), d.r.end());
    const double jump = 0.5 * (*r_hi - *r_lo);
    std::size_t edge = 0;
    for (std::size_t k = 1; k < d.size() && edge == 0; ++k) {
      if (d.r[k] - d.r[k - 1] > jump && jump > 0.0) edge = k;
    }
    for (std::size_t k = 1; k < d.size() && edge == 0; ++k) {
      if (std::abs(d.r[k] - d.r[k - 1]) > jump && jump > 0.0) edge = k;
    }
    const double t_edge = d.t[edge];
    const double t_lo = edge > 0 ? t_edge - 0.1 : d.t.front(), t_hi = t_lo + 1.1;
    const std::size_t k0 =
        static_cast<std::size_t>(std::lower_bound(d.t.begin(), d.t.end(), t_lo) - d.t.begin());
    const std::size_t k1 =
        static_cast<std::size_t>(std::upper_bound(d.t.begin(), d.t.end(), t_hi) - d.t.begin());
    drafts.push_back(time_draft(
        step, k0, k1, lin, alp, "fig14_time_step",
        "Fig 14: " + ds_.runs[step].file + " (" + pose_md(fit_.poses[run_pose_.at(step)]) +
            ") around its " +
            (edge > 0 ? "first jump of the reference, at t = " + common::sig(t_edge, 3) + " s"
                      : "start") +
            ": measured θ vs the linear and the α-model simulated from the run's start"));
  }
};

/// Looks `program` up as execvp would: a name with a '/' as is, else along PATH.
bool on_path(const std::string& program) {
  if (program.find('/') != std::string::npos) return access(program.c_str(), X_OK) == 0;
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "/usr/bin:/bin";
  std::size_t start = 0;
  while (start <= dirs.size()) {
    const std::size_t end = std::min(dirs.find(':', start), dirs.size());
    const std::string dir = end > start ? dirs.substr(start, end - start) : ".";
    if (access((dir + "/" + program).c_str(), X_OK) == 0) return true;
    start = end + 1;
  }
  return false;
}

bool has_png_signature(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  char sig[8] = {};
  in.read(sig, 8);
  return in.gcount() == 8 && std::memcmp(sig, "\x89PNG\r\n\x1a\n", 8) == 0;
}

std::string read_tail(const fs::path& file, std::size_t max_chars) {
  std::ifstream in(file, std::ios::binary);
  std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (s.size() > max_chars) s = "…" + s.substr(s.size() - max_chars);
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

/// Runs `gnuplot -e "cd '<dir>'; outfile='<id>.png.part'" <dir>/<id>.gp` with stderr to
/// <id>.log; renames the PNG into place when gnuplot exits 0 and wrote a PNG. Returns "" or why
/// not.
std::string draw(const std::string& gnuplot, const fs::path& dir_given, const std::string& id) {
  // Absolute: the script is named after gnuplot has changed into `dir` (a relative OUTDIR such as
  // out/fit would otherwise be looked up from inside itself).
  const fs::path dir = fs::absolute(dir_given);
  const fs::path png = dir / (id + ".png"), part = dir / (id + ".png.part"),
                 log = dir / (id + ".log");
  std::error_code ec;
  fs::remove(png, ec);  // never leave an old figure that looks like this fit's
  fs::remove(part, ec);
  const std::string setup =
      "cd " + gp_quote(dir.string()) + "; outfile = " + gp_quote(id + ".png.part");
  const std::string script = (dir / (id + ".gp")).string();
  std::vector<std::string> args = {gnuplot, "-e", setup, script};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  const std::string log_s = log.string();
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, log_s.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, gnuplot.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return "cannot run " + gnuplot + ": " + std::strerror(rc);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  std::string why;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    why = gnuplot + " failed on " + id + ".gp (" +
          (WIFEXITED(status) ? "exit " + std::to_string(WEXITSTATUS(status))
                             : std::string("killed")) +
          "): " + read_tail(log, 400);
  } else if (!has_png_signature(part)) {
    why = gnuplot + " wrote no PNG for " + id + ".gp: " + read_tail(log, 400);
  } else {
    try {
      common::commit_file(part, png);
    } catch (const Error& e) {
      why = e.what();
    }
  }
  if (!why.empty()) {
    fs::remove(part, ec);
  } else if (fs::file_size(log, ec) == 0) {
    fs::remove(log, ec);  // keep the log only when gnuplot had something to say
  }
  return why;
}

}  // namespace

void write_text_atomic(const std::filesystem::path& path, const std::string& text) {
  common::write_file_atomically(path, text);
}

std::string gnuplot_preamble(const std::string& id, const std::string& caption, int width,
                             int height) {
  return preamble(id, caption, width, height);
}

std::string gnuplot_quote(std::string_view s) { return gp_quote(s); }

bool program_on_path(const std::string& program) { return on_path(program); }

std::string draw_gnuplot_figure(const std::string& gnuplot, const std::filesystem::path& dir,
                                const std::string& id) {
  return draw(gnuplot, dir, id);
}

PlotSummary write_plots(const Dataset& dataset, const std::vector<RunData>& data,
                        const DatasetFit& fit, const PlotOptions& options) {
  Plotter plotter(dataset, data, fit);
  plotter.make_all();
  PlotSummary summary;
  summary.skipped = plotter.skipped;
  const fs::path dir = options.out_dir / "plots";
  std::error_code ec;
  // Files of figures an earlier fit into this folder made and this one does not: removed, so the
  // folder never shows a figure of other data.
  std::set<std::string> ids;
  for (const Draft& d : plotter.drafts) ids.insert(d.id);
  std::vector<fs::path> stale;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("fig", 0) == 0 && ids.count(name.substr(0, name.find('.'))) == 0) {
      stale.push_back(e.path());
    }
  }
  for (const auto& f : stale) fs::remove(f, ec);
  if (plotter.drafts.empty()) return summary;
  fs::create_directories(dir, ec);
  if (ec) throw Error("cannot create the plots folder: " + ec.message(), dir.string());
  for (const Draft& d : plotter.drafts) {
    write_text_atomic(dir / (d.id + ".dat"), d.dat);
    write_text_atomic(dir / (d.id + ".gp"), d.gp);
    summary.figures.push_back(Figure{d.id, d.caption, false, ""});
  }
  const std::size_t n = summary.figures.size();
  if (!options.run_gnuplot) {
    summary.gnuplot_problem = "drawing was not asked for";
    return summary;
  }
  if (!on_path(options.gnuplot)) {
    summary.gnuplot_problem =
        "`" + options.gnuplot + "` was not found on PATH (Debian: apt-get install gnuplot-nox)";
    return summary;
  }
  std::size_t drawn = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (options.progress) options.progress("plots", k, n);
    Figure& f = summary.figures[k];
    f.error = draw(options.gnuplot, dir, f.id);
    f.drawn = f.error.empty();
    drawn += f.drawn ? 1 : 0;
  }
  if (options.progress) options.progress("plots", n, n);
  if (drawn == 0)
    summary.gnuplot_problem = "gnuplot failed on every figure; first: " + summary.figures[0].error;
  return summary;
}

std::string PlotSummary::markdown() const {
  std::ostringstream r;
  r << "\n## Figures\n\n";
  if (!gnuplot_problem.empty()) {
    r << "Plots were skipped: " << gnuplot_problem << ". The plot data (`plots/*.dat`) and gnuplot "
      << "scripts (`plots/*.gp`) are written; draw them later with `cd plots && gnuplot "
         "<name>.gp`.\n\n";
  }
  for (const Figure& f : figures) {
    if (f.drawn) {
      r << "![" << f.id << "](plots/" << f.id << ".png)\n\n*" << f.caption << ".*\n\n";
    } else if (gnuplot_problem.empty()) {
      r << "- " << f.caption << ": **not drawn**: " << f.error << "\n";
    } else {
      r << "- " << f.caption << " (`plots/" << f.id << ".gp`)\n";
    }
  }
  if (figures.empty()) r << "This dataset supports none of the figures.\n";
  if (!skipped.empty()) {
    r << "\nFigures the data cannot support:\n\n";
    for (const auto& s : skipped) r << "- " << s << "\n";
  }
  return r.str();
}

std::string plots_skipped_markdown(std::string_view why) {
  return "\n## Figures\n\nPlots were skipped: " + std::string(why) + ".\n";
}

std::string draw_report_figures(const Dataset& dataset, const std::vector<RunData>& data,
                                const DatasetFit& fit, const PlotOptions& options,
                                std::string& warning) {
  warning.clear();
  try {
    const PlotSummary s = write_plots(dataset, data, fit, options);
    if (!s.gnuplot_problem.empty()) warning = "plots skipped: " + s.gnuplot_problem;
    return s.markdown();
  } catch (const std::exception& e) {
    warning = std::string("plots skipped: ") + e.what();
    return plots_skipped_markdown(e.what());
  }
}

}  // namespace omni_fit
