#include "alphainv/device/timing_stats.hpp"

#include <cstdio>

namespace alphainv::device {

std::string TimingStats::to_text() const {
  char buf[768];
  std::snprintf(buf, sizeof buf,
                "ticks %ld, deadline misses %ld (%ld deadlines skipped)\n"
                "wake-up latency [us]: p50 %.1f  p99 %.1f  p99.9 %.1f  max %.1f\n"
                "period jitter [us]:   p50 %.1f  p99 %.1f  p99.9 %.1f  max %.1f\n"
                "read [us]:            p50 %.1f  p99 %.1f  max %.1f\n"
                "write [us]:           p50 %.1f  p99 %.1f  max %.1f",
                ticks, deadline_misses, skipped_ticks, latency.p50_s * 1e6, latency.p99_s * 1e6,
                latency.p999_s * 1e6, latency.max_s * 1e6, period_jitter.p50_s * 1e6,
                period_jitter.p99_s * 1e6, period_jitter.p999_s * 1e6, period_jitter.max_s * 1e6,
                read.p50_s * 1e6, read.p99_s * 1e6, read.max_s * 1e6, write.p50_s * 1e6,
                write.p99_s * 1e6, write.max_s * 1e6);
  return buf;
}

}  // namespace alphainv::device
