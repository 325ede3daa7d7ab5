#pragma once
/// \file rt/latency_histogram.hpp
/// A fixed-size histogram of durations (1 µs bins up to 20 ms, and an overflow count) for the
/// loop's timing statistics: wake-up latency, read and write times. add() is real-time safe.

#include <array>
#include <cstdint>

namespace alphainv::rt {

/// Percentiles of a set of durations [s].
struct LatencySummary {
  long count = 0;
  double p50_s = 0.0, p99_s = 0.0, p999_s = 0.0, max_s = 0.0, mean_s = 0.0;
};

/// Histogram of durations (see the file comment).
class LatencyHistogram {
 public:
  static constexpr int kBins = 20000;         ///< bins of kBinWidthS; above: overflow
  static constexpr double kBinWidthS = 1e-6;  ///< bin width [s]

  /// Adds one duration [s] (negative counts as 0). Real-time safe: no allocation, no locks, no I/O.
  void add(double seconds) noexcept {
    if (!(seconds > 0.0)) seconds = 0.0;
    const double bin = seconds / kBinWidthS;
    if (bin >= kBins) {
      ++overflow_;
    } else {
      ++bins_[static_cast<std::size_t>(bin)];
    }
    if (seconds > max_s_) max_s_ = seconds;
    sum_s_ += seconds;
    ++count_;
  }
  /// Empties it. Real-time safe.
  void clear() noexcept {
    bins_.fill(0);
    overflow_ = 0;
    count_ = 0;
    max_s_ = 0.0;
    sum_s_ = 0.0;
  }
  /// p50, p99, p99.9 (upper edge of the bin where the cumulative count reaches the quantile;
  /// max_s when it falls in the overflow), max and mean. Real-time safe but O(kBins).
  LatencySummary summary() const noexcept {
    LatencySummary s;
    s.count = count_;
    if (count_ == 0) return s;
    s.max_s = max_s_;
    s.mean_s = sum_s_ / static_cast<double>(count_);
    s.p50_s = quantile(0.5);
    s.p99_s = quantile(0.99);
    s.p999_s = quantile(0.999);
    return s;
  }
  long count() const noexcept { return count_; }

 private:
  double quantile(double q) const noexcept {
    const double need = q * static_cast<double>(count_);
    double cum = 0.0;
    for (int i = 0; i < kBins; ++i) {
      cum += bins_[static_cast<std::size_t>(i)];
      if (cum >= need && cum > 0.0) {
        const double edge = (i + 1) * kBinWidthS;
        return edge < max_s_ ? edge : max_s_;
      }
    }
    return max_s_;
  }

  std::array<std::uint32_t, kBins> bins_{};
  long overflow_ = 0;
  long count_ = 0;
  double max_s_ = 0.0;
  double sum_s_ = 0.0;
};

}  // namespace alphainv::rt
