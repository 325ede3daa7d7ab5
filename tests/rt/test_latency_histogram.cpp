// LatencyHistogram percentiles against a known distribution.
#include <gtest/gtest.h>

#include <memory>

#include "alphainv/rt/latency_histogram.hpp"

using alphainv::rt::LatencyHistogram;

TEST(LatencyHistogram, PercentilesOfAUniformSet) {
  auto h = std::make_unique<LatencyHistogram>();
  for (int us = 1; us <= 1000; ++us) h->add((us - 0.5) * 1e-6);  // one per 1 µs bin
  const auto s = h->summary();
  EXPECT_EQ(s.count, 1000);
  EXPECT_NEAR(s.p50_s, 500e-6, 1e-12);
  EXPECT_NEAR(s.p99_s, 990e-6, 1e-12);
  EXPECT_NEAR(s.p999_s, 999e-6, 1e-12);
  EXPECT_NEAR(s.max_s, 999.5e-6, 1e-12);
  EXPECT_NEAR(s.mean_s, 500e-6, 1e-9);
}

TEST(LatencyHistogram, OverflowAndNegativeValues) {
  auto h = std::make_unique<LatencyHistogram>();
  EXPECT_EQ(h->summary().count, 0);
  for (int i = 0; i < 998; ++i) h->add(-1.0);  // counts as 0
  h->add(0.05);
  h->add(0.03);
  const auto s = h->summary();
  EXPECT_EQ(s.p50_s, 1e-6);   // the first bin's upper edge
  EXPECT_EQ(s.p999_s, 0.05);  // in the overflow: the max
  EXPECT_EQ(s.max_s, 0.05);
  h->clear();
  EXPECT_EQ(h->summary().count, 0);
}
