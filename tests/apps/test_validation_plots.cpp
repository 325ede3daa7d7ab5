// Tests of omni_fit's validation figures (apps/omni_fit/validation_plots.hpp): the .dat files carry
// the validation's own numbers (θ, θ_sim, the residual, ρ_e and ρ_eu with their bands), the runs
// shown are the ones with the lowest fit %, the report section links every PNG, and without
// gnuplot the data and scripts stay and the section says why there is no figure.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "alphainv/data/model_file.hpp"
#include "alphainv/identify/validation.hpp"
#include "support/model_dataset.hpp"
#include "support/plot_files.hpp"
#include "validation_plots.hpp"

namespace omni_fit {
namespace {

using namespace alphainv;
namespace fs = std::filesystem;




/// Four runs of the paper's α-model at one pose (three sines, one square), validated with the
/// paper's linear model (not the α-model that made them: the fit % differ between runs).
class ValidationPlotsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    ds_.position_unit = "rad";
    ds_.command_unit = "V";
    test::ModelDatasetPlan plan;
    plan.poses_deg = {{40.68, 68.52}};
    plan.freqs_hz = {2.0, 3.5, 6.0};
    plan.duration_s = 4.0;
    plan.file_prefix = "runs/";
    plan.separator = "_";
    test::append_model_runs(plan, ds_, data_);
    const ModelFile model =
        read_model_file(std::string(ALPHAINV_SOURCE_DIR) + "/tests/fixtures/paper_model.json");
    ValidationOptions vo;
    vo.use_alpha = false;
    result_ = validate_model(model, ds_, data_, vo);
  }
  static Dataset ds_;
  static std::vector<RunData> data_;
  static ValidationResult result_;
};
Dataset ValidationPlotsTest::ds_;
std::vector<RunData> ValidationPlotsTest::data_;
ValidationResult ValidationPlotsTest::result_;

TEST_F(ValidationPlotsTest, TheRunsShownAreThoseWithTheLowestFit) {
  ASSERT_TRUE(result_.ok) << result_.message;
  ASSERT_EQ(result_.runs.size(), 4u);
  std::vector<std::size_t> order = {0, 1, 2, 3};
  std::sort(order.begin(), order.end(), [](std::size_t a, std::size_t b) {
    return result_.runs[a].position.fit_percent < result_.runs[b].position.fit_percent;
  });
  std::vector<std::size_t> worst2 = {order[0], order[1]};
  std::sort(worst2.begin(), worst2.end());
  EXPECT_EQ(validation_runs_shown(result_, 2), worst2);
  EXPECT_EQ(validation_runs_shown(result_, 4), (std::vector<std::size_t>{0, 1, 2, 3}));
  EXPECT_EQ(validation_runs_shown(result_, 0), std::vector<std::size_t>{});
}

TEST_F(ValidationPlotsTest, DataFilesCarryTheValidationsNumbers) {
  const test::ScopedTempDir tmp("validation_plots", "data");
  ValidationPlotOptions opt;
  opt.plot.out_dir = tmp.path;
  opt.plot.run_gnuplot = false;
  opt.max_runs = 4;
  const PlotSummary s = write_validation_plots(ds_, data_, result_, opt);
  EXPECT_EQ(s.gnuplot_problem, "drawing was not asked for");
  ASSERT_EQ(s.figures.size(), 1u + 2u * 4u);  // fit per run, then compare and resid per run
  EXPECT_EQ(s.figures[0].id, "validation_fit_per_run");
  const fs::path plots = tmp.path / "plots";
  const auto per_run = test::read_dat_block(plots / "validation_fit_per_run.dat", 0);
  ASSERT_EQ(per_run.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(per_run[i][0], static_cast<double>(i + 1));
    EXPECT_NEAR(per_run[i][1], result_.runs[i].position.fit_percent, 1e-6);
  }
  for (std::size_t i = 0; i < 4; ++i) {
    const ValidatedRun& v = result_.runs[i];
    const std::string n = std::to_string(i + 1);
    const auto cmp = test::read_dat_block(plots / ("validation_compare_run" + n + ".dat"), 0);
    ASSERT_EQ(cmp.size(), data_[i].size()) << n;  // 4000 samples: every one
    for (std::size_t k = 0; k < cmp.size(); k += 397) {
      EXPECT_NEAR(cmp[k][0], data_[i].t[k], 1e-12);
      EXPECT_NEAR(cmp[k][1], data_[i].theta[k], 1e-9 * (1 + std::abs(data_[i].theta[k])));
      EXPECT_NEAR(cmp[k][2], v.theta_simulated[k], 1e-9 * (1 + std::abs(v.theta_simulated[k])));
      EXPECT_NEAR(cmp[k][3], data_[i].theta[k] - v.theta_simulated[k], 1e-9);
    }
    ASSERT_TRUE(v.residual.valid) << v.residual.message;
    const auto auto_rows = test::read_dat_block(plots / ("validation_resid_run" + n + ".dat"), 0);
    const auto cross_rows = test::read_dat_block(plots / ("validation_resid_run" + n + ".dat"), 1);
    ASSERT_EQ(auto_rows.size(), v.residual.autocorrelation.size());
    ASSERT_EQ(cross_rows.size(), v.residual.cross_correlation.size());
    EXPECT_DOUBLE_EQ(auto_rows[0][2], 1.0);  // ρ_e(0)
    // Lags in seconds: τ · decimation · 1 ms.
    EXPECT_NEAR(auto_rows[5][0], 5.0 * static_cast<double>(v.residual.decimation) * 1e-3, 1e-9);
    EXPECT_NEAR(auto_rows[3][2], v.residual.autocorrelation[3], 1e-9);
    EXPECT_NEAR(auto_rows[3][3], v.residual.autocorrelation_bound, 1e-9);
    const std::size_t mid = cross_rows.size() / 2;
    EXPECT_EQ(cross_rows[mid][1], 0.0);
    EXPECT_NEAR(cross_rows[mid][2], v.residual.cross_correlation[mid], 1e-9);
    EXPECT_NEAR(cross_rows[mid][3], v.residual.cross_correlation_bound, 1e-9);
  }
  // A long run is thinned to max_points.
  opt.max_points = 1000;
  (void)write_validation_plots(ds_, data_, result_, opt);
  const std::size_t n = data_[0].size(), step = (n + 999) / 1000;  // every step-th sample
  const auto thin = test::read_dat_block(plots / "validation_compare_run1.dat", 0);
  EXPECT_EQ(thin.size(), (n + step - 1) / step);
  EXPECT_LE(thin.size(), 1000u);
  ASSERT_GT(thin.size(), 2u);
  EXPECT_NEAR(thin[2][0], data_[0].t[2 * step], 1e-12);
}

TEST_F(ValidationPlotsTest, TheSectionLinksEveryDrawnFigureOrSaysWhyNone) {
  const test::ScopedTempDir tmp("validation_plots", "draw");
  ValidationPlotOptions opt;
  opt.plot.out_dir = tmp.path;
  opt.max_runs = 1;
  opt.prefix = "heldout";
  opt.plot.gnuplot = "no-such-gnuplot-program";
  std::string warning;
  const std::string missing = draw_validation_figures(ds_, data_, result_, opt, "###", warning);
  EXPECT_NE(missing.find("### Validation figures"), std::string::npos) << missing;
  EXPECT_NE(missing.find("Plots were skipped: `no-such-gnuplot-program` was not found"),
            std::string::npos) << missing;
  EXPECT_NE(warning.find("validation plots skipped"), std::string::npos);
  EXPECT_TRUE(fs::exists(tmp.path / "plots" / "heldout_fit_per_run.gp"));
  EXPECT_FALSE(fs::exists(tmp.path / "plots" / "heldout_fit_per_run.png"));
  EXPECT_NE(missing.find("the 1 of the 4 validated runs with the lowest fit %"), std::string::npos);
  if (!test::gnuplot_installed()) GTEST_SKIP() << "gnuplot not installed";
  opt.plot.gnuplot = "gnuplot";
  const std::string md = draw_validation_figures(ds_, data_, result_, opt, "###", warning);
  EXPECT_TRUE(warning.empty()) << warning;
  const std::size_t shown = validation_runs_shown(result_, 1).at(0) + 1;
  for (const std::string& id : {std::string("heldout_fit_per_run"),
                               "heldout_compare_run" + std::to_string(shown),
                               "heldout_resid_run" + std::to_string(shown)}) {
    EXPECT_NE(md.find("](plots/" + id + ".png)"), std::string::npos) << id << "\n" << md;
    std::ifstream png(tmp.path / "plots" / (id + ".png"), std::ios::binary);
    char sig[4] = {};
    png.read(sig, 4);
    EXPECT_EQ(std::string(sig + 1, 3), "PNG") << id;
  }
}

}  // namespace
}  // namespace omni_fit
