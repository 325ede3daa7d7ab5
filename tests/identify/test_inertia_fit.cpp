// Tests of inertia_fit.hpp: the fit of eqs. (27)-(29), against the paper's Tables 3 and 5,
// closed-form synthetic recovery, the analytic Jacobian, and bad input.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "alphainv/identify/detail/inertia_fit_residual.hpp"
#include "alphainv/identify/inertia_fit.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "support/error_of.hpp"

namespace alphainv {
namespace {

/// A CSV of the data/paper/ kind: one header line, numeric cells.
struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  std::size_t column(const std::string& name) const {
    const auto it = std::find(header.begin(), header.end(), name);
    if (it == header.end()) throw Error("no such column", "", 0, name);
    return static_cast<std::size_t>(it - header.begin());
  }
  double number(std::size_t row, const std::string& name) const {
    return std::stod(rows.at(row).at(column(name)));
  }
};

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) cells.push_back(cell);
  return cells;
}

Csv read_paper_csv(const std::string& name) {
  const std::string path = std::string(ALPHAINV_SOURCE_DIR) + "/data/paper/" + name;
  std::ifstream in(path);
  if (!in) throw Error("cannot open the file", path);
  Csv csv;
  std::string line;
  std::getline(in, line);
  csv.header = split(line);
  while (std::getline(in, line)) {
    if (!line.empty()) csv.rows.push_back(split(line));
  }
  return csv;
}

/// Poses from a table with true_gamma*_deg, c_linear_per_s, beta_tilde_linear columns.
std::vector<InertiaPose> poses_from(const Csv& csv) {
  std::vector<InertiaPose> poses;
  for (std::size_t i = 0; i < csv.rows.size(); ++i) {
    poses.push_back(InertiaPose{
        deg_to_rad(csv.number(i, "true_gamma1_deg")), deg_to_rad(csv.number(i, "true_gamma2_deg")),
        csv.number(i, "c_linear_per_s"), csv.number(i, "beta_tilde_linear"), 1.0});
  }
  return poses;
}

/// Exact data of a linear model at the given angles [deg].
std::vector<InertiaPose> synthetic_poses(const LinearModel& model,
                                         const std::vector<double>& gamma1_deg,
                                         const std::vector<double>& gamma2_deg) {
  std::vector<InertiaPose> poses;
  for (double g1 : gamma1_deg) {
    for (double g2 : gamma2_deg) {
      const InertiaPrediction p = predict_inertia_pose(model, deg_to_rad(g1), deg_to_rad(g2));
      poses.push_back(
          InertiaPose{deg_to_rad(g1), deg_to_rad(g2), p.c_linear, p.beta_tilde_linear, 1.0});
    }
  }
  return poses;
}

/// A model unlike the paper's (other parameters, other offset and ratio).
LinearModel synthetic_model() {
  return LinearModel{InertiaModel{2.0e-3, 1.5e-3, 1.2e-3, 2.2e-3, deg_to_rad(15.0)}, 28.0};
}

std::array<double, 6> parameters_of(const LinearModel& m) {
  return {m.inertia.i_base,         m.inertia.i1, m.inertia.i2, m.inertia.i3,
          m.inertia.gamma_offs_rad, m.c0_bar};
}

/// Standard normal from a portable generator (std::normal_distribution is not portable).
double gaussian(std::mt19937_64& rng) {
  constexpr double kTwoPi = 2.0 * kPi;
  const double u1 = (static_cast<double>(rng() >> 11) + 0.5) * 0x1.0p-53;
  const double u2 = (static_cast<double>(rng() >> 11) + 0.5) * 0x1.0p-53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(kTwoPi * u2);
}

// --- the paper's data -------------------------------------------------------------------------

// The data files agree with the paper's own cross-checks (erratum 3: Tables 6/7 with reversed α
// reproduce Table 10).
TEST(PaperData, Tables6And7WithCorrectedAlphaReproduceTable10) {
  const Csv params = read_paper_csv("table6_7_alpha_params.csv");
  const Csv t10 = read_paper_csv("table10_model_65_90.csv");
  ASSERT_EQ(params.rows.size(), 6u);
  ASSERT_EQ(t10.rows.size(), 6u);
  for (std::size_t i = 0; i < params.rows.size(); ++i) {
    const std::string quantity = params.rows[i][params.column("quantity")];
    const double alpha = params.number(i, "alpha");
    bool found = false;
    for (std::size_t j = 0; j < t10.rows.size(); ++j) {
      if (t10.rows[j][t10.column("quantity")] != quantity || t10.number(j, "alpha") != alpha)
        continue;
      found = true;
      const double value = 1.0 / (params.number(i, "value_n1") * t10.number(j, "inertia"));
      EXPECT_NEAR(value / t10.number(j, "value"), 1.0, 3e-4) << quantity << " at alpha " << alpha;
    }
    EXPECT_TRUE(found) << quantity << " at alpha " << alpha;
  }
}

// (b) The erratum: paper_inertia_model() with C̄0 = 36.694 reproduces Table 5's modelled columns.
TEST(PaperData, PaperInertiaModelReproducesTable5Modelled) {
  const Csv t5 = read_paper_csv("table5_modelled.csv");
  ASSERT_EQ(t5.rows.size(), 9u);
  const LinearModel model = paper_linear_model();
  EXPECT_DOUBLE_EQ(model.c0_bar, 36.694);
  for (std::size_t i = 0; i < t5.rows.size(); ++i) {
    const InertiaPrediction p =
        predict_inertia_pose(model, deg_to_rad(t5.number(i, "true_gamma1_deg")),
                             deg_to_rad(t5.number(i, "true_gamma2_deg")));
    EXPECT_NEAR(p.c_linear / t5.number(i, "c_linear_per_s"), 1.0, 1e-3) << "row " << i;
    EXPECT_NEAR(p.beta_tilde_linear / t5.number(i, "beta_tilde_linear"), 1.0, 1e-3) << "row " << i;
  }
}

// (f) Table 3's closed-form C̄0 ratio "36.727".
TEST(RegressC0Bar, Table3GivesPaperRatio) {
  const C0BarEstimate est = regress_c0_bar(poses_from(read_paper_csv("table3_linear_fits.csv")));
  ASSERT_TRUE(est.ok) << est.message;
  std::cout << "[ info ] closed-form C0_bar of Table 3 = " << est.c0_bar
            << " (paper 36.727), RMS relative residual " << est.rms_relative_residual << "\n";
  EXPECT_NEAR(est.c0_bar / 36.727, 1.0, 5e-3);
}

TEST(RegressC0Bar, ExactForProportionalData) {
  std::vector<InertiaPose> poses;
  for (int i = 1; i <= 4; ++i) poses.push_back(InertiaPose{0.0, 0.0, 1.0 * i, 30.0 * i, 1.0 + i});
  const C0BarEstimate est = regress_c0_bar(poses);
  ASSERT_TRUE(est.ok);
  EXPECT_NEAR(est.c0_bar, 30.0, 1e-12);
  EXPECT_NEAR(est.rms_relative_residual, 0.0, 1e-14);
}

TEST(RegressC0Bar, BadInputGivesMessage) {
  EXPECT_FALSE(regress_c0_bar({}).ok);
  const C0BarEstimate est = regress_c0_bar({InertiaPose{0.0, 0.0, -1.0, 200.0, 1.0}});
  EXPECT_FALSE(est.ok);
  EXPECT_TRUE(std::isnan(est.c0_bar));
  EXPECT_NE(est.message.find("pose 0"), std::string::npos) << est.message;
}

// (a) Fitting Table 3 (true angles, Fitted columns) reproduces Table 5's modelled values.
TEST(InertiaFit, Table3ReproducesTable5Modelled) {
  const std::vector<InertiaPose> poses = poses_from(read_paper_csv("table3_linear_fits.csv"));
  const Csv t5 = read_paper_csv("table5_modelled.csv");
  ASSERT_EQ(poses.size(), t5.rows.size());
  const InertiaFitSummary s = fit_inertia_model(poses);
  std::cout << s.full_report();
  ASSERT_TRUE(s.converged) << s.message;
  double max_dev_c = 0.0;
  double max_dev_b = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const double dev_c = s.predictions[i].c_linear / t5.number(i, "c_linear_per_s") - 1.0;
    const double dev_b =
        s.predictions[i].beta_tilde_linear / t5.number(i, "beta_tilde_linear") - 1.0;
    max_dev_c = std::max(max_dev_c, std::abs(dev_c));
    max_dev_b = std::max(max_dev_b, std::abs(dev_b));
    EXPECT_LT(std::abs(dev_c), 0.03) << "row " << i;
    EXPECT_LT(std::abs(dev_b), 0.03) << "row " << i;
  }
  std::cout << "[ info ] max relative deviation from Table 5 modelled: C " << max_dev_c
            << ", beta_tilde " << max_dev_b << "; C0_bar " << s.model.c0_bar << " (paper 36.693)\n";
  EXPECT_NEAR(s.model.c0_bar / 36.693, 1.0, 0.015);
  // The model is physically valid (section 2.2.6) and the summary is self-consistent.
  for (int k = kIBase; k <= kI3; ++k) EXPECT_GE(s.parameters[static_cast<std::size_t>(k)], 0.0);
  EXPECT_NEAR(s.residual_rms, std::sqrt(2.0 * s.final_cost / 18.0), 1e-15);
  EXPECT_EQ(s.num_poses, 9);
  EXPECT_EQ(s.num_residuals, 18);
  EXPECT_GT(s.num_starts_usable, 0);
  // Erratum 2: the inertia parameters are weakly identifiable from 9 poses; the summary must say
  // so rather than pretend precision. C̄0 itself is well determined.
  if (s.covariance_ok) {
    for (double se : s.standard_errors) EXPECT_TRUE(std::isfinite(se));
    EXPECT_FALSE(s.poorly_determined[kC0Bar]);
    EXPECT_NEAR(s.correlation(0, 0), 1.0, 1e-12);
    EXPECT_TRUE((s.correlation - s.correlation.transpose()).cwiseAbs().maxCoeff() < 1e-12);
  }
  // The paper's own fit (erratum 1's corrected Table 4) is consistent with ours within 3 SE.
  if (s.covariance_ok) {
    const std::array<double, 6> paper = parameters_of(paper_linear_model());
    for (std::size_t k = 0; k < paper.size(); ++k) {
      EXPECT_LT(std::abs(s.parameters[k] - paper[k]), 3.0 * s.standard_errors[k])
          << inertia_fit_parameter_name(static_cast<int>(k));
    }
  }
  const bool any_inertia_flagged = s.poorly_determined[kIBase] || s.poorly_determined[kI1] ||
                                   s.poorly_determined[kI2] || s.poorly_determined[kI3];
  EXPECT_TRUE(any_inertia_flagged);
  EXPECT_FALSE(s.warning.empty());
}

// --- closed-form recovery ---------------------------------------------------------------------

// (c) 3×3 grid like the paper's: exact data are refit to exact predictions (the parameters
// themselves need not be unique).
TEST(InertiaFit, ExactSynthetic3x3GridReproducesPredictions) {
  const LinearModel truth = synthetic_model();
  const std::vector<InertiaPose> poses =
      synthetic_poses(truth, {20.0, 40.0, 60.0}, {70.0, 90.0, 115.0});
  const InertiaFitSummary s = fit_inertia_model(poses);
  ASSERT_TRUE(s.converged) << s.full_report();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(s.predictions[i].c_linear / poses[i].c_linear, 1.0, 1e-6) << "pose " << i;
    EXPECT_NEAR(s.predictions[i].beta_tilde_linear / poses[i].beta_tilde_linear, 1.0, 1e-6)
        << "pose " << i;
  }
  // Also at poses the fit has not seen, inside the grid.
  const InertiaPrediction p = predict_inertia_pose(s.model, deg_to_rad(33.0), deg_to_rad(101.0));
  const InertiaPrediction q = predict_inertia_pose(truth, deg_to_rad(33.0), deg_to_rad(101.0));
  EXPECT_NEAR(p.beta_tilde_linear / q.beta_tilde_linear, 1.0, 1e-3);
  EXPECT_LT(s.residual_rms, 1e-7);
}

// (c) 25 well-spread poses determine the parameters.
TEST(InertiaFit, ExactSynthetic5x5GridRecoversParameters) {
  const LinearModel truth = synthetic_model();
  const std::vector<InertiaPose> poses =
      synthetic_poses(truth, {0.0, 20.0, 40.0, 60.0, 80.0}, {30.0, 60.0, 90.0, 120.0, 150.0});
  ASSERT_GE(poses.size(), 15u);
  const InertiaFitSummary s = fit_inertia_model(poses);
  ASSERT_TRUE(s.converged) << s.full_report();
  const std::array<double, 6> expected = parameters_of(truth);
  for (std::size_t k = 0; k < expected.size(); ++k) {
    EXPECT_NEAR(s.parameters[k] / expected[k], 1.0, 1e-4)
        << inertia_fit_parameter_name(static_cast<int>(k));
  }
  for (std::size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(s.predictions[i].c_linear / poses[i].c_linear, 1.0, 1e-6);
    EXPECT_NEAR(s.predictions[i].beta_tilde_linear / poses[i].beta_tilde_linear, 1.0, 1e-6);
  }
  EXPECT_TRUE(s.covariance_ok) << s.warning;
}

// (c) With 1 % noise the standard errors are finite and cover the truth.
TEST(InertiaFit, NoisySyntheticStandardErrorsCoverTruth) {
  const LinearModel truth = synthetic_model();
  std::vector<InertiaPose> poses =
      synthetic_poses(truth, {0.0, 20.0, 40.0, 60.0, 80.0}, {30.0, 60.0, 90.0, 120.0, 150.0});
  std::mt19937_64 rng(20240611u);
  for (InertiaPose& p : poses) {
    p.c_linear *= 1.0 + 0.01 * gaussian(rng);
    p.beta_tilde_linear *= 1.0 + 0.01 * gaussian(rng);
  }
  const InertiaFitSummary s = fit_inertia_model(poses);
  std::cout << s.full_report();
  ASSERT_TRUE(s.converged) << s.message;
  ASSERT_TRUE(s.covariance_ok) << s.warning;
  EXPECT_NEAR(s.residual_rms, 0.01, 0.005);  // the noise level, minus the fitted degrees of freedom
  const std::array<double, 6> expected = parameters_of(truth);
  for (std::size_t k = 0; k < expected.size(); ++k) {
    const char* name = inertia_fit_parameter_name(static_cast<int>(k));
    ASSERT_TRUE(std::isfinite(s.standard_errors[k])) << name;
    EXPECT_GT(s.standard_errors[k], 0.0) << name;
    EXPECT_LT(std::abs(s.parameters[k] - expected[k]), 4.0 * s.standard_errors[k])
        << name << " = " << s.parameters[k] << " +- " << s.standard_errors[k] << ", truth "
        << expected[k];
  }
}

// --- the analytic Jacobian --------------------------------------------------------------------

/// Random pose and parameters around the paper's magnitudes, including extreme angles.
void random_point(std::mt19937_64& rng, InertiaPose* pose, double* params) {
  auto uniform = [&rng](double lo, double hi) {
    return lo + (hi - lo) * (static_cast<double>(rng() >> 11) * 0x1.0p-53);
  };
  pose->gamma1_rad = deg_to_rad(uniform(-10.0, 95.0));
  pose->gamma2_rad = deg_to_rad(uniform(20.0, 160.0));
  pose->c_linear = uniform(2.0, 10.0);
  pose->beta_tilde_linear = uniform(100.0, 400.0);
  pose->weight = uniform(0.2, 3.0);
  params[kIBase] = uniform(1.5e-3, 4e-3);
  params[kI1] = uniform(0.0, 3e-3);
  params[kI2] = uniform(0.0, 3e-3);
  params[kI3] = uniform(0.0, 1e-3);
  params[kGammaOffs] = deg_to_rad(uniform(-30.0, 40.0));
  params[kC0Bar] = uniform(10.0, 60.0);
}

// (d) Analytic Jacobian vs central differences (with Richardson extrapolation).
TEST(InertiaFitJacobian, MatchesCentralDifferences) {
  std::mt19937_64 rng(7u);
  double worst = 0.0;
  for (int trial = 0; trial < 50; ++trial) {
    InertiaPose pose;
    double params[6];
    random_point(rng, &pose, params);
    double r[2];
    double jac[12];
    ASSERT_TRUE(detail::inertia_fit_residuals(pose, params, r, jac));
    for (int k = 0; k < 6; ++k) {
      const double typical = (k <= kI3) ? 1e-3 : 1.0;  // [inertia], [rad], [ratio]
      const double h = 1e-4 * std::max(std::abs(params[k]), typical);
      auto central = [&](double step, double* d) {
        double pp[6];
        double pm[6];
        std::copy(params, params + 6, pp);
        std::copy(params, params + 6, pm);
        pp[k] += step;
        pm[k] -= step;
        double rp[2] = {0.0, 0.0};
        double rm[2] = {0.0, 0.0};
        EXPECT_TRUE(detail::inertia_fit_residuals(pose, pp, rp, nullptr));
        EXPECT_TRUE(detail::inertia_fit_residuals(pose, pm, rm, nullptr));
        for (int i = 0; i < 2; ++i) d[i] = (rp[i] - rm[i]) / (2.0 * step);
      };
      double d1[2];
      double d2[2];
      central(h, d1);
      central(0.5 * h, d2);
      for (int i = 0; i < 2; ++i) {
        const double fd = (4.0 * d2[i] - d1[i]) / 3.0;  // Richardson: O(h⁴)
        const double analytic = jac[i * 6 + k];
        // Relative error; ∂r_β/∂C̄0 is exactly 0 in both, hence the small floor.
        const double err =
            std::abs(analytic - fd) / std::max({std::abs(analytic), std::abs(fd), 1e-8});
        worst = std::max(worst, err);
        EXPECT_LT(err, 1e-6) << "trial " << trial << " residual " << i << " parameter "
                             << inertia_fit_parameter_name(k) << ": analytic " << analytic
                             << ", finite difference " << fd;
      }
    }
  }
  std::cout << "[ info ] worst relative Jacobian error vs central differences: " << worst << "\n";
}

// (d) The Ceres cost function the fit uses (internal scaled parameters) passes Ceres' own check.
TEST(InertiaFitJacobian, PassesCeresGradientChecker) {
  std::mt19937_64 rng(11u);
  double worst = 0.0;
  for (int trial = 0; trial < 20; ++trial) {
    InertiaPose pose;
    double params[6];
    random_point(rng, &pose, params);
    const detail::InertiaJacobianCheck check =
        detail::check_inertia_fit_jacobian(pose, params, 4e-3, 36.7, 1e-6);
    worst = std::max(worst, check.max_relative_error);
    EXPECT_TRUE(check.ok) << "trial " << trial << ": " << check.log;
    EXPECT_LT(check.max_relative_error, 1e-6) << "trial " << trial;
  }
  std::cout << "[ info ] worst relative Jacobian error of the Ceres cost function: " << worst
            << "\n";
}

TEST(InertiaFitJacobian, RejectsNonPositiveInertia) {
  const InertiaPose pose{0.0, kPi / 2.0, 5.0, 200.0, 1.0};
  const double params[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 36.0};
  double r[2];
  EXPECT_FALSE(detail::inertia_fit_residuals(pose, params, r, nullptr));
}

// --- bad input --------------------------------------------------------------------------------

void expect_not_fitted(const std::vector<InertiaPose>& poses, const std::string& expected_text,
                       const InertiaFitOptions& options = {}) {
  InertiaFitSummary s;
  EXPECT_NO_THROW(s = fit_inertia_model(poses, options));
  EXPECT_FALSE(s.converged);
  EXPECT_FALSE(s.message.empty());
  EXPECT_NE(s.message.find(expected_text), std::string::npos) << s.message;
  EXPECT_FALSE(s.covariance_ok);
  EXPECT_TRUE(std::isnan(s.standard_errors[0]));
  EXPECT_FALSE(s.brief_report().empty());
  EXPECT_FALSE(s.full_report().empty());
}

// (e)
TEST(InertiaFit, BadInputGivesNonConvergedSummaryWithMessage) {
  const std::vector<InertiaPose> good = poses_from(read_paper_csv("table3_linear_fits.csv"));
  expect_not_fitted({good[0], good[1]}, "at least 6 poses");
  expect_not_fitted({}, "at least 6 poses");

  std::vector<InertiaPose> bad = good;
  bad[3].beta_tilde_linear = std::nan("");
  expect_not_fitted(bad, "pose 3: beta_tilde_linear");

  bad = good;
  bad[5].c_linear = -4.0;
  expect_not_fitted(bad, "pose 5: c_linear");

  bad = good;
  bad[0].c_linear = 0.0;
  expect_not_fitted(bad, "pose 0: c_linear");

  bad = good;
  bad[2].gamma2_rad = std::numeric_limits<double>::infinity();
  expect_not_fitted(bad, "pose 2: joint angles");

  bad = good;
  bad[8].weight = 0.0;
  expect_not_fitted(bad, "pose 8: weight");

  InertiaFitOptions options;
  options.gamma_offs_starts_rad = {deg_to_rad(120.0)};
  expect_not_fitted(good,
                    "invalid options: 'InertiaFitOptions::gamma_offs_starts_rad[0]': expected a "
                    "gamma_offs start in [-1.5708, 1.5708] rad, got 2.0944",
                    options);
  options = InertiaFitOptions{};
  options.max_iterations = 0;
  expect_not_fitted(good,
                    "'InertiaFitOptions::max_iterations': expected max_iterations >= 1, got 0",
                    options);
}

// Degenerate but valid input: six poses at the same angles cannot determine six parameters. The
// fit reproduces the data but must say the covariance is unavailable (rank deficient).
TEST(InertiaFit, RankDeficientInputReportsCovarianceFailure) {
  std::vector<InertiaPose> poses(6,
                                 InertiaPose{deg_to_rad(40.0), deg_to_rad(90.0), 5.0, 180.0, 1.0});
  InertiaFitSummary s;
  EXPECT_NO_THROW(s = fit_inertia_model(poses));
  EXPECT_FALSE(s.message.empty());
  EXPECT_FALSE(s.covariance_ok);
  EXPECT_NE(s.warning.find("Covariance not available"), std::string::npos) << s.warning;
  EXPECT_NE(s.warning.find("rank deficient"), std::string::npos) << s.warning;
  EXPECT_GT(s.jacobian_condition_number, 1e7);
  for (int k = 0; k < 6; ++k) {
    EXPECT_TRUE(std::isnan(s.standard_errors[static_cast<std::size_t>(k)]));
    EXPECT_TRUE(s.poorly_determined[static_cast<std::size_t>(k)]);
  }
  if (s.converged) {
    EXPECT_NEAR(s.predictions[0].beta_tilde_linear, 180.0, 1e-6 * 180.0);
    EXPECT_NEAR(s.predictions[0].c_linear, 5.0, 1e-6 * 5.0);
  }
}

TEST(InertiaFitOptions, DefaultsAreValidAndBadSettingsAreNamed) {
  EXPECT_NO_THROW(InertiaFitOptions{}.validate());
  auto rejected_field = [](const InertiaFitOptions& o) {
    return test::error_of([&] { o.validate(); }).field();
  };
  InertiaFitOptions o;
  o.gamma_offs_min_rad = 1.0;
  o.gamma_offs_max_rad = -1.0;
  EXPECT_EQ(rejected_field(o), "InertiaFitOptions::gamma_offs_min_rad");
  o = InertiaFitOptions{};
  o.inertia_scale_starts = {1.0, -0.5};
  EXPECT_EQ(rejected_field(o), "InertiaFitOptions::inertia_scale_starts[1]");
  o = InertiaFitOptions{};
  o.gradient_tolerance = std::nan("");
  EXPECT_EQ(rejected_field(o), "InertiaFitOptions::gradient_tolerance");
  o = InertiaFitOptions{};
  o.poorly_determined_correlation = 1.5;
  EXPECT_EQ(rejected_field(o), "InertiaFitOptions::poorly_determined_correlation");
  o = InertiaFitOptions{};
  o.gamma_offs_starts_rad.clear();
  EXPECT_EQ(rejected_field(o), "InertiaFitOptions::gamma_offs_starts_rad");
  EXPECT_STREQ(inertia_fit_parameter_name(kC0Bar), "C0_bar");
  EXPECT_STREQ(inertia_fit_parameter_name(6), "?");
}

}  // namespace
}  // namespace alphainv
