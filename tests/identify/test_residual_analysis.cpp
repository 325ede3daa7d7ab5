// Tests of include/alphainv/identify/residual_analysis.hpp: fit figures against closed forms, the
// quantiles against tables, and the residual tests' error rates on generated noise.
#include "alphainv/identify/residual_analysis.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace alphainv {
namespace {

TEST(FitFigures, MatchTheClosedForms) {
  const std::vector<double> y{1, 2, 3, 4}, y_hat{1, 2, 3, 5};
  const FitFigures f = fit_figures(y, y_hat);
  EXPECT_EQ(f.n, 4u);
  EXPECT_DOUBLE_EQ(f.rms, 0.5);
  EXPECT_DOUBLE_EQ(f.max_abs, 1.0);
  EXPECT_DOUBLE_EQ(f.fit_percent, 100.0 * (1.0 - 1.0 / std::sqrt(5.0)));  // ‖y − ȳ‖² = 5
  EXPECT_DOUBLE_EQ(f.relative_error, 1.0 / std::sqrt(30.0));             // ‖y‖² = 30
  const FitFigures perfect = fit_figures(y, y);
  EXPECT_EQ(perfect.fit_percent, 100.0);
  EXPECT_EQ(perfect.relative_error, 0.0);
  const FitFigures mean_only = fit_figures(y, std::vector<double>(4, 2.5));
  EXPECT_NEAR(mean_only.fit_percent, 0.0, 1e-12);  // the mean is a 0 % fit
  // A window, and non-finite pairs left out.
  const FitFigures w = fit_figures({1, 2, NAN, 4, 9}, {1, 2, 3, 5, 0}, 1, 4);
  EXPECT_EQ(w.n, 2u);
  EXPECT_DOUBLE_EQ(w.rms, std::sqrt(0.5));
  EXPECT_TRUE(std::isnan(fit_figures({3, 3}, {3, 4}).fit_percent));  // constant y
}

TEST(FitFigures, PooledOverRunsIsTheNormOverAllSamples) {
  const std::vector<double> y1{1, 2, 3}, h1{1.5, 2, 2}, y2{-1, 0, 4, 5}, h2{0, 0, 4, 4};
  const FitFigures p = pooled_fit_figures({fit_figures(y1, h1), fit_figures(y2, h2)});
  EXPECT_EQ(p.n, 7u);
  const double sse = 0.25 + 1.0 + 1.0 + 1.0;
  EXPECT_DOUBLE_EQ(p.rms, std::sqrt(sse / 7.0));
  EXPECT_DOUBLE_EQ(p.max_abs, 1.0);
  EXPECT_DOUBLE_EQ(p.relative_error, std::sqrt(sse / (1 + 4 + 9 + 1 + 0 + 16 + 25)));
  // ȳ per run: 2 and 2.
  EXPECT_DOUBLE_EQ(p.fit_percent, 100.0 * (1.0 - std::sqrt(sse / (2.0 + 26.0))));
}

TEST(Quantiles, MatchTheTables) {
  EXPECT_NEAR(normal_quantile(0.995), 2.5758293035489, 1e-8);
  EXPECT_NEAR(normal_quantile(0.975), 1.9599639845401, 1e-8);
  EXPECT_NEAR(normal_quantile(0.01), -2.3263478740408, 1e-8);
  EXPECT_NEAR(normal_quantile(0.5), 0.0, 1e-12);
  EXPECT_TRUE(std::isnan(normal_quantile(1.0)));
  EXPECT_NEAR(chi2_quantile(25, 0.99), 44.314, 0.01 * 44.314);
  EXPECT_NEAR(chi2_quantile(51, 0.99), 77.386, 0.01 * 77.386);
  EXPECT_NEAR(chi2_quantile(10, 0.95), 18.307, 0.01 * 18.307);
}

std::vector<double> white(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> x(n);
  for (double& v : x) v = g(rng);
  return x;
}

TEST(ResidualTests, WhiteNoiseIsWhiteAboutAsOftenAsTheConfidenceSays) {
  int not_white = 0, correlated = 0;
  const int trials = 200;
  for (int s = 0; s < trials; ++s) {
    const std::vector<double> e = white(3000, 1000 + s), u = white(3000, 5000 + s);
    const ResidualTests t = residual_tests(e, u);
    ASSERT_TRUE(t.valid) << t.message;
    EXPECT_EQ(t.autocorrelation.size(), 26u);
    EXPECT_EQ(t.cross_correlation.size(), 51u);
    EXPECT_DOUBLE_EQ(t.autocorrelation[0], 1.0);
    not_white += !t.white;
    correlated += t.input_correlated;
  }
  // 1 % expected of each: 2 of 200; at most 8 (binomial tail < 1e-3).
  EXPECT_LE(not_white, 8);
  EXPECT_LE(correlated, 8);
}

TEST(ResidualTests, ColouredResidualIsNotWhite) {
  const std::vector<double> w = white(3000, 7);
  std::vector<double> e(w.size());
  for (std::size_t k = 0; k < e.size(); ++k) e[k] = w[k] + (k > 0 ? 0.5 * e[k - 1] : 0.0);
  const ResidualTests t = residual_tests(e, {});
  ASSERT_TRUE(t.valid);
  EXPECT_FALSE(t.white);
  EXPECT_NEAR(t.autocorrelation[1], 0.5, 0.05);  // AR(1): ρ(1) = 0.5
  ASSERT_FALSE(t.lags_outside_auto.empty());
  EXPECT_EQ(t.lags_outside_auto.front(), 1);
  EXPECT_NE(t.verdict().find("residual not white"), std::string::npos) << t.verdict();
  EXPECT_NE(t.verdict().find("misses dynamics"), std::string::npos);
}

TEST(ResidualTests, ResidualDrivenByTheInputIsInputCorrelatedAtItsLag) {
  const std::vector<double> u = white(4000, 11), w = white(4000, 12);
  std::vector<double> e(u.size());
  for (std::size_t k = 0; k < e.size(); ++k) e[k] = w[k] + (k >= 3 ? 0.4 * u[k - 3] : 0.0);
  const ResidualTests t = residual_tests(e, u);
  ASSERT_TRUE(t.valid);
  EXPECT_TRUE(t.input_correlated);
  EXPECT_TRUE(t.white);  // e is still white in itself
  // ρ_eu(3) = 0.4/sqrt(1 + 0.16) ≈ 0.371, at index 3 + M.
  EXPECT_NEAR(t.cross_correlation[3 + 25], 0.4 / std::sqrt(1.16), 0.04);
  EXPECT_NE(std::find(t.lags_outside_cross.begin(), t.lags_outside_cross.end(), 3),
            t.lags_outside_cross.end());
  EXPECT_NE(t.verdict().find("misses input dynamics"), std::string::npos) << t.verdict();
}

TEST(ResidualTests, DecimationSpansTheDynamicsAndBadInputIsNamed) {
  ResidualTestOptions o;
  o.sample_period_s = 1e-3;
  const ResidualTests t = residual_tests(white(8000, 3), {}, o);
  EXPECT_EQ(t.decimation, 10u);  // 25 lags of 10 ms span 0.25 s
  EXPECT_EQ(t.n, 800u);
  const ResidualTests few = residual_tests(white(50, 3), {});
  EXPECT_FALSE(few.valid);
  EXPECT_NE(few.message.find("at least 101"), std::string::npos) << few.message;
  std::vector<double> bad = white(500, 4);
  bad[17] = NAN;
  EXPECT_NE(residual_tests(bad, {}).message.find("non-finite sample at 17"), std::string::npos);
  EXPECT_NE(residual_tests(std::vector<double>(500, 2.0), {}).message.find("constant"),
            std::string::npos);
  EXPECT_FALSE(residual_tests(white(500, 5), white(400, 6)).valid);  // lengths differ
  EXPECT_NE(few.verdict().find("not run"), std::string::npos);
}

}  // namespace
}  // namespace alphainv
