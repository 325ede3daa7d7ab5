#pragma once
/// \file rt/alpha_estimator.hpp
/// Streaming α-invariant estimator for the 1 kHz tick: one command sample in, (v, v̇, v̈, α) out.
///
/// Filtering. The command v is passed through a 3rd-order Butterworth low-pass filter realised in
/// state-variable (phase-variable) form, so its three states are exactly the filtered command w and
/// its first two time derivatives ẇ, ẅ:
///     w''' + 2ωc w'' + 2ωc² w' + ωc³ w = ωc³ v,
/// discretised exactly for an input that is linear between samples (first-order hold; matrix
/// exponential, computed once in the constructor). α is then eq. (33) applied to the filtered
/// signal: α̂ = ẇ² − w·ẅ. A zero-order hold would be simpler but its staircase ripple, amplified
/// twice by differentiation, biases α̂ of slow sines by several per cent; the linear hold's
/// interpolation error is smaller by a factor of about ωT/4.
///
/// Why this filter: for a sine v = A sin(ωt), w is a sine of amplitude |H(ω)|·A, and α of any sine is
/// its amplitude² × ω², independent of its phase. So the filter's phase lag does not bias α̂ in the
/// sinusoidal steady state; only its magnitude does: α̂ = |H(ω)|²·A²ω² with |H|² = 1/(1 + (ω/ωc)⁶)
/// (times the hold's gain, sinc⁴(ωT/2) < 2e-4 below 10 Hz at 1 kHz). With the default ωc = 2π·25 Hz
/// the bias is below 0.5 % up to 10 Hz. The price is delay (group delay at DC 2/ωc, 12.7 ms at the
/// default; the estimate refers to the instant of the newest sample) and noise gain, which grows as
/// ωc^2.5 for ẅ: see noise_gain().
///
/// Real-time: construction allocates nothing on the heap either, but may throw on bad settings, so
/// construct outside the loop; update() and reset() are noexcept, allocate nothing, take no locks
/// and do no I/O. Fixed-size storage: the filter state is the whole history.

#include <cmath>

#include <Eigen/Core>
#include <unsupported/Eigen/MatrixFunctions>

#include "alphainv/error.hpp"

namespace alphainv::rt {

/// Settings of the streaming α estimator.
struct AlphaEstimatorConfig {
  double sample_period_s = 1e-3;  ///< tick period T [s]
  double cutoff_hz = 25.0;        ///< Butterworth cut-off fc [Hz]; must be < 0.25 / T
};

/// One estimate: the filtered command and its derivatives, and α̂ = v̇² − v·v̈ (eq. (33)).
struct AlphaEstimate {
  double v = 0.0;       ///< filtered command [command unit]
  double v_dot = 0.0;   ///< its derivative [unit/s]
  double v_ddot = 0.0;  ///< its second derivative [unit/s²]
  double alpha = 0.0;   ///< α̂ [unit²/s²]
};

/// Standard deviation of each output per unit standard deviation of white noise on the input.
struct AlphaNoiseGain {
  double v = 0.0;       ///< [1]
  double v_dot = 0.0;   ///< [1/s]
  double v_ddot = 0.0;  ///< [1/s²]
};

/// Streaming α estimator (see file comment). Not thread-safe; one instance per loop.
class AlphaEstimator {
 public:
  /// Builds the discrete filter. Throws alphainv::Error if T ≤ 0 or fc is not in (0, 0.25/T).
  explicit AlphaEstimator(const AlphaEstimatorConfig& config = {}) : config_(config) {
    const double T = config.sample_period_s;
    if (!(T > 0.0) || !std::isfinite(T)) {
      throw Error("expected a positive, finite sample period [s], got " + std::to_string(T), {}, 0,
                  "sample_period_s");
    }
    if (!(config.cutoff_hz > 0.0) || !(config.cutoff_hz < 0.25 / T)) {
      throw Error("expected 0 < cutoff_hz < " + std::to_string(0.25 / T) + " Hz, got " +
                      std::to_string(config.cutoff_hz),
                  {}, 0, "cutoff_hz");
    }
    wc_ = 2.0 * 3.14159265358979323846 * config.cutoff_hz;
    // Continuous companion form, states (w, w', w''), augmented with the input u and its slope u'
    // (constant over a period): the first-order-hold discretisation.
    Eigen::Matrix<double, 5, 5> m = Eigen::Matrix<double, 5, 5>::Zero();
    m(0, 1) = 1.0;
    m(1, 2) = 1.0;
    m(2, 0) = -wc_ * wc_ * wc_;
    m(2, 1) = -2.0 * wc_ * wc_;
    m(2, 2) = -2.0 * wc_;
    m(2, 3) = wc_ * wc_ * wc_;
    m(3, 4) = 1.0;
    const Eigen::Matrix<double, 5, 5> e = (m * T).exp();
    ad_ = e.topLeftCorner<3, 3>();
    bd_ = e.block<3, 1>(0, 3);       // effect of u at the period's start
    bs_ = e.block<3, 1>(0, 4) / T;   // effect of the increment (u_next − u) over the period
    warmup_ticks_ = static_cast<long>(std::ceil(20.0 / (wc_ * T)));
  }

  /// Sets the filter to the steady state of a constant command v0 (v̇ = v̈ = 0). Real-time safe.
  void reset(double v0 = 0.0) noexcept {
    x_ = Eigen::Vector3d(v0, 0.0, 0.0);
    u_prev_ = v0;
    ticks_ = 0;
  }

  /// Feeds the newest command sample and returns the estimate at its instant (the input is taken
  /// as linear between the previous sample and this one). Real-time safe: noexcept, no allocation,
  /// no locks, no I/O.
  AlphaEstimate update(double v) noexcept {
    x_ = ad_ * x_ + bd_ * u_prev_ + bs_ * (v - u_prev_);
    u_prev_ = v;
    if (ticks_ < warmup_ticks_) ++ticks_;
    return AlphaEstimate{x_(0), x_(1), x_(2), x_(1) * x_(1) - x_(0) * x_(2)};
  }

  /// True once enough ticks have passed for a start-up transient to decay below ~1e-4 (20/ωc).
  bool warmed_up() const noexcept { return ticks_ >= warmup_ticks_; }
  /// Ticks needed to warm up.
  long warmup_ticks() const noexcept { return warmup_ticks_; }
  /// Group delay at low frequency [s]: 2/ωc (the linear hold adds none).
  double delay_s() const noexcept { return 2.0 / wc_; }
  /// |H(f)|² of the filter: the factor by which α̂ under-reads a sine of frequency f.
  double alpha_gain(double freq_hz) const noexcept {
    const double r = 2.0 * 3.14159265358979323846 * freq_hz / wc_;
    return 1.0 / (1.0 + r * r * r * r * r * r);
  }
  /// Noise gains from the discrete impulse response (sum of squares to convergence). Not real-time
  /// (loops a few thousand times); call at set-up.
  AlphaNoiseGain noise_gain() const noexcept {
    // Impulse response to a unit sample: with the linear hold, a unit sample at k enters as u_next
    // in step k (bs_) and as u_prev in step k+1 (bd_ − bs_).
    Eigen::Vector3d h = bs_;
    Eigen::Vector3d sum = h.cwiseProduct(h);
    h = ad_ * h + (bd_ - bs_);
    for (int k = 0; k < 200000; ++k) {
      sum += h.cwiseProduct(h);
      h = ad_ * h;
      if (h.cwiseAbs().maxCoeff() < 1e-300) break;
    }
    return AlphaNoiseGain{std::sqrt(sum(0)), std::sqrt(sum(1)), std::sqrt(sum(2))};
  }
  const AlphaEstimatorConfig& config() const noexcept { return config_; }

 private:
  AlphaEstimatorConfig config_;
  double wc_ = 0.0;
  Eigen::Matrix3d ad_ = Eigen::Matrix3d::Zero();
  Eigen::Vector3d bd_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d bs_ = Eigen::Vector3d::Zero();
  double u_prev_ = 0.0;
  Eigen::Vector3d x_ = Eigen::Vector3d::Zero();
  long ticks_ = 0;
  long warmup_ticks_ = 0;
};

}  // namespace alphainv::rt
