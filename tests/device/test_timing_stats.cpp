// TimingStats as text and as the JSON object of dataset.json's `timing` and the daemon's replies
// (docs/omni_ctl-protocol.md): every key, integers as integers, durations in µs.
#include "alphainv/device/timing_stats.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

using namespace alphainv;
using namespace alphainv::device;

namespace {

rt::LatencySummary summary(long count, double p50_s, double max_s) {
  rt::LatencySummary s;
  s.count = count;
  s.p50_s = p50_s;
  s.p99_s = 2 * p50_s;
  s.p999_s = 3 * p50_s;
  s.max_s = max_s;
  s.mean_s = 0.5 * max_s;
  return s;
}

TimingStats stats() {
  TimingStats t;
  t.ticks = 2000;
  t.deadline_misses = 3;
  t.skipped_ticks = 5;
  t.period_s = 1e-3;
  t.latency = summary(2000, 42e-6, 941e-6);
  t.period_jitter = summary(1999, 7e-6, 920e-6);
  t.read = summary(2000, 1e-6, 2.5e-6);
  t.write = summary(2000, 3e-6, 11e-6);
  return t;
}

}  // namespace

TEST(TimingStats, JsonHasEveryKeyInMicroseconds) {
  const nlohmann::json j = timing_json<nlohmann::json>(stats());
  EXPECT_EQ(j.size(), 8u);
  EXPECT_EQ(j["period_s"].get<double>(), 1e-3);
  ASSERT_TRUE(j["ticks"].is_number_integer());
  EXPECT_EQ(j["ticks"].get<long>(), 2000);
  EXPECT_EQ(j["deadline_misses"].get<long>(), 3);
  EXPECT_EQ(j["skipped_ticks"].get<long>(), 5);
  for (const char* key : {"wake_latency", "period_jitter", "read", "write"}) {
    SCOPED_TRACE(key);
    ASSERT_TRUE(j.contains(key));
    EXPECT_EQ(j[key].size(), 6u);
    EXPECT_TRUE(j[key]["count"].is_number_integer());
  }
  EXPECT_EQ(j["period_jitter"]["count"].get<long>(), 1999);
  EXPECT_DOUBLE_EQ(j["wake_latency"]["p50_us"].get<double>(), 42.0);
  EXPECT_DOUBLE_EQ(j["wake_latency"]["p99_us"].get<double>(), 84.0);
  EXPECT_DOUBLE_EQ(j["wake_latency"]["p999_us"].get<double>(), 126.0);
  EXPECT_DOUBLE_EQ(j["wake_latency"]["max_us"].get<double>(), 941.0);
  EXPECT_DOUBLE_EQ(j["wake_latency"]["mean_us"].get<double>(), 470.5);
  EXPECT_DOUBLE_EQ(j["read"]["max_us"].get<double>(), 2.5);
  EXPECT_DOUBLE_EQ(j["write"]["mean_us"].get<double>(), 5.5);
  // The protocol's keys, in the order the daemon sends them (sorted).
  std::vector<std::string> keys;
  for (const auto& item : j["write"].items()) keys.push_back(item.key());
  EXPECT_EQ(keys, (std::vector<std::string>{"count", "max_us", "mean_us", "p50_us", "p999_us",
                                            "p99_us"}));
}

TEST(TimingStats, TextGivesTheCountsAndPercentiles) {
  EXPECT_EQ(stats().to_text(),
            "ticks 2000, deadline misses 3 (5 deadlines skipped)\n"
            "wake-up latency [us]: p50 42.0  p99 84.0  p99.9 126.0  max 941.0\n"
            "period jitter [us]:   p50 7.0  p99 14.0  p99.9 21.0  max 920.0\n"
            "read [us]:            p50 1.0  p99 2.0  max 2.5\n"
            "write [us]:           p50 3.0  p99 6.0  max 11.0");
}
