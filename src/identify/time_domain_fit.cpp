#include "alphainv/identify/time_domain_fit.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "alphainv/error.hpp"
#include "alphainv/identify/fit_report.hpp"
#include "alphainv/identify/output_error.hpp"
#include "alphainv/model/detail/field_checks.hpp"
#include "alphainv/model/plant_input.hpp"
#include "alphainv/simulate/known_inputs.hpp"

namespace alphainv {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
/// An estimate is identifiable with a relative SE up to this (the sine branch's threshold) …
constexpr double kIdentifiableRelativeSe = 0.10;
/// … and no correlation with another estimate above this (beyond it the data fix only a
/// combination of the two).
constexpr double kIdentifiableCorrelation = 0.95;

/// The output-error problem of `runs` with the model built by `model`.
OutputErrorProblem make_problem(const std::vector<TimeDomainRun>& runs,
                                const TimeDomainFitOptions& options) {
  OutputErrorProblem pr;
  for (const auto& r : runs) pr.runs.push_back({r.data, r.controller, 1.0, {}, {}});
  pr.simulation = options.simulation;
  pr.max_residuals_per_run = options.max_residuals_per_run;
  return pr;
}

/// Breakpoint quantile levels for N breakpoints: α0 = 0, then levels from 0.5 to 0.95 spaced
/// geometrically in 1 − level (more resolution where α is large and sparse).
std::vector<double> quantile_levels(std::size_t n) {
  std::vector<double> lv;
  if (n < 2) return lv;
  if (n == 2) return {0.9};
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double x = static_cast<double>(k) / static_cast<double>(n - 2);
    lv.push_back(1.0 - 0.5 * std::pow(0.1, x));
  }
  return lv;
}

/// "" when `options` are valid, else "invalid options: " and what validate() says.
std::string options_error(const TimeDomainFitOptions& options) {
  try {
    options.validate();
  } catch (const Error& e) {
    return std::string("invalid options: ") + e.what();
  }
  return {};
}

}  // namespace

void TimeDomainFitOptions::validate() const {
  if (n_breakpoints < 2 || n_breakpoints > kMaxBreakpoints) {
    detail::bad("TimeDomainFitOptions::n_breakpoints",
                "2 to " + std::to_string(kMaxBreakpoints) + " breakpoints",
                static_cast<double>(n_breakpoints));
  }
  detail::require_positive("TimeDomainFitOptions::smoothing_window_s", smoothing_window_s);
  if (max_residuals_per_run < 1) {
    detail::bad("TimeDomainFitOptions::max_residuals_per_run", "at least 1 residual per run", 0.0);
  }
  validate_effects(effects, "TimeDomainFitOptions::effects.");
}

void local_quadratic_derivatives(const std::vector<double>& t, const std::vector<double>& y,
                                 double half_window_s, std::vector<double>& dy,
                                 std::vector<double>& ddy) {
  const std::size_t n = std::min(t.size(), y.size());
  dy.assign(n, 0.0);
  ddy.assign(n, 0.0);
  if (n < 3) return;
  std::size_t lo = 0, hi = 0;
  for (std::size_t k = 0; k < n; ++k) {
    while (lo < k && t[k] - t[lo] > half_window_s && k - lo > 2) ++lo;
    if (hi < k) hi = k;
    while (hi + 1 < n && (t[hi + 1] - t[k] <= half_window_s || hi - k < 2)) ++hi;
    // Normal equations of y ≈ a + b·x + c·x², x = (t − t_k)/s scaled for conditioning.
    const double s = std::max(t[hi] - t[lo], 1e-12);
    Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
    Eigen::Vector3d aty = Eigen::Vector3d::Zero();
    for (std::size_t j = lo; j <= hi; ++j) {
      const double x = (t[j] - t[k]) / s;
      const Eigen::Vector3d row(1.0, x, x * x);
      ata += row * row.transpose();
      aty += row * y[j];
    }
    const Eigen::Vector3d c = ata.ldlt().solve(aty);
    dy[k] = c(1) / s;
    ddy[k] = 2.0 * c(2) / (s * s);
  }
}

std::vector<double> alpha_of_command(const std::vector<double>& t, const std::vector<double>& v,
                                     double half_window_s) {
  std::vector<double> dv, ddv;
  local_quadratic_derivatives(t, v, half_window_s, dv, ddv);
  std::vector<double> a(dv.size());
  for (std::size_t k = 0; k < a.size(); ++k) a[k] = dv[k] * dv[k] - v[k] * ddv[k];  // eq. (33)
  return a;
}

TimeDomainLinearFit fit_linear_time_domain(const std::vector<TimeDomainRun>& runs,
                                           const TimeDomainFitOptions& options) {
  TimeDomainLinearFit out;
  if (runs.empty()) {
    out.message = "no runs";
    return out;
  }
  out.message = options_error(options);
  if (!out.message.empty()) return out;
  // Stage 1: θ̈ = −C·θ̇ + β̃·u, u = v through the known effects (inverse dynamics, least squares).
  Eigen::Matrix2d ata = Eigen::Matrix2d::Zero();
  Eigen::Vector2d aty = Eigen::Vector2d::Zero();
  std::size_t used = 0;
  for (const auto& run : runs) {
    const RunData& d = *run.data;
    const KnownInputSeries known = KnownInputSeries::of_run(d);
    std::vector<double> dth, ddth;
    local_quadratic_derivatives(d.t, d.theta, options.smoothing_window_s, dth, ddth);
    std::vector<double> memory(discovered_memory_active(options.effects) ? d.size() : 0);
    discovered_memory_torque_along(options.effects, d.t.data(), dth.data(), memory.size(), memory.data());
    for (std::size_t k = 0; k < d.size(); ++k) {
      // u of plant_input.hpp at the sample (the delay is left to the output-error stage), with a
      // discovered term's memory terms run along the record (effect_torque() has no state).
      const double u = plant_input(options.effects, d.t[k], d.v[k], d.theta[k], dth[k],
                                   known.at_sample(k)) +
                       (memory.empty() ? 0.0 : memory[k]);
      const Eigen::Vector2d row(-dth[k], u);
      if (!row.allFinite() || !std::isfinite(ddth[k])) continue;
      ata += row * row.transpose();
      aty += row * ddth[k];
      ++used;
    }
  }
  const Eigen::Vector2d x = ata.ldlt().solve(aty);
  out.c_equation_error = x(0);
  out.beta_tilde_equation_error = x(1);
  if (used < 10 || !x.allFinite() || !(x(1) > 0.0)) {
    out.message = "the equation-error start failed (β̃ = " + std::to_string(x(1)) +
                  "): the runs do not excite the joint";
    return out;
  }
  // A negative C from noisy derivatives: start from a light damping instead.
  const double c0 = x(0) > 0.0 ? x(0) : 0.1 * std::sqrt(x(1));
  const double b0 = x(1);

  // Stage 2: output error on C, β̃.
  OutputErrorProblem pr = make_problem(runs, options);
  pr.parameters = {{"c_linear", c0, c0 / 100.0, c0 * 100.0},
                   {"beta_tilde_linear", b0, b0 / 100.0, b0 * 100.0}};
  const Effects fx = options.effects;
  pr.model = [fx](const double* p, std::size_t) {
    JointModelAtPose m;
    m.use_alpha = false;
    m.c_linear = p[0];
    m.beta_tilde_linear = p[1];
    m.effects = fx;
    return m;
  };
  OutputErrorOptions oo;
  oo.threads = options.threads;
  oo.extra_starts = {{c0 * 3.0, b0}, {c0 / 3.0, b0}};
  const OutputErrorResult r = fit_output_error(pr, oo);
  if (!r.ok) {
    out.message = "output error fit failed: " + r.message;
    return out;
  }
  out.c_linear = r.values[0];
  out.beta_tilde_linear = r.values[1];
  out.c_se = r.standard_errors[0];
  out.beta_tilde_se = r.standard_errors[1];
  out.rms = r.rms;
  out.ok = true;
  out.message = r.message;
  return out;
}

TimeDomainAlphaFit fit_alpha_time_domain(const std::vector<TimeDomainRun>& runs,
                                         const TimeDomainLinearFit& start,
                                         const TimeDomainFitOptions& options) {
  TimeDomainAlphaFit out;
  const std::size_t n = options.n_breakpoints;
  if (!start.ok) {
    out.message = "no linear model to start from";
    return out;
  }
  out.message = options_error(options);
  if (!out.message.empty()) return out;
  // Breakpoints at quantiles of the positive α of the commands.
  std::vector<double> alphas;
  for (const auto& run : runs) {
    const auto a = alpha_of_command(run.data->t, run.data->v, options.smoothing_window_s);
    for (double x : a) {
      if (x > 0.0 && std::isfinite(x)) alphas.push_back(x);
    }
  }
  if (alphas.size() < 10 * n) {
    out.message = "too few samples with α > 0 to place breakpoints";
    return out;
  }
  std::sort(alphas.begin(), alphas.end());
  out.alpha_max = alphas.back();
  AlphaModel model;
  model.n_breakpoints = n;
  model.alpha[0] = 0.0;
  const std::vector<double> levels = quantile_levels(n);
  for (std::size_t k = 1; k < n; ++k) {
    const auto idx = static_cast<std::size_t>(levels[k - 1] * static_cast<double>(alphas.size() - 1));
    model.alpha[k] = std::max(alphas[idx], model.alpha[k - 1] * 1.01 + 1e-12);
  }
  model.beta_alpha = {0.0, model.alpha[n - 1]};

  OutputErrorProblem pr = make_problem(runs, options);
  const double c0 = start.c_linear, b0 = start.beta_tilde_linear;
  for (std::size_t k = 0; k < n; ++k)
    pr.parameters.push_back({"C_" + std::to_string(k), c0, c0 / 50.0, c0 * 50.0});
  pr.parameters.push_back({"beta_tilde_0", b0, b0 / 50.0, b0 * 50.0});
  pr.parameters.push_back({"beta_tilde_1", b0, b0 / 50.0, b0 * 50.0});
  const Effects fx = options.effects;
  pr.model = [model, n, fx](const double* p, std::size_t) {
    JointModelAtPose m;
    m.use_alpha = true;
    m.inertia = 1.0;
    m.alpha = model;
    for (std::size_t k = 0; k < n; ++k) m.alpha.c_n1[k] = 1.0 / p[k];  // eq. (40) with I = 1
    m.alpha.beta_n1 = {1.0 / p[n], 1.0 / p[n + 1]};                   // eq. (42) with I = 1
    m.c_linear = p[0];                 // start of the fixed point (45)
    m.beta_tilde_linear = p[n];
    m.effects = fx;
    return m;
  };
  OutputErrorOptions oo;
  oo.threads = options.threads;
  const OutputErrorResult r = fit_output_error(pr, oo);
  if (!r.ok) {
    out.message = "output error fit failed: " + r.message;
    return out;
  }
  out.model = model;
  for (std::size_t k = 0; k < n; ++k) {
    out.model.c_n1[k] = 1.0 / r.values[k];
    out.c_se[k] = r.standard_errors[k];
  }
  out.model.beta_n1 = {1.0 / r.values[n], 1.0 / r.values[n + 1]};
  out.beta_tilde_se = {r.standard_errors[n], r.standard_errors[n + 1]};
  // Identifiability from the SEs and the correlations of the estimates (the parameters are C_0 …
  // C_{N−1}, β̃_0, β̃_1 in that order).
  const std::size_t np = n + 2;
  for (std::size_t j = 0; j < np; ++j) {
    double worst = std::numeric_limits<double>::quiet_NaN();
    if (r.correlations.size() == np * np) {
      worst = 0.0;
      for (std::size_t i = 0; i < np; ++i) {
        if (i != j) worst = std::max(worst, std::abs(r.correlations[j * np + i]));
      }
    }
    out.max_abs_correlation[j] = worst;
    const double rel = r.standard_errors[j] / std::abs(r.values[j]);
    const bool ok = rel <= kIdentifiableRelativeSe && worst <= kIdentifiableCorrelation;
    if (j < n) out.c_identifiable[j] = ok;
    else out.beta_tilde_identifiable[j - n] = ok;
  }
  out.rms = r.rms;
  out.ok = out.model.valid();
  out.message = out.ok ? r.message : "the fitted α-model is not valid";
  return out;
}

std::string TimeDomainLinearFit::brief_report() const {
  if (!ok) return "time-domain linear fit: NOT usable: " + message;
  return "time-domain linear fit: usable, C = " + report_number(c_linear) + " ± " +
         report_number(c_se, "%.2g") + " 1/s, β̃ = " + report_number(beta_tilde_linear) + " ± " +
         report_number(beta_tilde_se, "%.2g") + ", RMS of θ − θ_sim " + report_number(rms);
}

std::string TimeDomainLinearFit::full_report() const {
  std::string out = brief_report() + "\n";
  out += "  equation-error start: C = " + report_number(c_equation_error) + " 1/s, β̃ = " +
         report_number(beta_tilde_equation_error) + "\n";
  if (ok) out += "  " + message + "\n";
  return out;
}

std::string TimeDomainAlphaFit::brief_report() const {
  if (!ok) return "time-domain α fit: NOT usable: " + message;
  return "time-domain α fit: usable, N = " + std::to_string(model.n_breakpoints) +
         " breakpoints up to α = " + report_number(model.alpha[model.n_breakpoints - 1]) +
         " (the commands reach " + report_number(alpha_max) + "), RMS of θ − θ_sim " +
         report_number(rms);
}

std::string TimeDomainAlphaFit::full_report() const {
  std::string out = brief_report() + "\n";
  if (!ok) return out;
  for (std::size_t k = 0; k < model.n_breakpoints; ++k) {
    out += "  α_" + std::to_string(k) + " = " + report_number(model.alpha[k]) + ": C_" +
           std::to_string(k) + " = " + report_number(1.0 / model.c_n1[k]) + " ± " +
           report_number(c_se[k], "%.2g") + " 1/s\n";
  }
  for (std::size_t k = 0; k < 2; ++k) {
    out += "  β̃_" + std::to_string(k) + " = " + report_number(1.0 / model.beta_n1[k]) + " ± " +
           report_number(beta_tilde_se[k], "%.2g") + " at α = " +
           report_number(model.beta_alpha[k]) + "\n";
  }
  out += "  " + message + "\n";
  return out;
}

}  // namespace alphainv
