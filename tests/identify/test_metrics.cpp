#include "alphainv/identify/metrics.hpp"

#include <cmath>

#include <gtest/gtest.h>

namespace alphainv {
namespace {

TEST(Metrics, PercentileInterpolates) {
  EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4, 5}, 50), 3.0);
  EXPECT_DOUBLE_EQ(percentile({5, 1, 4, 2, 3}, 90), 4.6);
  EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4, 5}, 0), 1.0);
  EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4, 5}, 100), 5.0);
  EXPECT_DOUBLE_EQ(median({4, 1, 3, 2}), 2.5);
  EXPECT_TRUE(std::isnan(percentile({}, 50)));
}

TEST(Metrics, FundamentalErrorOfKnownGainAndPhase) {
  std::vector<double> t, r, m, s;
  const double w = 2 * M_PI * 2.0;
  for (int k = 0; k < 4000; ++k) {
    const double tt = k * 1e-3;
    t.push_back(tt);
    r.push_back(0.07 * std::sin(w * tt));
    m.push_back(0.9 * 0.07 * std::sin(w * tt - 0.5));            // gain 0.9, −0.5 rad
    s.push_back(1.2 * 0.07 * std::sin(w * tt - 0.5 + 0.1) + 1e-3);  // gain 1.2, 0.1 rad ahead
  }
  const FundamentalError e = fundamental_error(t, r, m, s, 2.0, 0, t.size());
  ASSERT_TRUE(e.valid);
  EXPECT_NEAR(e.gain_measured, 0.9, 1e-9);
  EXPECT_NEAR(e.gain_simulated, 1.2, 1e-9);
  EXPECT_NEAR(e.magnitude_abs_error, 0.3, 1e-9);
  EXPECT_NEAR(e.phase_measured_deg, -0.5 * 180 / M_PI, 1e-7);
  EXPECT_NEAR(e.phase_abs_error_deg, 0.1 * 180 / M_PI, 1e-7);
}

TEST(Metrics, PhaseErrorWrapsAround180) {
  std::vector<double> t, r, m, s;
  const double w = 2 * M_PI;
  for (int k = 0; k < 2000; ++k) {
    const double tt = k * 1e-3;
    t.push_back(tt);
    r.push_back(std::sin(w * tt));
    m.push_back(std::sin(w * tt + 3.0));
    s.push_back(std::sin(w * tt - 3.0));
  }
  const FundamentalError e = fundamental_error(t, r, m, s, 1.0, 0, t.size());
  EXPECT_NEAR(e.phase_abs_error_deg, (2 * M_PI - 6.0) * 180 / M_PI, 1e-7);
}

TEST(Metrics, AbsErrorStatsTable11Style) {
  const std::vector<double> meas = {0, 0, 0, 0, 0};
  const std::vector<double> sim = {0.1, -0.2, 0.3, -0.4, 0.5};
  const AbsErrorStats s = abs_error_stats(meas, sim, 0, 5);
  EXPECT_EQ(s.n, 5u);
  EXPECT_DOUBLE_EQ(s.median, 0.3);
  EXPECT_NEAR(s.p90, 0.46, 1e-12);
  EXPECT_NEAR(s.rms, std::sqrt((0.01 + 0.04 + 0.09 + 0.16 + 0.25) / 5), 1e-12);
  EXPECT_EQ(abs_error_stats(meas, sim, 3, 3).n, 0u);
}

}  // namespace
}  // namespace alphainv
