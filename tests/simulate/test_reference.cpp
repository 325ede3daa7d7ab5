#include "alphainv/simulate/reference.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

namespace alphainv {
namespace {

TEST(Reference, SineDerivatives) {
  const SineReference s(0.07, 3.0, 0.2, 0.01);
  const double w = 2 * M_PI * 3.0, t = 0.123;
  const ReferenceSample r = s.at(t);
  EXPECT_NEAR(r.r, 0.01 + 0.07 * std::sin(w * t + 0.2), 1e-15);
  EXPECT_NEAR(r.r_dot, 0.07 * w * std::cos(w * t + 0.2), 1e-13);
  EXPECT_NEAR(r.r_ddot, -0.07 * w * w * std::sin(w * t + 0.2), 1e-11);
}

TEST(Reference, SquareValuesAndJumps) {
  const SquareReference q(0.07, 0.25);
  EXPECT_DOUBLE_EQ(q.at(0.0).r, 0.07);   // right-continuous: up at t = 0
  EXPECT_DOUBLE_EQ(q.at(1.99).r, 0.07);
  EXPECT_DOUBLE_EQ(q.at(2.0).r, -0.07);
  EXPECT_DOUBLE_EQ(q.at(3.5).r_dot, 0.0);
  std::vector<double> jumps;
  q.discontinuities(0.0, 8.0, jumps);
  ASSERT_EQ(jumps.size(), 4u);
  EXPECT_DOUBLE_EQ(jumps[0], 2.0);
  EXPECT_DOUBLE_EQ(jumps[3], 8.0);
}

TEST(Reference, SampledFollowsSmoothSignalAndKeepsJumps) {
  std::vector<double> t, r;
  for (int k = 0; k <= 1000; ++k) {
    t.push_back(k * 1e-3);
    r.push_back(std::sin(2 * M_PI * 2.0 * t.back()));
  }
  const SampledReference s(t, r);
  const double w = 2 * M_PI * 2.0, tt = 0.3005;
  EXPECT_NEAR(s.at(tt).r, std::sin(w * tt), 1e-8);
  EXPECT_NEAR(s.at(tt).r_dot, w * std::cos(w * tt), 1e-4 * w);
  EXPECT_NEAR(s.at(tt).r_ddot, -w * w * std::sin(w * tt), 0.01 * w * w);
  std::vector<double> jumps;
  s.discontinuities(0.0, 1.0, jumps);
  EXPECT_TRUE(jumps.empty());

  std::vector<double> sq(t.size());
  for (std::size_t k = 0; k < t.size(); ++k) sq[k] = t[k] < 0.5 ? -1.0 : 1.0;
  const SampledReference step(t, sq);
  step.discontinuities(0.0, 1.0, jumps);
  ASSERT_EQ(jumps.size(), 1u);
  EXPECT_DOUBLE_EQ(jumps[0], 0.5);
  EXPECT_DOUBLE_EQ(step.at(0.4995).r, -1.0);
  EXPECT_DOUBLE_EQ(step.at(0.5).r, 1.0);
  EXPECT_THROW(SampledReference({0.0}, {1.0}), std::exception);
}

TEST(Reference, SampledFindsTheSegmentOnIrregularTimes) {
  // The segment is guessed from the mean sample period and walked to, else searched: on samples
  // whose spacing grows 30-fold (the guess is off by hundreds of samples) and on a uniform grid,
  // r at each sample is that sample's and between samples it follows the signal.
  for (const bool uniform : {false, true}) {
    std::vector<double> t, r;
    for (int k = 0; k <= 600; ++k) {
      const double x = k / 600.0;
      t.push_back(uniform ? 3.0 * x : 3.0 * (0.1 * x + 0.9 * x * x * x));
      r.push_back(std::sin(2.0 * t.back()));
    }
    const SampledReference s(t, r);
    double worst = 0.0;
    for (std::size_t k = 1; k + 1 < t.size(); ++k) {
      EXPECT_EQ(s.at(t[k]).r, r[k]) << k;
      const double mid = 0.5 * (t[k] + t[k + 1]);
      worst = std::max(worst, std::abs(s.at(mid).r - std::sin(2.0 * mid)));
    }
    EXPECT_LT(worst, 2e-5) << (uniform ? "uniform" : "irregular");
  }
}

}  // namespace
}  // namespace alphainv
