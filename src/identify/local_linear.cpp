#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>

#include "alphainv/identify/local_linear.hpp"

namespace alphainv {

double SineFit::amplitude() const { return std::hypot(a1, a2); }
double SineFit::phase_rad() const { return std::atan2(a1, a2); }

SineFit fit_sine(const double* t_s, const double* y, std::size_t n, double omega_rad_s,
                 bool fit_offset) {
  SineFit fit;
  fit.omega_rad_s = omega_rad_s;
  fit.n = n;
  const Eigen::Index cols = fit_offset ? 3 : 2;
  if (n < static_cast<std::size_t>(cols) + 1 || !(omega_rad_s > 0.0)) return fit;
  // Normal equations of (15), accumulated (n can be large; the system is tiny).
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < n; ++k) {
    const double wt = omega_rad_s * t_s[k];
    const Eigen::Vector3d row(std::cos(wt), std::sin(wt), fit_offset ? 1.0 : 0.0);
    ata += row * row.transpose();
    atb += row * y[k];
  }
  if (!fit_offset) ata(2, 2) = 1.0;
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(ata);
  if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-12)) return fit;
  const Eigen::Vector3d x = ldlt.solve(atb);
  fit.a1 = x(0);
  fit.a2 = x(1);
  fit.offset = fit_offset ? x(2) : 0.0;
  double ss = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double wt = omega_rad_s * t_s[k];
    const double e = y[k] - (fit.a1 * std::cos(wt) + fit.a2 * std::sin(wt) + fit.offset);
    ss += e * e;
  }
  fit.rms_residual = std::sqrt(ss / static_cast<double>(n));
  fit.valid = std::isfinite(fit.a1) && std::isfinite(fit.a2);
  return fit;
}

SineFit fit_sine(const std::vector<double>& t_s, const std::vector<double>& y, double omega_rad_s,
                 bool fit_offset) {
  const std::size_t n = std::min(t_s.size(), y.size());
  return fit_sine(t_s.data(), y.data(), n, omega_rad_s, fit_offset);
}

IndexRange steady_state_window(const std::vector<double>& t_s, double freq_hz, double settle_s) {
  IndexRange range;
  if (t_s.size() < 2 || !(freq_hz > 0.0)) return range;
  const double period_s = 1.0 / freq_hz;
  const double t_end = t_s.back();
  const double t_start_min = t_s.front() + std::max(0.0, settle_s);
  const double available = t_end - t_start_min;
  const double cycles = std::floor(available / period_s + 1e-9);
  if (cycles < 1.0) return range;
  const double t_begin = t_end - cycles * period_s;
  const auto first = std::lower_bound(t_s.begin(), t_s.end(), t_begin - 1e-12);
  range.begin = static_cast<std::size_t>(first - t_s.begin());
  range.end = t_s.size();
  return range;
}

std::complex<double> sampled_loop_shape(double c_per_s, double omega_rad_s,
                                        double sample_period_s) {
  using cd = std::complex<double>;
  const double t = sample_period_s, x = c_per_s * t;
  const double e = std::exp(-x);
  // n1 = (x − 1 + e^{−x})/C², n0 = (1 − e^{−x} − x e^{−x})/C²: both ≈ T²/2 and cancel badly for
  // small x, so use their Taylor series there (error < x³T² ≈ 1e-12 T²).
  double n1, n0;
  if (std::abs(x) < 1e-4) {
    n1 = t * t * (0.5 - x / 6.0 + x * x / 24.0);
    n0 = t * t * (0.5 - x / 3.0 + x * x / 8.0);
  } else {
    const double c2 = c_per_s * c_per_s;
    n1 = (x + std::expm1(-x)) / c2;
    n0 = (-std::expm1(-x) - x * e) / c2;
  }
  const cd z = std::polar(1.0, omega_rad_s * t);
  return (n1 * z + n0) / ((z - 1.0) * (z - e));
}

bool sampled_loop_c_beta(double omega_rad_s, double a1, double a2, double ar,
                         double sample_period_s, double& c_per_s, double& beta_per_s2) {
  using cd = std::complex<double>;
  const double w = omega_rad_s, t = sample_period_s;
  // First order (ZOH ≈ delay T/2): C_cont = (C − ω²T/2)/(1 + CT/2), β_cont = β/(1 + CT/2),
  // inverted. Also the fallback.
  const double den = a1 * a1 + a2 * (a2 - ar);
  const double c_cont = -w * ar * a1 / den;                    // eq. (19)
  const double beta_cont = w * w * (a1 * a1 + a2 * a2) / den;  // eq. (20)
  const double c_first = (c_cont + w * w * t / 2.0) / (1.0 - c_cont * t / 2.0);
  c_per_s = c_first;
  beta_per_s2 = beta_cont * (1.0 + c_first * t / 2.0);
  if (!(t > 0.0) || !(w > 0.0) || !std::isfinite(c_first) || !(c_first > 0.0)) return false;
  // Measured loop gain: H = θ/r = (A2 + jA1)/Ar at the samples (θ = Im(H Ar e^{jωt})), L = H/(1 −
  // H).
  const cd h = cd(a2, a1) / ar;
  const cd l = h / (1.0 - h);
  // Residual: the phase of L/g(C), wrapped; zero at the plant's C. It increases with C (for the
  // continuous loop it is atan2(ω, C) − π/2 + arg L), so Newton from the first-order estimate
  // converges in a few steps; the step is halved while the |residual| does not fall.
  auto residual = [&](double c) { return std::arg(l / sampled_loop_shape(c, w, t)); };
  double c = c_first, r = residual(c);
  bool converged = false;
  for (int it = 0; it < 50 && std::isfinite(r); ++it) {
    const double h_c = 1e-6 * std::max(1.0, std::abs(c));
    const double slope = (residual(c + h_c) - residual(c - h_c)) / (2.0 * h_c);
    if (!(std::abs(slope) > 0.0) || !std::isfinite(slope)) break;
    double step = -r / slope, c_next = c + step, r_next = residual(c_next);
    for (int half = 0; half < 30 && !(std::abs(r_next) < std::abs(r)); ++half) {
      step *= 0.5;
      c_next = c + step;
      r_next = residual(c_next);
    }
    c = c_next;
    r = r_next;
    if (std::abs(step) <= 1e-13 * std::max(1.0, std::abs(c)) || std::abs(r) < 1e-15) {
      converged = true;
      break;
    }
  }
  if (!converged || !(c > 0.0)) return false;
  const cd ratio = l / sampled_loop_shape(c, w, t);  // = β, real and positive at the root
  if (!(ratio.real() > 0.0) || !std::isfinite(ratio.real())) return false;
  c_per_s = c;
  beta_per_s2 = std::abs(ratio);
  return true;
}

LocalLinearPoint local_linear_point(double freq_hz, double a1, double a2, double ar, double kp,
                                    double sample_period_s) {
  LocalLinearPoint p;
  p.freq_hz = freq_hz;
  p.omega_rad_s = 2.0 * 3.14159265358979323846 * freq_hz;
  p.a1 = a1;
  p.a2 = a2;
  p.ar = ar;
  const double w = p.omega_rad_s;
  const double den = a1 * a1 + a2 * (a2 - ar);
  p.c_data_continuous = -w * ar * a1 / den;                            // eq. (19)
  p.beta_data_continuous = w * w * (a1 * a1 + a2 * a2) / den;          // eq. (20)
  p.alpha_data = kp * kp * w * w * (a1 * a1 + (ar - a2) * (ar - a2));  // eq. (36)
  p.c_data = p.c_data_continuous;
  p.beta_data = p.beta_data_continuous;
  p.a1_continuous = a1;
  p.a2_continuous = a2;
  // den ≤ 0: negative β_data whatever the loop (an "excessive" lag); such points are not inverted.
  // A small negative C_data with den > 0 can be the digital loop's bias (ω²T/2 > C) and is.
  const bool denominator_ok = den > 0.0 && std::isfinite(p.beta_data_continuous);
  if (sample_period_s > 0.0 && denominator_ok) {
    p.sample_period_s = sample_period_s;
    p.sampled_exact = sampled_loop_c_beta(w, a1, a2, ar, sample_period_s, p.c_data, p.beta_data);
    // The continuous loop (13) with the plant's C, β: θ/r = β/(β − ω² + jωC) = (A2 + jA1)/Ar.
    const std::complex<double> hc =
        ar * p.beta_data / std::complex<double>(p.beta_data - w * w, w * p.c_data);
    p.a1_continuous = hc.imag();
    p.a2_continuous = hc.real();
  }
  p.physical = denominator_ok && p.c_data > 0.0 && p.beta_data > 0.0 && std::isfinite(p.c_data) &&
               std::isfinite(p.beta_data);
  return p;
}

GlobalLinearFit global_linear_fit(const std::vector<LocalLinearPoint>& points, double kp) {
  GlobalLinearFit out;
  out.n_points = points.size();
  if (points.empty()) {
    out.message = "no sine points to fit";
    return out;
  }
  // eq. (22): rows [ω A2, A1] and [−ω A1, A2 − Ar] times [C, β] = [A1 ω², A2 ω²].
  // Note the sign of ω A1: substituting (14) into (13) gives −ω A1 C in the sine equation of (18);
  // the printed "+ω A1" contradicts (19), which is verified (paper-notes), so we follow (19).
  const Eigen::Index m = static_cast<Eigen::Index>(2 * points.size());
  Eigen::MatrixXd a(m, 2);
  Eigen::VectorXd b(m);
  for (std::size_t k = 0; k < points.size(); ++k) {
    const auto& p = points[k];
    const double w = p.omega_rad_s;
    const double a1 = p.a1_continuous, a2 = p.a2_continuous;  // = (a1, a2) for continuous data
    const Eigen::Index i = static_cast<Eigen::Index>(2 * k);
    a(i, 0) = w * a2;
    a(i, 1) = a1;
    b(i) = a1 * w * w;
    a(i + 1, 0) = -w * a1;
    a(i + 1, 1) = a2 - p.ar;
    b(i + 1) = a2 * w * w;
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
  if (qr.rank() < 2) {
    out.message = "the regression (22) is rank deficient";
    return out;
  }
  const Eigen::Vector2d x = qr.solve(b);
  out.c_linear = x(0);
  out.beta_linear = x(1);
  out.beta_tilde_linear = kp != 0.0 ? x(1) / kp : 0.0;
  out.rms_residual = std::sqrt((a * x - b).squaredNorm() / static_cast<double>(m));
  out.valid = std::isfinite(x(0)) && std::isfinite(x(1));
  if (out.valid && (x(0) <= 0.0 || x(1) <= 0.0)) {
    out.message = "non-physical global linear fit (C_linear or beta_linear <= 0); restrict the band";
  }
  return out;
}

}  // namespace alphainv
