#include "alphainv/identify/residual_analysis.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace alphainv {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string fmt(const char* f, double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, x);
  return buf;
}

/// "1-25", "3, 7, 12-14": lags as ranges.
std::string lag_ranges(const std::vector<int>& lags) {
  std::string out;
  for (std::size_t i = 0; i < lags.size();) {
    std::size_t j = i;
    while (j + 1 < lags.size() && lags[j + 1] == lags[j] + 1) ++j;
    out += (out.empty() ? "" : ", ") + std::to_string(lags[i]);
    if (j > i) out += ".." + std::to_string(lags[j]);
    i = j + 1;
  }
  return out;
}

/// The figures from the sums (NaN where they are undefined).
FitFigures finish(FitFigures f) {
  if (f.n == 0) {
    f.rms = f.max_abs = f.fit_percent = f.relative_error = kNaN;
    return f;
  }
  f.rms = std::sqrt(f.sum_squared_error / static_cast<double>(f.n));
  f.fit_percent = f.sum_squared_deviation > 0.0
                      ? 100.0 * (1.0 - std::sqrt(f.sum_squared_error / f.sum_squared_deviation))
                      : kNaN;
  f.relative_error = f.sum_squared > 0.0 ? std::sqrt(f.sum_squared_error / f.sum_squared) : kNaN;
  return f;
}

}  // namespace

FitFigures fit_figures(const std::vector<double>& y, const std::vector<double>& y_hat,
                       std::size_t begin, std::size_t end) {
  FitFigures f;
  end = std::min({end, y.size(), y_hat.size()});
  double sum_y = 0.0;
  for (std::size_t k = begin; k < end; ++k) {
    if (!std::isfinite(y[k]) || !std::isfinite(y_hat[k])) continue;
    sum_y += y[k];
    ++f.n;
  }
  if (f.n == 0) return finish(f);
  const double mean = sum_y / static_cast<double>(f.n);
  for (std::size_t k = begin; k < end; ++k) {
    if (!std::isfinite(y[k]) || !std::isfinite(y_hat[k])) continue;
    const double e = y[k] - y_hat[k];
    f.sum_squared_error += e * e;
    f.sum_squared_deviation += (y[k] - mean) * (y[k] - mean);
    f.sum_squared += y[k] * y[k];
    f.max_abs = std::max(f.max_abs, std::abs(e));
  }
  return finish(f);
}

FitFigures pooled_fit_figures(const std::vector<FitFigures>& runs) {
  FitFigures p;
  for (const FitFigures& r : runs) {
    if (r.n == 0) continue;
    p.n += r.n;
    p.sum_squared_error += r.sum_squared_error;
    p.sum_squared_deviation += r.sum_squared_deviation;
    p.sum_squared += r.sum_squared;
    p.max_abs = std::max(p.max_abs, r.max_abs);
  }
  return finish(p);
}

double normal_quantile(double p) {
  if (!(p > 0.0 && p < 1.0)) return kNaN;
  // Acklam's rational approximation of the inverse normal CDF.
  static const double a[] = {-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
                             1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static const double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                             6.680131188771972e+01,  -1.328068155288572e+01};
  static const double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                             -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static const double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                             3.754408661907416e+00};
  const double lo = 0.02425;
  if (p < lo) {
    const double q = std::sqrt(-2.0 * std::log(p));
    return (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
           ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
  }
  if (p > 1.0 - lo) return -normal_quantile(1.0 - p);
  const double q = p - 0.5, r = q * q;
  return (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
         (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0);
}

double chi2_quantile(double dof, double p) {
  if (!(dof > 0.0)) return kNaN;
  const double z = normal_quantile(p);
  const double h = 2.0 / (9.0 * dof);
  const double x = 1.0 - h + z * std::sqrt(h);
  return dof * x * x * x;  // Wilson–Hilferty
}

ResidualTests residual_tests(const std::vector<double>& e_in, const std::vector<double>& u_in,
                             const ResidualTestOptions& options) {
  ResidualTests t;
  const std::size_t m = options.max_lag;
  if (m == 0 || !(options.confidence > 0.0 && options.confidence < 1.0)) {
    t.message = "max_lag must be > 0 and confidence in (0, 1)";
    return t;
  }
  if (!u_in.empty() && u_in.size() != e_in.size()) {
    t.message = "the input has " + std::to_string(u_in.size()) + " samples, the residual " +
                std::to_string(e_in.size());
    return t;
  }
  std::size_t dec = options.decimation;
  if (dec == 0) {
    dec = 1;
    if (options.sample_period_s > 0.0) {
      const double k = 0.25 / (static_cast<double>(m) * options.sample_period_s);
      dec = static_cast<std::size_t>(std::max(1.0, std::round(k)));
    }
  }
  t.decimation = dec;
  std::vector<double> e, u;
  for (std::size_t k = 0; k < e_in.size(); k += dec) {
    if (!std::isfinite(e_in[k]) || (!u_in.empty() && !std::isfinite(u_in[k]))) {
      t.message = "a non-finite sample at " + std::to_string(k);
      return t;
    }
    e.push_back(e_in[k]);
    if (!u_in.empty()) u.push_back(u_in[k]);
  }
  const std::size_t n = e.size();
  t.n = n;
  if (n <= 4 * m) {
    t.message = std::to_string(n) + " samples after decimation by " + std::to_string(dec) +
                ": at least " + std::to_string(4 * m + 1) + " are needed for " + std::to_string(m) +
                " lags";
    return t;
  }
  auto demean = [](std::vector<double>& x) {
    double s = 0.0;
    for (double v : x) s += v;
    const double mean = s / static_cast<double>(x.size());
    for (double& v : x) v -= mean;
  };
  // R_xy(τ) = (1/n) Σ_k x_k·y_{k−τ}, τ ≥ 0 (the biased estimate, as resid uses).
  auto corr = [n](const std::vector<double>& x, const std::vector<double>& y, std::size_t tau) {
    double s = 0.0;
    for (std::size_t k = tau; k < n; ++k) s += x[k] * y[k - tau];
    return s / static_cast<double>(n);
  };
  demean(e);
  const double re0 = corr(e, e, 0);
  if (!(re0 > 0.0)) {
    t.message = "the residual is constant";
    return t;
  }
  const double z = normal_quantile(0.5 + 0.5 * options.confidence);
  const double nn = static_cast<double>(n);
  t.autocorrelation.resize(m + 1);
  for (std::size_t tau = 0; tau <= m; ++tau) t.autocorrelation[tau] = corr(e, e, tau) / re0;
  t.autocorrelation_bound = z / std::sqrt(nn);
  for (std::size_t tau = 1; tau <= m; ++tau) {
    const double r = t.autocorrelation[tau];
    t.ljung_box_q += r * r / (nn - static_cast<double>(tau));
    if (std::abs(r) > t.autocorrelation_bound) t.lags_outside_auto.push_back(static_cast<int>(tau));
  }
  t.ljung_box_q *= nn * (nn + 2.0);
  t.chi2_auto_limit = chi2_quantile(static_cast<double>(m), options.confidence);
  t.white = t.ljung_box_q <= t.chi2_auto_limit;
  if (!u.empty()) {
    demean(u);
    const double ru0 = corr(u, u, 0);
    if (ru0 > 0.0) {
      // Var ρ_eu(τ) ≈ (1/n)·Σ_k ρ_e(k)·ρ_u(k) when e and u are independent (resid's band).
      double p = 1.0;
      for (std::size_t k = 1; k <= m; ++k) p += 2.0 * t.autocorrelation[k] * (corr(u, u, k) / ru0);
      const double sigma = std::sqrt(std::max(p, 1.0) / nn);
      t.cross_correlation_bound = z * sigma;
      t.cross_correlation.resize(2 * m + 1);
      const double norm = std::sqrt(re0 * ru0);
      for (std::size_t i = 0; i <= 2 * m; ++i) {
        const int tau = static_cast<int>(i) - static_cast<int>(m);
        // τ ≥ 0: e against past inputs u_{k−τ}; τ < 0: against future inputs.
        const double r = (tau >= 0 ? corr(e, u, static_cast<std::size_t>(tau))
                                   : corr(u, e, static_cast<std::size_t>(-tau))) /
                         norm;
        t.cross_correlation[i] = r;
        t.cross_q += (r / sigma) * (r / sigma);
        if (std::abs(r) > t.cross_correlation_bound) t.lags_outside_cross.push_back(tau);
      }
      t.chi2_cross_limit = chi2_quantile(static_cast<double>(2 * m + 1), options.confidence);
      t.input_correlated = t.cross_q > t.chi2_cross_limit;
    }
  }
  t.valid = true;
  return t;
}

std::string ResidualTests::verdict() const {
  if (!valid) return "residual tests not run: " + message;
  std::string out;
  const std::string lags_auto =
      lags_outside_auto.empty() ? "no lag" : "lags " + lag_ranges(lags_outside_auto);
  if (white) {
    out = "residual white (Q " + fmt("%.3g", ljung_box_q) + " <= " + fmt("%.3g", chi2_auto_limit) +
          "; " + lags_auto + " outside ±" + fmt("%.2g", autocorrelation_bound) +
          "): no evidence of missed dynamics";
  } else {
    out = "residual not white (Q " + fmt("%.3g", ljung_box_q) + " > " + fmt("%.3g", chi2_auto_limit) +
          "; " + lags_auto + " outside ±" + fmt("%.2g", autocorrelation_bound) +
          "): the model misses dynamics";
  }
  if (cross_correlation.empty()) return out;
  if (input_correlated) {
    out += "; correlated with the input (Q " + fmt("%.3g", cross_q) + " > " +
           fmt("%.3g", chi2_cross_limit) + "; lags " + lag_ranges(lags_outside_cross) + " outside ±" +
           fmt("%.2g", cross_correlation_bound) + "): the model misses input dynamics";
  } else {
    out += "; uncorrelated with the input (Q " + fmt("%.3g", cross_q) + " <= " +
           fmt("%.3g", chi2_cross_limit) + ")";
  }
  return out;
}

}  // namespace alphainv
