#include "alphainv/simulate/reference.hpp"

#include <algorithm>
#include <cmath>

#include "alphainv/error.hpp"

namespace alphainv {

namespace {
constexpr double kTwoPi = 6.28318530717958647692;
}

void Reference::discontinuities(double, double, std::vector<double>&) const {}

SineReference::SineReference(double amplitude, double freq_hz, double phase_rad, double offset)
    : amplitude_(amplitude), omega_(kTwoPi * freq_hz), phase_(phase_rad), offset_(offset) {}

ReferenceSample SineReference::at(double t_s) const {
  const double s = std::sin(omega_ * t_s + phase_);
  const double c = std::cos(omega_ * t_s + phase_);
  return {offset_ + amplitude_ * s, amplitude_ * omega_ * c, -amplitude_ * omega_ * omega_ * s};
}

SquareReference::SquareReference(double amplitude, double freq_hz, double offset)
    : amplitude_(amplitude), freq_hz_(freq_hz), offset_(offset) {
  if (!(freq_hz > 0.0)) throw Error("expected a positive frequency [Hz]", {}, 0, "freq_hz");
}

ReferenceSample SquareReference::at(double t_s) const {
  const double phase = t_s * freq_hz_ - std::floor(t_s * freq_hz_);
  return {offset_ + (phase < 0.5 ? amplitude_ : -amplitude_), 0.0, 0.0};
}

void SquareReference::discontinuities(double t0_s, double t1_s, std::vector<double>& out) const {
  const double half_period = 0.5 / freq_hz_;
  for (double k = std::floor(t0_s / half_period) + 1.0;; k += 1.0) {
    const double t = k * half_period;
    if (t > t1_s) break;
    if (t > t0_s) out.push_back(t);
  }
}

SampledReference::SampledReference(std::vector<double> t_s, std::vector<double> r)
    : t_(std::move(t_s)), r_(std::move(r)) {
  if (t_.size() != r_.size() || t_.size() < 2) {
    throw Error("expected t and r of equal length >= 2", {}, 0, "r");
  }
  const std::size_t n = t_.size();
  const double span = t_.back() - t_.front();
  inv_mean_dt_ = span > 0.0 ? static_cast<double>(n - 1) / span : 0.0;
  // A jump is a step much larger than the typical (90th percentile) step of the signal.
  std::vector<double> steps(n - 1);
  for (std::size_t k = 0; k + 1 < n; ++k) steps[k] = std::abs(r_[k + 1] - r_[k]);
  std::vector<double> sorted = steps;
  const std::size_t q = (sorted.size() * 9) / 10;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(q), sorted.end());
  const double typical = sorted[q];
  double scale = 0.0;
  for (double v : r_) scale = std::max(scale, std::abs(v));
  const double threshold = std::max(20.0 * typical, 1e-9 * std::max(scale, 1e-300));
  jump_before_.assign(n, 0);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    if (steps[k] > threshold) jump_before_[k + 1] = 1;
  }
  // Slopes: central differences inside smooth stretches, one-sided at their ends, 0 next to jumps.
  slope_.assign(n, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    const bool left_ok = k > 0 && !jump_before_[k];
    const bool right_ok = k + 1 < n && !jump_before_[k + 1];
    if (left_ok && right_ok) {
      slope_[k] = (r_[k + 1] - r_[k - 1]) / (t_[k + 1] - t_[k - 1]);
    } else if (right_ok) {
      slope_[k] = (r_[k + 1] - r_[k]) / (t_[k + 1] - t_[k]);
    } else if (left_ok) {
      slope_[k] = (r_[k] - r_[k - 1]) / (t_[k] - t_[k - 1]);
    }
  }
}

std::size_t SampledReference::upper_index(double t_s) const noexcept {
  // The first k with t_[k] > t_s (std::upper_bound), t_.front() < t_s < t_.back(): guessed from
  // the mean sample period and walked to (a uniformly sampled run: at most a step or two), else
  // the binary search. The simulators ask once per step, so this is their reference's cost.
  const std::size_t n = t_.size();
  const double g = (t_s - t_.front()) * inv_mean_dt_;
  if (g >= 0.0 && g < static_cast<double>(n)) {
    std::size_t k = std::min(n - 1, static_cast<std::size_t>(g) + 1);
    for (int walk = 0; walk < 4; ++walk) {
      if (t_[k] <= t_s) {
        ++k;  // k < n: t_.back() > t_s
      } else if (t_[k - 1] > t_s) {
        --k;  // k > 1: t_.front() < t_s
      } else {
        return k;
      }
    }
  }
  return static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), t_s) - t_.begin());
}

ReferenceSample SampledReference::at(double t_s) const {
  if (t_s <= t_.front()) return {r_.front(), 0.0, 0.0};
  if (t_s >= t_.back()) return {r_.back(), 0.0, 0.0};
  const std::size_t k1 = upper_index(t_s);
  const std::size_t k0 = k1 - 1;
  if (jump_before_[k1]) return {r_[k0], 0.0, 0.0};  // held until the jump at t_[k1]
  const double h = t_[k1] - t_[k0];
  const double s = (t_s - t_[k0]) / h;
  const double p0 = r_[k0], p1 = r_[k1], m0 = slope_[k0] * h, m1 = slope_[k1] * h;
  // Cubic Hermite basis and its derivatives in s.
  const double s2 = s * s, s3 = s2 * s;
  const double r = (2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * p1 +
                   (s3 - s2) * m1;
  const double dr = (6 * s2 - 6 * s) * p0 + (3 * s2 - 4 * s + 1) * m0 + (-6 * s2 + 6 * s) * p1 +
                    (3 * s2 - 2 * s) * m1;
  const double ddr = (12 * s - 6) * p0 + (6 * s - 4) * m0 + (-12 * s + 6) * p1 + (6 * s - 2) * m1;
  return {r, dr / h, ddr / (h * h)};
}

void SampledReference::discontinuities(double t0_s, double t1_s, std::vector<double>& out) const {
  auto it = std::upper_bound(t_.begin(), t_.end(), t0_s);
  for (; it != t_.end() && *it <= t1_s; ++it) {
    if (jump_before_[static_cast<std::size_t>(it - t_.begin())]) out.push_back(*it);
  }
}

}  // namespace alphainv
