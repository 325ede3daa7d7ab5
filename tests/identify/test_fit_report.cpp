// report.md of the bundled set's fit (the virtual Omni's paper plan, seed 1: bit for bit
// data/omni_yaw_sim, generated here). The lines checked are those of `omni_fit fit
// data/omni_yaw_sim`'s report.md.

#include "alphainv/identify/fit_report.hpp"

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "alphainv/identify/fit_stages.hpp"
#include "alphainv/simulate/experiment_plan.hpp"

namespace alphainv {
namespace {

struct BundledFit {
  GeneratedDataset data;
  DatasetFit fit;
};

/// The bundled set and its fit (default options), computed once.
const BundledFit& bundled() {
  static const BundledFit b = [] {
    BundledFit out;
    out.data = generate_dataset(paper_experiment_plan(1));
    FitPipelineOptions o;
    o.threads = 2;
    out.fit = fit_dataset(out.data.index, out.data.runs, o);
    return out;
  }();
  return b;
}

void expect_lines(const std::string& text, const std::vector<std::string>& lines) {
  for (const std::string& line : lines) {
    EXPECT_NE(text.find("\n" + line + "\n"), std::string::npos) << "missing line: " << line;
  }
}

TEST(FitReport, ReportNumberFormatsLikeTheTables) {
  EXPECT_EQ(report_number(17.6912), "17.69");
  EXPECT_EQ(report_number(0.00055365), "0.0005537");
  EXPECT_EQ(report_number(-20.7071, "%.2f"), "-20.71");
  EXPECT_EQ(report_number(std::numeric_limits<double>::quiet_NaN()), "–");
  EXPECT_EQ(report_number(-std::numeric_limits<double>::infinity(), "%.2f"), "–");
}

TEST(FitReport, MarkdownOfTheBundledFit) {
  const BundledFit& b = bundled();
  FitReportInfo info;
  info.dataset_hash = "f4325ab4c399bb67";
  info.appendix_markdown = "\n## Figures\n\nnone\n";
  const std::string md = fit_report_markdown(b.data.index, b.fit, info);
  EXPECT_EQ(md.rfind("# omni_fit report\n\nDataset: `` (106 runs, 25 poses, position unit rad, "
                     "command unit V), hash f4325ab4c399bb67.\n\n",
                     0),
            0u)
      << md.substr(0, 200);
  expect_lines(md, {
      "## What the data could and could not support",
      "- models simulated as the digital loop at 1000 Hz (command held over each tick)",
      "## Local linear points (eqs. 19, 20, 36)",
      "| runs/sine_25_70_1.5hz.csv | 20.01° / 68.43° | 1.5 | 1.126 | -20.71 | 17.69 | 529.6 | "
      "0.2808 | yes |",
      "| runs/sine_25_90_3hz.csv | 19.52° / 87.41° | 3 | 4.282 | -110.79 | 3.986 | 328.8 | "
      "155.8 | yes |",
      "| 20.01° / 68.43° | 2.69–4.55 | 5.595 | 441.1 | 220.6 | 0.0045445 |",
      "| 60.73° / 113.15° | 2.69–4.55 | 5.507 | 431.8 | 215.9 | 0.00471124 |",
      "| I_base | 0.0015244 | 6.45e-05 | no |",
      "| C0_bar | 39.017 | 0.57 | no |",
      "RMS relative error of the model: C_linear 4.82 %, β̃_linear 3.21 %.",
      "## α-invariant model (eqs. 38–42; breakpoints by exhaustive grid search over 560 sets, "
      "refined by NLopt Nelder-Mead)",
      "| 3 | 154 | **no** | 45.54 | 0.508 | **no** |",
      "β̃_n1 = 0.8369 ± 0.00092 at α = 0, 1.072 ± 0.0015 at α = 154. RMS relative error on the "
      "data: C 4.47 %, β̃ 0.45 %.",
      "| 61.48° / 107.59° | – | – | 0.004201 | 0.02288 | – | – | 0.0005411 | 0.003791 |",
      "| **median** | 0.5078 | 12.78 | 0.004352 | 0.02305 | 0.04263 | 1.843 | 0.0005537 | "
      "0.004137 |",
      "| runs/sine_25_70_1.5hz.csv | 24.6319 % | 1.3153 % |",
  });
  EXPECT_EQ(md.find("Fitted with known effects"), std::string::npos);
  // The appendix ends the report, after the last run of the relative-error table.
  const std::string tail = "| runs/square_65_115.csv | 17.2517 % | 4.1114 % |\n";
  ASSERT_NE(md.find(tail), std::string::npos);
  EXPECT_EQ(md.substr(md.size() - info.appendix_markdown.size()), info.appendix_markdown);
  EXPECT_EQ(md.find(tail) + tail.size(), md.size() - info.appendix_markdown.size());
}

TEST(FitReport, NamesTheKnownEffectsAndWhereTheyCameFrom) {
  DatasetFit fit = bundled().fit;
  fit.effects.coulomb_v = 0.004;
  FitReportInfo info;
  info.effects_source = "from `diag.json`";
  const std::string md = fit_report_markdown(bundled().data.index, fit, info);
  EXPECT_NE(md.find("**Fitted with known effects** (from `diag.json`): coulomb_friction "
                    "(coulomb_v = 0.004, coulomb_smoothing_rad_s = 0.001). The local points"),
            std::string::npos)
      << md.substr(0, 600);
}

TEST(FitReport, WithoutModelsTheSectionsAreLeftOut) {
  const BundledFit& b = bundled();
  DatasetFit fit;
  group_runs_by_pose(b.data.index, fit);  // poses only: nothing identified
  const std::string md = fit_report_markdown(b.data.index, fit);
  EXPECT_EQ(md.find("## What the data could"), std::string::npos);  // no notes
  EXPECT_EQ(md.find("## Inertia model"), std::string::npos);
  EXPECT_EQ(md.find("## α-invariant model"), std::string::npos);
  expect_lines(md, {"## Global linear model per pose (eq. 22)",
                    "| 20.01° / 68.43° | – | – | – | – | – | – | – | – |"});
}

}  // namespace
}  // namespace alphainv
