// Tests of omni_fit's report figures (apps/omni_fit/plots.hpp): the .dat files carry the fit's
// numbers, figures the data cannot support are skipped with a reason, a missing or failing gnuplot
// leaves data and scripts but no PNG, and with gnuplot every PNG is complete.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "alphainv/identify/fit_pipeline.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "alphainv/simulate/reference.hpp"
#include "plots.hpp"
#include "support/model_dataset.hpp"
#include "support/plot_files.hpp"

namespace omni_fit {
namespace {

using namespace alphainv;
namespace fs = std::filesystem;

/// Runs made by the paper's α-model itself at `poses`: sines at `freqs` and, with `square`, one
/// 0.25 Hz square run per pose (as tests/test_fit_pipeline.cpp, shorter runs).
void make_dataset(const std::vector<std::pair<double, double>>& poses,
                  const std::vector<double>& freqs, bool square, Dataset& ds,
                  std::vector<RunData>& data) {
  ds.position_unit = "rad";
  ds.command_unit = "V";
  test::ModelDatasetPlan plan;
  plan.poses_deg = poses;
  plan.freqs_hz = freqs;
  plan.square = square;
  plan.duration_s = 6.0;
  plan.file_prefix = "runs/";
  plan.separator = "_";
  test::append_model_runs(plan, ds, data);
}




bool has(const std::vector<std::string>& v, const std::string& text) {
  for (const auto& s : v) {
    if (s.find(text) != std::string::npos) return true;
  }
  return false;
}

const Figure* find(const PlotSummary& s, const std::string& id) {
  for (const auto& f : s.figures) {
    if (f.id == id) return &f;
  }
  return nullptr;
}

/// Six poses (enough for the inertia model), a five-frequency sweep and a square run each;
/// fitted once for the suite.
class PlotsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    make_dataset({{21.54, 69.54},
                  {19.31, 112.44},
                  {40.68, 68.52},
                  {39.83, 87.63},
                  {60.08, 87.00},
                  {59.56, 111.45}},
                 {1.5, 2.5, 3.5, 5.0, 7.0}, true, ds_, data_);
    fit_ = fit_dataset(ds_, data_);
  }
  static Dataset ds_;
  static std::vector<RunData> data_;
  static DatasetFit fit_;
};
Dataset PlotsTest::ds_;
std::vector<RunData> PlotsTest::data_;
DatasetFit PlotsTest::fit_;

TEST_F(PlotsTest, DataFilesCarryTheFitsNumbers) {
  ASSERT_TRUE(fit_.has_inertia_model);
  ASSERT_TRUE(fit_.alpha.ok);
  PlotOptions opt;
  const test::ScopedTempDir tmp("plots", "data");
  opt.out_dir = tmp.path;
  opt.run_gnuplot = false;
  const PlotSummary s = write_plots(ds_, data_, fit_, opt);
  EXPECT_EQ(s.gnuplot_problem, "drawing was not asked for");
  for (const char* id :
       {"fig04_c_linear_inertia", "fig05_beta_linear_inertia", "fig06_c_alpha_inertia",
        "fig07_beta_alpha_inertia", "fig08_alpha_frequency", "fig09_c_alpha", "fig10_beta_alpha",
        "fig11_bode_pose1", "fig11_bode_pose6", "fig13_time_sine", "fig14_time_step"}) {
    EXPECT_NE(find(s, id), nullptr) << id;
    EXPECT_TRUE(fs::exists(opt.out_dir / "plots" / (std::string(id) + ".gp"))) << id;
  }
  EXPECT_TRUE(s.skipped.empty()) << s.skipped.front();
  const fs::path dir = opt.out_dir / "plots";

  // Bode of pose 2: one row per sine run, by frequency: measured gain/phase of the local fit, the
  // simulated fundamentals of the validation.
  const auto bode = test::read_dat_block(dir / "fig11_bode_pose2.dat", 0);
  std::vector<const SineRunPoint*> pts;
  for (const auto& sp : fit_.sine_points) {
    if (sp.pose == 1) pts.push_back(&sp);
  }
  ASSERT_EQ(bode.size(), 5u);
  ASSERT_EQ(pts.size(), 5u);
  for (std::size_t k = 0; k < 5; ++k) {
    const SineRunPoint& sp = *pts[k];
    const RunValidation& v = fit_.validation[sp.run];
    ASSERT_EQ(bode[k].size(), 7u);
    EXPECT_NEAR(bode[k][0], sp.point.freq_hz, 1e-9);
    EXPECT_NEAR(bode[k][1], sp.gain, 1e-9 * sp.gain);
    EXPECT_NEAR(std::remainder(bode[k][2] - sp.phase_deg, 360.0), 0.0, 1e-7);
    EXPECT_NEAR(bode[k][3], v.linear.fundamental.gain_simulated, 1e-9);
    EXPECT_NEAR(std::remainder(bode[k][4] - v.linear.fundamental.phase_simulated_deg, 360.0), 0.0,
                1e-7);
    EXPECT_NEAR(bode[k][5], v.alpha.fundamental.gain_simulated, 1e-9);
    EXPECT_NEAR(std::remainder(bode[k][6] - v.alpha.fundamental.phase_simulated_deg, 360.0), 0.0,
                1e-7);
    // Phases are unwrapped: a lagging plant, 0 … −180° through resonance.
    EXPECT_LT(bode[k][2], 5.0);
    EXPECT_GT(bode[k][2], -185.0);
  }

  // Fig 9 of pose 1: data points are C_data, β_data/kp; the curve is the α-model at the pose's I.
  const auto c_points = test::read_dat_block(dir / "fig09_c_alpha.dat", 0);
  const auto c_curve = test::read_dat_block(dir / "fig09_c_alpha.dat", 1);
  std::size_t physical = 0;
  for (const auto& sp : fit_.sine_points) physical += sp.pose == 0 && sp.point.physical ? 1 : 0;
  ASSERT_EQ(c_points.size(), physical);
  for (const auto& row : c_points) {
    const SineRunPoint* match = nullptr;
    for (const auto& sp : fit_.sine_points) {
      if (sp.pose == 0 && std::abs(sp.point.freq_hz - row[3]) < 1e-9) match = &sp;
    }
    ASSERT_NE(match, nullptr);
    EXPECT_NEAR(row[0], match->point.alpha_data, 1e-9 * match->point.alpha_data);
    EXPECT_NEAR(row[1], match->point.c_data, 1e-9 * match->point.c_data);
    EXPECT_NEAR(row[2], match->point.beta_data / fit_.kp, 1e-9 * match->point.beta_data);
  }
  ASSERT_EQ(c_curve.size(), 120u);
  const double inertia = fit_.poses[0].inertia;
  for (const auto& row : c_curve) {
    EXPECT_NEAR(row[1], fit_.alpha.model.damping(row[0], inertia), 1e-9 * row[1]);
    EXPECT_NEAR(row[2], fit_.alpha.model.beta_tilde(row[0], inertia), 1e-9 * row[2]);
    EXPECT_NEAR(row[3], fit_.poses[0].linear.c_linear, 1e-9 * row[3]);
  }
  // The breakpoint search spans the data: the curve covers every data α.
  EXPECT_LT(c_curve.front()[0], c_points.front()[0]);

  // Fig 4: one row per pose: I and C_linear; the model curve is 1/(C̄0 I).
  const auto lin_points = test::read_dat_block(dir / "fig04_c_linear_inertia.dat", 0);
  const auto lin_curve = test::read_dat_block(dir / "fig04_c_linear_inertia.dat", 1);
  ASSERT_EQ(lin_points.size(), 6u);
  for (std::size_t p = 0; p < 6; ++p) {
    EXPECT_NEAR(lin_points[p][0], fit_.poses[p].inertia, 1e-9 * fit_.poses[p].inertia);
    EXPECT_NEAR(lin_points[p][1], fit_.poses[p].linear.c_linear, 1e-9 * lin_points[p][1]);
    EXPECT_NEAR(lin_points[p][3], *fit_.poses[p].gamma1_deg, 1e-9);
  }
  for (const auto& row : lin_curve) {
    EXPECT_NEAR(row[1], 1.0 / (fit_.inertia.model.c0_bar * row[0]), 1e-9 * row[1]);
    EXPECT_NEAR(row[2], 1.0 / row[0], 1e-9 * row[2]);
  }

  // Fig 14: from 0.1 s before the square wave's first upward jump (t = 4 s: it starts at +Ar and
  // falls at 2 s) to 1 s after; measured θ and r are the run's samples; the α-model (of the kind
  // that made the data) follows the measurement more closely than the linear model.
  const auto step = test::read_dat_block(dir / "fig14_time_step.dat", 0);
  ASSERT_EQ(step.size(), 1101u);
  EXPECT_NEAR(step.front()[0], 3.9, 1e-9);
  EXPECT_NEAR(step.back()[0], 5.0, 1e-9);
  std::size_t sq = 0;
  while (ds_.runs[sq].kind != "square") ++sq;
  double ss_alpha = 0.0, ss_linear = 0.0;
  for (const auto& row : step) {
    const auto k = static_cast<std::size_t>(std::lround(row[0] * 1e3));
    EXPECT_NEAR(row[1], data_[sq].r[k], 1e-10);  // %.10g in the file
    EXPECT_NEAR(row[2], data_[sq].theta[k], 1e-10);
    ss_alpha += std::pow(row[4] - row[2], 2);
    ss_linear += std::pow(row[3] - row[2], 2);
  }
  EXPECT_LT(std::sqrt(ss_alpha / 1101), 0.5 * std::sqrt(ss_linear / 1101));
}

TEST_F(PlotsTest, GnuplotMissingLeavesDataAndScripts) {
  PlotOptions opt;
  const test::ScopedTempDir tmp("plots", "missing");
  opt.out_dir = tmp.path;
  const char* old_path = std::getenv("PATH");
  const std::string saved = old_path ? old_path : "";
  ::setenv("PATH", (opt.out_dir / "empty-bin").c_str(), 1);  // a PATH without gnuplot
  const PlotSummary s = write_plots(ds_, data_, fit_, opt);
  ::setenv("PATH", saved.c_str(), 1);
  EXPECT_NE(s.gnuplot_problem.find("not found on PATH"), std::string::npos) << s.gnuplot_problem;
  ASSERT_FALSE(s.figures.empty());
  for (const auto& f : s.figures) {
    EXPECT_FALSE(f.drawn);
    EXPECT_TRUE(fs::exists(opt.out_dir / "plots" / (f.id + ".dat")));
    EXPECT_TRUE(fs::exists(opt.out_dir / "plots" / (f.id + ".gp")));
    EXPECT_FALSE(fs::exists(opt.out_dir / "plots" / (f.id + ".png")));
  }
  const std::string md = s.markdown();
  EXPECT_NE(md.find("Plots were skipped"), std::string::npos);
  EXPECT_EQ(md.find("!["), std::string::npos);  // no image links to files that do not exist
}

TEST_F(PlotsTest, GnuplotFailingLeavesNoPng) {
  PlotOptions opt;
  const test::ScopedTempDir tmp("plots", "failing");
  opt.out_dir = tmp.path;
  opt.gnuplot = "false";  // runs, exits 1, writes nothing
  const PlotSummary s = write_plots(ds_, data_, fit_, opt);
  EXPECT_NE(s.gnuplot_problem.find("failed on every figure"), std::string::npos)
      << s.gnuplot_problem;
  for (const auto& e : fs::directory_iterator(opt.out_dir / "plots")) {
    const std::string ext = e.path().extension().string();
    EXPECT_TRUE(ext == ".dat" || ext == ".gp" || ext == ".log") << e.path();
  }
  std::string warning;
  const std::string md = draw_report_figures(ds_, data_, fit_, opt, warning);
  EXPECT_NE(warning.find("plots skipped"), std::string::npos);
  EXPECT_NE(md.find("Plots were skipped"), std::string::npos);
}

TEST_F(PlotsTest, GnuplotDrawsCompletePngs) {
  if (!test::gnuplot_installed()) GTEST_SKIP() << "gnuplot is not installed (Debian: gnuplot-nox)";
  PlotOptions opt;
  const test::ScopedTempDir tmp("plots", "draw");
  opt.out_dir = tmp.path;
  fs::create_directories(opt.out_dir / "plots");
  std::ofstream(opt.out_dir / "plots" / "fig13_time_sine.png") << "stale";  // from an older fit
  std::size_t calls = 0, last_done = 0;
  opt.progress = [&](std::string_view stage, std::size_t done, std::size_t) {
    EXPECT_EQ(stage, "plots");
    ++calls;
    last_done = done;
  };
  const PlotSummary s = write_plots(ds_, data_, fit_, opt);
  EXPECT_TRUE(s.gnuplot_problem.empty()) << s.gnuplot_problem;
  EXPECT_EQ(calls, s.figures.size() + 1);
  EXPECT_EQ(last_done, s.figures.size());
  for (const auto& f : s.figures) {
    EXPECT_TRUE(f.drawn) << f.id << ": " << f.error;
    const fs::path png = opt.out_dir / "plots" / (f.id + ".png");
    std::ifstream in(png, std::ios::binary);
    char sig[8] = {};
    in.read(sig, 8);
    EXPECT_EQ(std::string(sig, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << png;
    EXPECT_GT(fs::file_size(png), 5000u) << png;
    EXPECT_FALSE(fs::exists(opt.out_dir / "plots" / (f.id + ".png.part")));
  }
  const std::string md = s.markdown();
  EXPECT_NE(md.find("![fig11_bode_pose1](plots/fig11_bode_pose1.png)"), std::string::npos);
}

TEST_F(PlotsTest, RelativeOutputFolderDraws) {
  // `omni_fit fit DATASET -o out/fit`: gnuplot changes into the plots folder before it reads the
  // script, so the script's path must not be relative to the caller's folder.
  if (!test::gnuplot_installed()) GTEST_SKIP() << "gnuplot is not installed (Debian: gnuplot-nox)";
  const test::ScopedTempDir tmp("plots", "relative");
  const fs::path old_cwd = fs::current_path();
  fs::current_path(tmp.path);
  PlotOptions opt;
  opt.out_dir = fs::path("out") / "fit";
  const PlotSummary s = write_plots(ds_, data_, fit_, opt);
  fs::current_path(old_cwd);
  EXPECT_TRUE(s.gnuplot_problem.empty()) << s.gnuplot_problem;
  ASSERT_FALSE(s.figures.empty());
  for (const auto& f : s.figures) {
    EXPECT_TRUE(f.drawn) << f.id << ": " << f.error;
    EXPECT_TRUE(fs::exists(tmp.path / "out" / "fit" / "plots" / (f.id + ".png"))) << f.id;
  }
}

TEST(Plots, FiguresWithoutDataAreSkippedWithAReason) {
  // Square runs only and no time-domain fit: no sine points, so no linear model and nothing to
  // plot.
  Dataset ds;
  std::vector<RunData> data;
  make_dataset({{60.08, 87.00}}, {}, true, ds, data);
  FitPipelineOptions no_time_domain;
  no_time_domain.time_domain = false;
  const DatasetFit fit = fit_dataset(ds, data, no_time_domain);
  PlotOptions opt;
  const test::ScopedTempDir tmp("plots", "no_sine");
  opt.out_dir = tmp.path;
  opt.run_gnuplot = false;
  fs::create_directories(opt.out_dir / "plots");
  std::ofstream(opt.out_dir / "plots" / "fig11_bode_pose3.png") << "an older fit's figure";
  const PlotSummary s = write_plots(ds, data, fit, opt);
  EXPECT_TRUE(s.figures.empty());
  EXPECT_FALSE(fs::exists(opt.out_dir / "plots" / "fig11_bode_pose3.png"));
  EXPECT_TRUE(has(s.skipped, "Fig 8 (α against frequency): no sine runs"));
  EXPECT_TRUE(has(s.skipped, "Figs 11-12 (Bode): no sine runs"));
  EXPECT_TRUE(has(s.skipped, "Figs 4-7"));
  EXPECT_TRUE(has(s.skipped,
                  "Fig 14 (step response): no square or step run at a pose with a fitted model"));
  EXPECT_NE(s.markdown().find("Figures the data cannot support"), std::string::npos);

  // Sines only at one pose: Bode, α figures and the sine overlay; no step figure, no inertia.
  Dataset ds2;
  std::vector<RunData> data2;
  make_dataset({{60.08, 87.00}}, {2.0, 3.0, 3.5, 4.0, 6.0}, false, ds2, data2);
  const DatasetFit fit2 = fit_dataset(ds2, data2);
  const PlotSummary s2 = write_plots(ds2, data2, fit2, opt);
  EXPECT_NE(find(s2, "fig11_bode_pose1"), nullptr);
  EXPECT_NE(find(s2, "fig09_c_alpha"), nullptr);
  EXPECT_NE(find(s2, "fig13_time_sine"), nullptr);
  EXPECT_EQ(find(s2, "fig14_time_step"), nullptr);
  EXPECT_EQ(find(s2, "fig04_c_linear_inertia"), nullptr);
  EXPECT_TRUE(has(s2.skipped, "no inertia model"));
  // Fig 13 shows the last three periods of the run nearest 0.75 f_res (f_res: largest gain).
  double f_res = 0.0, g_max = 0.0;
  for (const auto& sp : fit2.sine_points) {
    if (sp.gain > g_max) g_max = sp.gain, f_res = sp.point.freq_hz;
  }
  double f_shown = 0.0;
  for (double f : {2.0, 3.0, 3.5, 4.0, 6.0}) {
    if (std::abs(f - 0.75 * f_res) < std::abs(f_shown - 0.75 * f_res)) f_shown = f;
  }
  const auto sine = test::read_dat_block(opt.out_dir / "plots" / "fig13_time_sine.dat", 0);
  ASSERT_FALSE(sine.empty());
  EXPECT_NEAR(sine.back()[0], 6.0, 1e-9);
  EXPECT_NEAR(sine.back()[0] - sine.front()[0], 3.0 / f_shown, 2e-3);
  for (const auto& row : sine)
    EXPECT_NEAR(row[1], 0.07 * std::sin(2 * kPi * f_shown * row[0]), 1e-9);
}

}  // namespace
}  // namespace omni_fit
